//! The path tracers: one function per path, and the tiled parallel loop.
//!
//! Two estimators of the same integral ([`Integrator`]):
//! - `bsdf`: unidirectional path tracing with BSDF sampling only, as the
//!   Ray Tracing in One Weekend family does ([`trace_path`]);
//! - `mis`: the same paths plus next-event estimation at every vertex
//!   whose material has a density ([`crate::material::bsdf_eval`]): one
//!   light sample ([`crate::light`]) with a shadow ray, combined with the
//!   BSDF sample's emission by the power heuristic (Veach 1997, ch. 9);
//!   emission reached through a delta lobe's draw or a density-less
//!   vertex (glass, metal, a plastic's coat:
//!   [`crate::material::Scatter::density`]) and from the camera counts
//!   in full ([`trace_path_mis`]).
//!
//! Punctual lights (point, spot, directional) are delta lights, which no
//! BSDF sample can find: both estimators sample them by next-event
//! estimation at every vertex with a density, with weight 1 — `mis` from
//! its whole light set, `bsdf` from the set of the punctual lights alone
//! ([`LightSet::punctual_only`]; it has no other light sample). Area
//! emitters and the environment keep each estimator's own treatment.
//!
//! Both read the same vertex randoms in the same slots; the light sample
//! reads its own block ([`crate::rng::light_randoms`]). `max_depth`
//! counts ray segments: a path traces at most `max_depth` rays and gets
//! nothing after the last (the book's `depth` argument); the shadow ray of
//! a vertex counts with the segment that reached it, so both estimators
//! gather light over paths of the same lengths. A vertex shades with its
//! material's [`Wrappers`](crate::material::Wrappers) ([`wrapped_scatter`],
//! [`wrapped_bsdf_eval`]; a blend's two BSDFs, [`crate::material::Blend`]):
//! a pass through a mask is a delta draw and takes a segment, as in
//! Mitsuba's path integrator.

use crate::background::evaluate_background;
use crate::film::{Film, FilmSums, PixelSums};
use crate::filter::FilterTable;
use crate::geometry::{spawn_origin, Ray, SurfaceInteraction};
use crate::light::{is_punctual, punctual_tag, LightSet, ENV_PRIM, PUNCTUAL_PRIM};
use crate::material::{
    draw_density, emitted, wrapped_bsdf_eval, wrapped_scatter, Bsdf, Material, TextureContext,
};
use crate::mutants::{self, Mutant};
use crate::rng::{dims, light_dims, sampled_light_randoms, sampled_vertex_randoms};
use crate::scene::{RenderSettings, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;

/// Russian roulette survival probability is the throughput's largest
/// component, capped so that bright paths still end sometimes (0.95:
/// Mitsuba 3's path integrator caps at the same value; pbrt-v4 lets a
/// path whose throughput is 1 or more survive always).
pub const ROULETTE_MAX_SURVIVAL: f32 = 0.95;

/// Tile side in pixels for the parallel loop (order never changes results).
pub const TILE_SIZE: u32 = 16;

/// Traces one path with BSDF sampling (and next-event estimation of the
/// punctual lights of `lights`, [`LightSet::punctual_only`]) and returns
/// its radiance estimate.
pub fn trace_path(
    scene: &Scene,
    lights: &LightSet,
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
        let material = vertex_material(scene, si.material);
        let bsdf = vertex_bsdf(scene, material, si.material);
        throughput *= transmittance(material, &si, hit.t);
        radiance += throughput * emitted(scene.emission(si.material), ctx, &si);
        let u = sampled_vertex_randoms(settings.sampler, settings.seed, pixel, sample, segment + 1);
        // Delta lights, by next-event estimation as in `trace_path_mis`.
        if bsdf.has_density() && !lights.is_empty() && segment + 1 < settings.max_depth {
            let ul =
                sampled_light_randoms(settings.sampler, settings.seed, pixel, sample, segment + 1);
            radiance += throughput * next_event(scene, lights, ctx, bsdf, &ray, &si, &ul);
        }
        let Some(s) = wrapped_scatter(bsdf, ctx, ray.direction, &si, &u) else {
            break;
        };
        throughput *= s.weight;
        if !survives_roulette(&mut throughput, u[dims::ROULETTE], segment, settings) {
            break;
        }
        ray = Ray::new(spawn_toward(&si, s.direction), s.direction);
    }
    radiance
}

