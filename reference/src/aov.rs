//! First-hit quantities: the arbitrary output variables (AOVs) that
//! denoisers and compositing read beside the image, traced from the same
//! camera samples as the image's paths.
//!
//! Each sample's camera ray ([`crate::integrator::camera_ray`], the same
//! ray its path starts with) is traced to its first hit ([`first_hit`]),
//! and each pixel sums, sample after sample in index order, in f32:
//! - the albedo ([`albedo`]): the reflectance colour of the material hit;
//! - the shading normal on the side the ray arrived from (the normal map
//!   applied; unit length; world space);
//! - the depth: the distance along the camera ray (unit direction, from
//!   its origin on the lens) to the hit, the ray's `t`;
//! - the hit point in render space.
//!
//! Besides the sums, a pixel counts its samples and the samples that hit
//! something ([`AovSums`], [`WORDS`] words a pixel). Albedo and normal are
//! means over all samples (a sample that leaves the scene adds zero, so an
//! edge is filtered as the image is, and the background's normal is the
//! zero vector, as denoisers expect); depth and position are means over
//! the samples that hit (a pixel no sample hit has depth +∞ and position
//! zero). The sums are f32 additions in sample order on both twins
//! (`shaders/aov.wgsl` keeps the same order across dispatches), so a
//! render's AOVs are the same whichever ranges, in order, made them.

use crate::camera::Camera;
use crate::geometry::{Ray, SurfaceInteraction};
use crate::integrator::camera_ray;
use crate::material::{Material, TextureContext};
use crate::scene::{RenderSettings, Scene};
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Words a pixel of [`AovSums`]: the sums' f32 bits, then two counts.
pub const WORDS: usize = 12;

/// Where each quantity starts in a pixel's [`WORDS`] words.
pub mod word {
    /// Σ albedo (3 words, f32).
    pub const ALBEDO: usize = 0;
    /// Σ facing shading normal (3 words, f32).
    pub const NORMAL: usize = 3;
    /// Σ depth over the hits (f32).
    pub const DEPTH: usize = 6;
    /// Σ hit point over the hits (3 words, f32).
    pub const POSITION: usize = 7;
    /// Samples added (u32).
    pub const COUNT: usize = 10;
    /// Samples that hit something (u32).
    pub const HITS: usize = 11;
}

/// The quantities of one camera ray's first hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    pub albedo: Vec3,
    pub normal: Vec3,
    pub depth: f32,
    pub position: Vec3,
}

/// The reflectance colour a denoiser's albedo guide means: a diffuse or
/// metal surface's colour (its texture), a conductor's specular tint (smooth or rough), a glTF material's base colour
/// (texture times vertex colour), white for glass, smooth or rough (it reflects and
/// transmits everything), black for a `DiffuseLight` (it reflects
/// nothing). Emission added to a BSDF does not change what it reflects:
/// an emissive glTF material's albedo is its base colour.
#[inline]
pub fn albedo(material: &Material, ctx: TextureContext, si: &SurfaceInteraction) -> Vec3 {
    match *material {
        Material::Lambertian { albedo } | Material::Metal { albedo, .. } => ctx.eval(albedo, si),
        Material::Conductor { specular, .. } | Material::RoughConductor { specular, .. } => {
            ctx.eval(specular, si)
        }
        Material::Ggx { base_color, .. } => ctx.base_color(base_color, si),
        Material::Plastic { diffuse, .. } | Material::RoughPlastic { diffuse, .. } => {
            ctx.eval(diffuse, si)
        }
        Material::Principled { base_color, .. } => ctx.eval(base_color, si),
        Material::Dielectric { .. }
        | Material::SmoothDielectric { .. }
        | Material::ThinDielectric { .. }
        | Material::RoughDielectric { .. } => Vec3::ONE,
        Material::DiffuseLight { .. } => Vec3::ZERO,
    }
}

/// What `ray` (a camera ray) first hits; `None` where it leaves the scene.
pub fn first_hit(scene: &Scene, ray: &Ray) -> Option<FirstHit> {
    let hit = scene.intersect(ray, 0.0, f32::INFINITY)?;
    let si = scene.surface_interaction(ray, &hit);
    let ctx = TextureContext {
        textures: scene.textures(),
        images: scene.images(),
    };
    let material = &scene.materials()[si.material as usize];
    let normal = if si.front_face {
        si.shading_normal
    } else {
        -si.shading_normal
    };
    Some(FirstHit {
        albedo: albedo(material, ctx, &si),
        normal,
        depth: hit.t,
        position: si.p,
    })
}

/// Each pixel's AOV sums ([`WORDS`] words, pixel-major; the layout of
/// [`word`]): the device's buffer word for word.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AovSums {
    pub width: u32,
    pub height: u32,
    pub words: Vec<u32>,
}

