//! A first image check: GPU vs reference mean per pixel agree in a
//! two-sample z-test that uses both variances (Šidák-corrected α = 0.01
//! over all pixel-channels, ≥ 99.75 % must pass: Mitsuba 3's scheme), and
//! the image sums per channel agree (|z| below the Šidák bound for 3
//! tests). The full harness lives in `twintrace::compare`.

mod common;

use reference::material::Material;
use reference::{Film, RenderSettings, Scene};

/// Inverse of the standard normal CDF's upper tail for small p, by
/// bisection on erfc (accurate to 1e-6, enough for a threshold).
fn z_for_two_sided(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erfc(mid / std::f64::consts::SQRT_2) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Complementary error function (Numerical Recipes' Chebyshev fit,
/// fractional error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06 + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

struct Verdict {
    pixel_pass_fraction: f64,
    sum_z: [f64; 3],
    sum_bound: f64,
}

impl Verdict {
    fn passes(&self) -> bool {
        self.pixel_pass_fraction >= 0.9975 && self.sum_z.iter().all(|z| z.abs() < self.sum_bound)
    }
}

fn compare(a: &Film, b: &Film) -> Verdict {
    let n = (a.pixels.len() * 3) as f64;
    // Šidák: per-test α such that the family-wise rate is 0.01.
    let alpha = 1.0 - (1.0 - 0.01f64).powf(1.0 / n);
    let bound = z_for_two_sided(alpha);
    // Variance floor: pixels with zero sample variance on both sides
    // (black background) compare exactly; 1e-12 keeps the ratio defined.
    let floor = 1e-12;
    let mut pass = 0usize;
    let mut sums = [[0.0f64; 2]; 3];
    let mut vars = [[0.0f64; 2]; 3];
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let (vp, vq) = (p.variance_of_mean(), q.variance_of_mean());
        for c in 0..3 {
            let z = (p.mean[c] - q.mean[c]) / (vp[c] + vq[c]).max(floor).sqrt();
            pass += (z.abs() < bound) as usize;
            sums[c][0] += p.mean[c];
            sums[c][1] += q.mean[c];
            vars[c][0] += vp[c];
            vars[c][1] += vq[c];
        }
    }
    let sum_z = [0, 1, 2].map(|c| (sums[c][0] - sums[c][1]) / (vars[c][0] + vars[c][1]).max(floor).sqrt());
    let sum_bound = z_for_two_sided(1.0 - (1.0 - 0.01f64).powf(1.0 / 3.0));
    Verdict { pixel_pass_fraction: pass as f64 / n, sum_z, sum_bound }
}

fn render_both(cpu_scene: &Scene, gpu_scene: &Scene, settings: &RenderSettings) -> (Film, Film) {
    let cpu = reference::render(cpu_scene, settings, &|_| {});
    let ctx = common::gpu();
    // A different seed on the GPU: the two renders are independent samples.
    let gpu_settings = RenderSettings { seed: settings.seed + 1, ..*settings };
    let g = gpu::GpuRenderer::new(ctx, gpu_scene).unwrap().render(&gpu_settings, &|_, _| {}).unwrap();
    (cpu, g.film)
}

fn scaled_albedo(scene: &Scene, factor: f32) -> Scene {
    let mut s = scene.clone();
    for m in &mut s.materials {
        if let Material::Lambertian { albedo } = m {
            if let reference::texture::Texture::Constant(c) = &mut s.textures[*albedo as usize] {
                *c *= factor;
            }
        }
    }
    s
}

#[test]
fn cornell_gpu_matches_reference_and_a_biased_gpu_does_not() {
    let scene = reference::load_scene("cornell").unwrap();
    // 24x24 at 256 spp: ~0.15 M paths per renderer, seconds on lavapipe.
    let settings = RenderSettings { width: 24, height: 24, spp: 256, max_depth: 12, ..scene.render };
    let (cpu, gpu) = render_both(&scene, &scene, &settings);
    let v = compare(&cpu, &gpu);
    println!("cornell: {:.4} of pixel tests pass, image-sum z = {:?} (bound {:.2})", v.pixel_pass_fraction, v.sum_z, v.sum_bound);
    assert!(v.passes(), "GPU and reference differ: {:.4} pass, sum z {:?}", v.pixel_pass_fraction, v.sum_z);
    // Mutation: albedo ×1.1 on the GPU side must be detected.
    let biased = scaled_albedo(&scene, 1.1);
    let (cpu, gpu) = render_both(&scene, &biased, &settings);
    let v = compare(&cpu, &gpu);
    println!("cornell, GPU albedo x1.1: {:.4} pass, sum z = {:?}", v.pixel_pass_fraction, v.sum_z);
    assert!(!v.passes(), "a 10% albedo bias went undetected");
}

#[test]
fn every_material_and_texture_matches_on_a_mixed_scene() {
    // Glass, bubble, fuzzy metal, checker texture, sky, lights; and image
    // textures + GGX; and the environment map.
    for spec in ["four-materials.json", "textures.json", "skybox.json", "ggx-roughness.json"] {
        let path = format!("{}/fixtures/scenes/{spec}", env!("CARGO_MANIFEST_DIR"));
        let scene = reference::load_scene(&path).unwrap();
        let settings = RenderSettings { width: 24, height: 16, spp: 128, max_depth: 8, ..scene.render };
        let (cpu, gpu) = render_both(&scene, &scene, &settings);
        let v = compare(&cpu, &gpu);
        println!("{spec}: {:.4} pass, sum z = {:?}", v.pixel_pass_fraction, v.sum_z);
        assert!(v.passes(), "{spec}: GPU and reference differ: {:.4} pass, sum z {:?}", v.pixel_pass_fraction, v.sum_z);
    }
}