/// The BSDF of material `id` at a path vertex: the scene's (emission,
/// [`Scene::emission`], is read apart from it and adds to it).
#[inline]
fn vertex_material(scene: &Scene, id: u32) -> &Material {
    /// What [`Mutant::EmissiveBsdfDropped`] leaves of an emissive
    /// material's BSDF: none (it absorbs; its emission is still read).
    const ABSORBER: Material = Material::DiffuseLight { emission: 0 };
    if mutants::is(Mutant::EmissiveBsdfDropped) && scene.added_emission(id).is_some() {
        return &ABSORBER;
    }
    &scene.materials()[id as usize]
}

/// The BSDF of material `id` at a path vertex, `material` its model
/// ([`vertex_material`]), with its wrappers and a blend's second BSDF.
#[inline]
fn vertex_bsdf<'a>(scene: &'a Scene, material: &'a Material, id: u32) -> Bsdf<'a> {
    let wrap = scene.wrappers(id);
    Bsdf {
        material,
        wrap,
        second: wrap.blend.map(|b| {
            (
                &scene.materials()[b.second as usize],
                scene.wrappers(b.second).one_sided,
            )
        }),
    }
}

/// Beer-Lambert transmittance over a segment of length `t` that ended on
/// the inside of an absorbing dielectric (1 elsewhere).
#[inline]
fn transmittance(material: &Material, si: &SurfaceInteraction, t: f32) -> Vec3 {
    match material {
        Material::Dielectric { absorption, .. }
            if !si.front_face && absorption.max_element() > 0.0 =>
        {
            (-*absorption * t).exp()
        }
        _ => Vec3::ONE,
    }
}

/// The origin of a ray leaving `si` toward `direction`: offset to the side
/// of the geometric normal the direction points to.
#[inline]
pub fn spawn_toward(si: &SurfaceInteraction, direction: Vec3) -> Vec3 {
    let side = if direction.dot(si.geometric_normal) >= 0.0 {
        si.geometric_normal
    } else {
        -si.geometric_normal
    };
    spawn_origin(si.p, side, si.p_error)
}

/// Russian roulette after vertex `segment`: from `roulette_depth` on, the
/// path survives with probability `q` (the throughput's largest component,
/// capped) and its throughput is divided by `q`. Returns whether it does.
#[inline]
fn survives_roulette(
    throughput: &mut Vec3,
    u: f32,
    segment: u32,
    settings: &RenderSettings,
) -> bool {
    if segment + 1 < settings.roulette_depth {
        return true;
    }
    let q = throughput.max_element().min(ROULETTE_MAX_SURVIVAL);
    if u >= q {
        return false;
    }
    *throughput /= q;
    true
}

/// Which estimator a render uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// BSDF sampling only.
    #[default]
    Bsdf,
    /// BSDF sampling and light sampling, combined by MIS.
    Mis,
}

impl Integrator {
    pub const ALL: [Integrator; 2] = [Integrator::Bsdf, Integrator::Mis];

    pub fn name(self) -> &'static str {
        match self {
            Integrator::Bsdf => "bsdf",
            Integrator::Mis => "mis",
        }
    }
}

/// The power heuristic with exponent 2: the weight of a sample drawn with
/// density `a` when the other strategy would have drawn it with `b`,
/// `a² / (a² + b²)`, computed as `1 / (1 + (b/a)²)` so that it neither
/// underflows nor overflows, and exactly 1 where the other strategy cannot
/// make the sample (`b = 0`; a division `a²/a²` is not exact on every GPU,
/// and the white furnace must stay exact under MIS).
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if (b == 0.0 && a > 0.0) || a.is_infinite() {
        return 1.0;
    }
    if a.is_nan() || a <= 0.0 {
        return 0.0;
    }
    let r = b / a;
    let r2 = r * r;
    // `b` far larger than `a`, or undefined: the other strategy's sample.
    if !r2.is_finite() {
        return 0.0;
    }
    1.0 / (1.0 + r2)
}