impl AovSums {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            words: vec![0; width as usize * height as usize * WORDS],
        }
    }

    /// Sums of `width x height` pixels from their words; `None` if there
    /// are not `WORDS` a pixel.
    pub fn from_words(width: u32, height: u32, words: Vec<u32>) -> Option<Self> {
        (words.len() == width as usize * height as usize * WORDS).then_some(Self {
            width,
            height,
            words,
        })
    }

    /// Adds one sample of `pixel` (its first hit, or `None`).
    #[inline]
    pub fn add(&mut self, pixel: usize, hit: Option<FirstHit>) {
        add_to(&mut self.words[pixel * WORDS..(pixel + 1) * WORDS], hit);
    }

    /// The means ([`AovLayers`]).
    pub fn layers(&self) -> AovLayers {
        let pixels = self.words.chunks_exact(WORDS);
        let f = |w: &[u32], at: usize| f32::from_bits(w[at]);
        let v = |w: &[u32], at: usize| Vec3::new(f(w, at), f(w, at + 1), f(w, at + 2));
        let mut out = AovLayers {
            width: self.width,
            height: self.height,
            ..AovLayers::default()
        };
        for w in pixels {
            let (count, hits) = (w[word::COUNT], w[word::HITS]);
            let per_sample = if count > 0 { 1.0 / count as f32 } else { 0.0 };
            out.albedo.push(v(w, word::ALBEDO) * per_sample);
            out.normal.push(v(w, word::NORMAL) * per_sample);
            if hits > 0 {
                out.depth.push(f(w, word::DEPTH) / hits as f32);
                out.position.push(v(w, word::POSITION) / hits as f32);
            } else {
                out.depth.push(f32::INFINITY);
                out.position.push(Vec3::ZERO);
            }
            out.samples.push(count);
            out.hits.push(hits);
        }
        out
    }
}

/// One sample added to a pixel's words (the twin of `aov_sums_add`).
#[inline]
fn add_to(w: &mut [u32], hit: Option<FirstHit>) {
    w[word::COUNT] += 1;
    let Some(h) = hit else {
        return;
    };
    let mut add = |at: usize, x: f32| w[at] = (f32::from_bits(w[at]) + x).to_bits();
    for (i, c) in h.albedo.to_array().into_iter().enumerate() {
        add(word::ALBEDO + i, c);
    }
    for (i, c) in h.normal.to_array().into_iter().enumerate() {
        add(word::NORMAL + i, c);
    }
    add(word::DEPTH, h.depth);
    for (i, c) in h.position.to_array().into_iter().enumerate() {
        add(word::POSITION + i, c);
    }
    w[word::HITS] += 1;
}

/// The means of [`AovSums`], row-major, top row first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AovLayers {
    pub width: u32,
    pub height: u32,
    pub albedo: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    /// +∞ where no sample hit.
    pub depth: Vec<f32>,
    /// Render space; zero where no sample hit.
    pub position: Vec<Vec3>,
    /// Samples a pixel.
    pub samples: Vec<u32>,
    /// Samples that hit something.
    pub hits: Vec<u32>,
}

/// Traces the camera rays of sample indices `samples` of every pixel of
/// `settings`' image (the camera `scene.traced_camera(settings)`) and adds their
/// first hits to `sums` in sample order. Rows run in parallel on rayon's
/// current pool.
pub fn render_aovs(
    scene: &Scene,
    settings: &RenderSettings,
    samples: Range<u32>,
    sums: &mut AovSums,
) {
    let camera: Camera = scene.traced_camera(settings);
    let w = settings.width as usize;
    assert_eq!(
        (sums.width, sums.height),
        (settings.width, settings.height),
        "AOV sums of another size"
    );
    sums.words
        .par_chunks_mut(w * WORDS)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, pixel) in row.chunks_exact_mut(WORDS).enumerate() {
                for sample in samples.clone() {
                    // The filter's weights (mean square 1 + 7e-5) are not
                    // applied: a layer is the mean over the camera samples.
                    let (ray, _) = camera_ray(
                        scene.filter_table(),
                        &camera,
                        settings,
                        x as u32,
                        y as u32,
                        sample,
                    );
                    add_to(pixel, first_hit(scene, &ray));
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_divide_by_samples_and_hits() {
        let mut sums = AovSums::new(2, 1);
        let hit = FirstHit {
            albedo: Vec3::new(0.5, 0.25, 1.0),
            normal: Vec3::Z,
            depth: 3.0,
            position: Vec3::new(1.0, 2.0, 3.0),
        };
        sums.add(0, Some(hit));
        sums.add(0, None);
        sums.add(0, Some(hit));
        sums.add(0, None);
        let l = sums.layers();
        assert_eq!(l.albedo[0], hit.albedo * 0.5);
        assert_eq!(l.normal[0], Vec3::Z * 0.5);
        assert_eq!(l.depth[0], 3.0);
        assert_eq!(l.position[0], hit.position);
        assert_eq!((l.samples[0], l.hits[0]), (4, 2));
        // A pixel nothing was added to, and one no sample hit.
        assert_eq!(
            (l.depth[1], l.position[1], l.samples[1]),
            (f32::INFINITY, Vec3::ZERO, 0)
        );
        assert!(AovSums::from_words(2, 1, vec![0; 23]).is_none());
    }
}
