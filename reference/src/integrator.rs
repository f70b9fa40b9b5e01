//! The path tracer: one function per path, and the tiled parallel loop.
//!
//! Unidirectional path tracing with BSDF sampling only (no light
//! sampling), as the Ray Tracing in One Weekend family does. `max_depth`
//! counts ray segments: a path traces at most `max_depth` rays and gets
//! nothing after the last (the book's `depth` argument).

use crate::background::evaluate_background;
use crate::film::{Film, PixelStats};
use crate::geometry::{spawn_origin, Ray};
use crate::material::{emitted, scatter, Material, TextureContext};
use crate::rng::{dims, vertex_randoms};
use crate::scene::{RenderSettings, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Russian roulette survival probability is the throughput's largest
/// component, capped so that bright paths still end sometimes (0.95:
/// pbrt-v4 uses the same cap).
pub const ROULETTE_MAX_SURVIVAL: f32 = 0.95;

/// Tile side in pixels for the parallel loop (order never changes results).
pub const TILE_SIZE: u32 = 16;

/// Traces one path and returns its radiance estimate.
pub fn trace_path(
    scene: &Scene,
    mut ray: Ray,
    settings: &RenderSettings,
    pixel: u32,
    sample: u32,
) -> Vec3 {
    let ctx = TextureContext {
        textures: scene.textures(),
        images: scene.images(),
    };
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    for segment in 0..settings.max_depth {
        let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
            radiance += throughput
                * evaluate_background(&scene.background(), scene.images(), ray.direction);
            break;
        };
        let si = scene.surface_interaction(&ray, &hit);
        let material = &scene.materials()[si.material as usize];
        if let Material::Dielectric { absorption, .. } = material {
            // Beer-Lambert over the segment just travelled inside.
            if !si.front_face && absorption.max_element() > 0.0 {
                throughput *= (-*absorption * hit.t).exp();
            }
        }
        radiance += throughput * emitted(material, ctx, &si);
        let u = vertex_randoms(settings.seed, pixel, sample, segment + 1);
        let Some(s) = scatter(material, ctx, ray.direction, &si, &u) else {
            break;
        };
        throughput *= s.weight;
        if segment + 1 >= settings.roulette_depth {
            let q = throughput.max_element().min(ROULETTE_MAX_SURVIVAL);
            if u[dims::ROULETTE] >= q {
                break;
            }
            throughput /= q;
        }
        let side = if s.direction.dot(si.geometric_normal) >= 0.0 {
            si.geometric_normal
        } else {
            -si.geometric_normal
        };
        ray = Ray::new(spawn_origin(si.p, side, si.p_error), s.direction);
    }
    radiance
}

/// The camera ray of one sample.
#[inline]
pub fn camera_ray(
    camera: &crate::camera::Camera,
    settings: &RenderSettings,
    x: u32,
    y: u32,
    sample: u32,
) -> Ray {
    let pixel = y * settings.width + x;
    let u = vertex_randoms(settings.seed, pixel, sample, 0);
    let film = Vec2::new(
        (x as f32 + u[dims::PIXEL_X]) / settings.width as f32,
        (y as f32 + u[dims::PIXEL_Y]) / settings.height as f32,
    );
    camera.generate_ray(film, Vec2::new(u[dims::LENS_U], u[dims::LENS_V]))
}

/// Renders `settings.spp` samples per pixel, samples `[first, first+spp)`.
/// Tiles run in parallel on rayon's current pool; `progress` is called
/// after each tile with the number of pixels done in it.
pub fn render(scene: &Scene, settings: &RenderSettings, progress: &(dyn Fn(u64) + Sync)) -> Film {
    let camera = scene.camera(settings.width, settings.height);
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE_SIZE);
    let tiles_y = h.div_ceil(TILE_SIZE);
    let tiles: Vec<(u32, Vec<PixelStats>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE_SIZE, (tile / tiles_x) * TILE_SIZE);
            let (x1, y1) = ((x0 + TILE_SIZE).min(w), (y0 + TILE_SIZE).min(h));
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut stats = PixelStats::default();
                    let pixel = y * w + x;
                    for sample in 0..settings.spp {
                        let ray = camera_ray(&camera, settings, x, y, sample);
                        stats.add(trace_path(scene, ray, settings, pixel, sample));
                    }
                    out.push(stats);
                }
            }
            progress(out.len() as u64);
            (tile, out)
        })
        .collect();
    let mut film = Film::new(w, h);
    for (tile, pixels) in tiles {
        let (x0, y0) = ((tile % tiles_x) * TILE_SIZE, (tile / tiles_x) * TILE_SIZE);
        let x1 = (x0 + TILE_SIZE).min(w);
        let tw = (x1 - x0) as usize;
        for (i, p) in pixels.into_iter().enumerate() {
            let (x, y) = (x0 + (i % tw) as u32, y0 + (i / tw) as u32);
            film.pixels[(y * w + x) as usize] = p;
        }
    }
    film
}