/// Traces one path with next-event estimation and MIS (see the module
/// documentation) and returns its radiance estimate.
pub fn trace_path_mis(
    scene: &Scene,
    lights: &LightSet,
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
    // The density of the BSDF sample that made `ray`, and where it left;
    // `None` when the ray's emission counts in full (camera ray, a delta or
    // density-less vertex).
    let mut came_from: Option<(Vec3, f32)> = None;
    for segment in 0..settings.max_depth {
        let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
            // An environment map is a light too: weighed against its
            // light samples like an emitter's hit.
            let weight = bsdf_sample_weight(came_from, |_| lights.env_pdf(ray.direction));
            radiance += throughput
                * weight
                * evaluate_background(&scene.background(), scene.images(), ray.direction);
            break;
        };
        let si = scene.surface_interaction(&ray, &hit);
        let material = vertex_material(scene, si.material);
        let bsdf = vertex_bsdf(scene, material, si.material);
        throughput *= transmittance(material, &si, hit.t);
        let le = emitted(scene.emission(si.material), ctx, &si);
        if le != Vec3::ZERO {
            let weight = bsdf_sample_weight(came_from, |from| {
                lights.pdf(scene, hit.prim, from, si.p, si.geometric_normal)
            });
            radiance += throughput * le * weight;
        }
        let u = sampled_vertex_randoms(settings.sampler, settings.seed, pixel, sample, segment + 1);
        // The shadow ray is the path's next segment: none after the last.
        if bsdf.has_density() && !lights.is_empty() && segment + 1 < settings.max_depth {
            let ul =
                sampled_light_randoms(settings.sampler, settings.seed, pixel, sample, segment + 1);
            radiance += throughput * next_event(scene, lights, ctx, bsdf, &ray, &si, &ul);
        }
        let Some(s) = wrapped_scatter(bsdf, ctx, ray.direction, &si, &u) else {
            break;
        };
        came_from = draw_density(bsdf, ctx, ray.direction, &si, &s).map(|pdf| (si.p, pdf));
        throughput *= s.weight;
        if !survives_roulette(&mut throughput, u[dims::ROULETTE], segment, settings) {
            break;
        }
        ray = Ray::new(spawn_toward(&si, s.direction), s.direction);
    }
    radiance
}

/// The MIS weight of emission found by a BSDF sample: `came_from` is where
/// the sample left and its density (`None`: it counts in full), and
/// `pdf_light(from)` the density with which light sampling from there
/// would have picked the same direction.
#[inline]
fn bsdf_sample_weight(came_from: Option<(Vec3, f32)>, pdf_light: impl FnOnce(Vec3) -> f32) -> f32 {
    match came_from {
        Some((from, pdf_bsdf)) if !mutants::is(Mutant::MisDoubleCount) => {
            power_heuristic(pdf_bsdf, pdf_light(from))
        }
        _ => 1.0,
    }
}

/// One light sample at `si`: `f · |cos| · Le · w / p_light`, zero when the
/// sample is blocked, faces away or has no density. The shadow ray's first
/// hit must be the sampled emitter (emitters are convex, so nothing else
/// of it lies in between); its surface interaction gives the emission and
/// the density, exactly as a BSDF sample reaching that point would.
fn next_event(
    scene: &Scene,
    lights: &LightSet,
    ctx: TextureContext,
    bsdf: Bsdf,
    ray: &Ray,
    si: &SurfaceInteraction,
    ul: &[f32; 4],
) -> Vec3 {
    let Some(ls) = lights.sample(
        scene,
        si.p,
        ul[light_dims::SELECT],
        Vec2::new(ul[light_dims::POINT_U], ul[light_dims::POINT_V]),
    ) else {
        return Vec3::ZERO;
    };
    let wi = ls.direction;
    let Some((f_cos, pdf_bsdf)) = wrapped_bsdf_eval(bsdf, ctx, ray.direction, si, wi) else {
        return Vec3::ZERO;
    };
    if f_cos == Vec3::ZERO {
        return Vec3::ZERO;
    }
    // Aimed from the spawn point at the sampled point itself: along `wi`
    // the origin's offset (10^-2 on the far-from-origin fixture's ground)
    // would carry rays near an emitter's edge past it, losing light.
    let origin = spawn_toward(si, wi);
    if is_punctual(ls.prim) {
        return punctual_contribution(scene, lights, si, &ls, origin, f_cos);
    }
    if ls.prim == ENV_PRIM {
        // The environment: lit if the ray leaves the scene.
        let shadow = Ray::new(origin, wi);
        if scene.intersect(&shadow, 0.0, f32::INFINITY).is_some() {
            return Vec3::ZERO;
        }
        let le = evaluate_background(&scene.background(), scene.images(), wi);
        let pdf_light = lights.env_pdf(wi);
        if !(pdf_light > 0.0 && pdf_light.is_finite()) {
            return Vec3::ZERO;
        }
        return f_cos * le * (power_heuristic(pdf_light, pdf_bsdf) / pdf_light);
    }
    let aim = ls.offset - (origin.as_dvec3() - si.p.as_dvec3());
    let Some(dir) = aim.try_normalize().map(|d| d.as_vec3()) else {
        return Vec3::ZERO;
    };
    let shadow = Ray::new(origin, dir);
    let Some(hit) = scene.intersect(&shadow, 0.0, f32::INFINITY) else {
        return Vec3::ZERO;
    };
    if hit.prim != ls.prim {
        return Vec3::ZERO;
    }
    let sl = scene.surface_interaction(&shadow, &hit);
    let le = emitted(scene.emission(sl.material), ctx, &sl);
    let pdf_light = lights.pdf(scene, ls.prim, si.p, sl.p, sl.geometric_normal);
    if le == Vec3::ZERO || !(pdf_light > 0.0 && pdf_light.is_finite()) {
        return Vec3::ZERO;
    }
    f_cos * le * (power_heuristic(pdf_light, pdf_bsdf) / pdf_light)
}

/// A punctual light's sample: `f · |cos θ| · incident / p_select`
/// (weight 1: a delta light is found by no other strategy), zero when the
/// shadow ray from `origin` meets anything before the light — a point or
/// spot at its distance, a directional light anywhere along the ray.
fn punctual_contribution(
    scene: &Scene,
    lights: &LightSet,
    si: &SurfaceInteraction,
    ls: &crate::light::LightSample,
    origin: Vec3,
    f_cos: Vec3,
) -> Vec3 {
    let index = ls.prim & !PUNCTUAL_PRIM;
    let pmf = lights.punctual_pmf(index);
    if pmf.is_nan() || pmf <= 0.0 || ls.incident == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let light = &scene.punctual_lights()[index as usize];
    let (dir, t_max) = if light.tag == punctual_tag::DIRECTIONAL {
        (ls.direction, f32::INFINITY)
    } else {
        let aim = ls.offset - (origin.as_dvec3() - si.p.as_dvec3());
        let Some(dir) = aim.try_normalize() else {
            return Vec3::ZERO;
        };
        (dir.as_vec3(), aim.length() as f32)
    };
    if scene
        .intersect(&Ray::new(origin, dir), 0.0, t_max)
        .is_some()
    {
        return Vec3::ZERO;
    }
    let f_cos = match mutants::active() {
        Mutant::PunctualNoCosine => f_cos / si.shading_normal.dot(ls.direction).abs(),
        _ => f_cos,
    };
    f_cos * ls.incident / pmf
}

/// The camera ray of one sample and its weight: the sub-pixel position
/// uniform over the pixel (weight 1), or drawn from the scene's filter
/// (`filter`: [`crate::filter`]) with its weight.
#[inline]
pub fn camera_ray(
    filter: Option<&FilterTable>,
    camera: &crate::camera::Camera,
    settings: &RenderSettings,
    x: u32,
    y: u32,
    sample: u32,
) -> (Ray, f32) {
    let pixel = y * settings.width + x;
    let u = sampled_vertex_randoms(settings.sampler, settings.seed, pixel, sample, 0);
    let (film, weight) = match filter {
        None => (
            Vec2::new(
                (x as f32 + u[dims::PIXEL_X]) / settings.width as f32,
                (y as f32 + u[dims::PIXEL_Y]) / settings.height as f32,
            ),
            1.0,
        ),
        Some(t) => {
            let (dx, wx) = t.sample(u[dims::PIXEL_X], x, settings.width);
            let (dy, wy) = t.sample(u[dims::PIXEL_Y], y, settings.height);
            (
                Vec2::new(
                    (x as f32 + 0.5 + dx) / settings.width as f32,
                    (y as f32 + 0.5 + dy) / settings.height as f32,
                ),
                wx * wy,
            )
        }
    };
    let ray = camera.generate_ray(film, Vec2::new(u[dims::LENS_U], u[dims::LENS_V]));
    (ray, weight)
}

/// Renders `settings.spp` samples per pixel with BSDF sampling only
/// ([`render_with`] with [`Integrator::Bsdf`]).
pub fn render(scene: &Scene, settings: &RenderSettings, progress: &(dyn Fn(u64) + Sync)) -> Film {
    render_with(scene, settings, Integrator::Bsdf, progress)
}

/// Renders `settings.spp` samples per pixel with `integrator`: the film
/// of [`render_samples`] over `0..spp`.
pub fn render_with(
    scene: &Scene,
    settings: &RenderSettings,
    integrator: Integrator,
    progress: &(dyn Fn(u64) + Sync),
) -> Film {
    render_samples(scene, settings, integrator, 0..settings.spp, progress).to_film()
}

/// Renders sample indices `samples` of every pixel (the same paths, keyed
/// by the same indices, as a whole render traces for them) into a film of
/// exact sums ([`crate::film`]), so that the films of ranges tiling
/// `0..spp` merge into the whole render's film bit for bit. Tiles run in
/// parallel on rayon's current pool; `progress` is called after each tile
/// with the number of pixels done in it.
pub fn render_samples(
    scene: &Scene,
    settings: &RenderSettings,
    integrator: Integrator,
    samples: Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
) -> FilmSums {
    render_samples_until(scene, settings, integrator, samples, progress, &|| false)
        .expect("a render that is never stopped ends")
}

/// [`render_samples`], abandoned where `stop()` is true as a tile starts:
/// `None`, and none of the range's sums (a render stopped by an interrupt
/// drops the range in flight and keeps the film it had).
pub fn render_samples_until(
    scene: &Scene,
    settings: &RenderSettings,
    integrator: Integrator,
    samples: Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
    stop: &(dyn Fn() -> bool + Sync),
) -> Option<FilmSums> {
    let lights = match integrator {
        Integrator::Mis => LightSet::new(scene),
        Integrator::Bsdf => LightSet::punctual_only(scene),
    };
    let camera = scene.traced_camera(settings);
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE_SIZE);
    let tiles_y = h.div_ceil(TILE_SIZE);
    let tiles: Option<Vec<(u32, Vec<PixelSums>)>> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            if stop() {
                return None;
            }
            let (x0, y0) = ((tile % tiles_x) * TILE_SIZE, (tile / tiles_x) * TILE_SIZE);
            let (x1, y1) = ((x0 + TILE_SIZE).min(w), (y0 + TILE_SIZE).min(h));
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut sums = PixelSums::default();
                    let pixel = y * w + x;
                    for sample in samples.clone() {
                        let (ray, weight) =
                            camera_ray(scene.filter_table(), &camera, settings, x, y, sample);
                        sums.add(
                            weight
                                * match integrator {
                                    Integrator::Bsdf => {
                                        trace_path(scene, &lights, ray, settings, pixel, sample)
                                    }
                                    Integrator::Mis => {
                                        trace_path_mis(scene, &lights, ray, settings, pixel, sample)
                                    }
                                },
                        );
                    }
                    out.push(sums);
                }
            }
            progress(out.len() as u64);
            Some((tile, out))
        })
        .collect();
    let mut film = FilmSums::new(w, h);
    for (tile, pixels) in tiles? {
        let (x0, y0) = ((tile % tiles_x) * TILE_SIZE, (tile / tiles_x) * TILE_SIZE);
        let x1 = (x0 + TILE_SIZE).min(w);
        let tw = (x1 - x0) as usize;
        for (i, p) in pixels.into_iter().enumerate() {
            let (x, y) = (x0 + (i % tw) as u32, y0 + (i / tw) as u32);
            film.pixels[(y * w + x) as usize] = p;
        }
    }
    Some(film)
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_weights_sum_to_one_and_hold_at_the_limits() {
        for (a, b) in [
            (1.0, 1.0),
            (0.3, 2.0),
            (1e-30, 1e-30),
            (1e30, 3e29),
            (5.0, 1e-25),
        ] {
            let sum = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((sum - 1.0).abs() < 1e-6, "{a} {b}: {sum}");
        }
        assert_eq!(power_heuristic(1e-25, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(1.0, f32::NAN), 0.0);
    }
}
