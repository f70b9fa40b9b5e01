//! First-hit quantities (AOVs), GPU vs reference: `gpu`'s `aov_main`
//! against `reference::aov::render_aovs` over the same pixels and sample
//! indices, sum for sum.
//!
//! A pixel agrees when its sample count and hit count are equal and each
//! sum is within the bound below of the reference's; a pixel where one
//! sample of the two twins hits another primitive or misses (a camera ray
//! within the error model of an edge or a tie, as the hit-record twin
//! excuses, or a lens sample whose `sin`/`cos` rounds differently) may
//! differ by a whole sample's value: at most [`MAX_OFF_FRACTION`] of the
//! pixels, counted. On a software adapter the two are expected bit for
//! bit; the summary says how many pixels were.

use super::harness::{ensure, Outcome};
use crate::compare::gate::{fixture_scene, workspace_root};
use glam::Vec3;
use gpu::GpuContext;
use reference::aov::{render_aovs, word, AovSums, WORDS};
use reference::{RenderSettings, Scene};
use std::ops::Range;

/// f32's machine epsilon (2^-23), the unit of the bounds.
const EPS: f32 = f32::EPSILON;

/// A sample's albedo: a texel's bilinear blend (three lerps of two
/// roundings), times the vertex colour (an interpolated three-term sum,
/// 8 ε as the surface twin's) and a factor: within 32 ε of its magnitude.
const ALBEDO_TOL: f32 = 32.0 * EPS;

/// A sample's normal: the surface twin's bound on normal-mapped shading
/// normals (64 ε; plain ones 8 ε), absolute on unit vectors.
const NORMAL_TOL: f32 = 64.0 * EPS;

/// A sample's depth and hit point: the hit-record twin's t bound is
/// `T_ERROR_ULPS` (64) unit roundoffs of the ray's reach over |cos θ|;
/// camera rays seen head-on to 1/|cos θ| ≤ 8 (θ ≤ 83°), and the camera
/// ray itself (a normalized difference, 4 ε) and the point (`o + t·d`,
/// 3 roundings) add a few: 256 ε relative. Grazing hits beyond it are
/// the off pixels.
const DISTANCE_TOL: f32 = 256.0 * EPS;

/// The share of pixels that may disagree by more than the bounds. The
/// twins' camera rays differ by an ulp or two (the GPU's `normalize`,
/// `sin`, `cos`), and three things turn that into a whole sample's
/// difference: a ray within the error model of an edge or a tie (the
/// hit-record twin excuses 1 % of its rays), a sphere's uv (Vulkan's
/// `atan2`/`acos`, 4096 ε) across a sharp texture's lines, and glTF BLEND
/// coverage, drawn from a hash of the ray's bits. Measured on lavapipe
/// (24x16 × 4 samples): rtow-final 1 pixel of 384, textures 11 (the
/// image-textured sphere), gltf-materials 13 (3.4 %; BLEND). 8 % leaves
/// room for another adapter's rounding; each mutant of tests/gpu/gpu_aov.rs
/// puts 21 % or more of its scene's pixels off.
pub const MAX_OFF_FRACTION: f64 = 0.08;

/// The size and samples the check renders.
const WIDTH: u32 = 24;
const HEIGHT: u32 = 16;
const SAMPLES: Range<u32> = 3..7;

/// The scenes: depth of field (lens samples), the Cornell box (quads from
/// both sides), textures, the glTF materials (normal maps, vertex
/// colours, both uv sets), glass and metal, and Mitsuba gate scenes (an
/// orthographic camera, uv checkers; the Gaussian pixel filter).
pub fn scenes() -> Result<Vec<(String, Scene)>, String> {
    let load = |spec: &str| reference::load_scene(spec).map_err(|e| e.to_string());
    let mut out = vec![
        ("rtow-final".to_string(), load("rtow-final")?),
        ("cornell".to_string(), load("cornell")?),
    ];
    for f in [
        "depth-of-field.json",
        "textures.json",
        "gltf-materials.json",
        "four-materials.json",
    ] {
        out.push((f.trim_end_matches(".json").into(), load(&fixture_scene(f))?));
    }
    for (name, file) in [
        ("mitsuba-plan", "plan/test_plan_path.xml"),
        ("mitsuba-soft", "soft/test_soft_direct.xml"),
    ] {
        let path = workspace_root().join("fixtures/mitsuba").join(file);
        out.push((name.into(), load(&path.display().to_string())?));
    }
    Ok(out)
}

/// The check's settings for `scene`.
fn settings(scene: &Scene) -> RenderSettings {
    RenderSettings {
        width: WIDTH,
        height: HEIGHT,
        spp: SAMPLES.end - SAMPLES.start,
        ..scene.render_settings()
    }
}

/// How the two twins' sums compare.
#[derive(Debug, Default)]
pub struct Comparison {
    pub pixels: usize,
    pub identical: usize,
    /// Pixels off by more than the bounds (or in their counts).
    pub off: usize,
    /// The first off pixel, described.
    pub first_off: Option<String>,
}

/// Compares the GPU's sums with the reference's, pixel by pixel.
pub fn compare(gpu: &AovSums, cpu: &AovSums) -> Result<Comparison, String> {
    ensure!(
        (gpu.width, gpu.height) == (cpu.width, cpu.height) && gpu.words.len() == cpu.words.len(),
        "AOV sums of {}x{} against {}x{}",
        gpu.width,
        gpu.height,
        cpu.width,
        cpu.height
    );
    let mut c = Comparison::default();
    for (i, (g, r)) in gpu
        .words
        .chunks_exact(WORDS)
        .zip(cpu.words.chunks_exact(WORDS))
        .enumerate()
    {
        c.pixels += 1;
        if g == r {
            c.identical += 1;
            continue;
        }
        if let Some(why) = pixel_off(g, r) {
            c.off += 1;
            if c.first_off.is_none() {
                let (x, y) = (i as u32 % gpu.width, i as u32 / gpu.width);
                c.first_off = Some(format!("pixel ({x}, {y}): {why}"));
            }
        }
    }
    Ok(c)
}

/// Why a pixel's sums are not within the bounds (`None`: they are).
fn pixel_off(g: &[u32], r: &[u32]) -> Option<String> {
    let (count, hits) = (r[word::COUNT], r[word::HITS]);
    if g[word::COUNT] != count || g[word::HITS] != hits {
        return Some(format!(
            "{} samples, {} hits on the GPU; {count}, {hits} in the reference",
            g[word::COUNT],
            g[word::HITS]
        ));
    }
    let f = |w: &[u32], at: usize| f32::from_bits(w[at]);
    let v = |w: &[u32], at: usize| Vec3::new(f(w, at), f(w, at + 1), f(w, at + 2));
    let n = hits.max(1) as f32;
    let within = |what: &str, at: usize, tol: f32, abs: bool| -> Option<String> {
        let (a, b) = (v(g, at), v(r, at));
        // A sum of n samples: n times a sample's bound (absolute, or of
        // the sum's magnitude).
        let bound = if abs {
            n * tol
        } else {
            tol * n * b.abs().max_element().max(f32::MIN_POSITIVE)
        };
        let d = (a - b).abs().max_element();
        (d > bound || d.is_nan())
            .then(|| format!("{what} {a} against {b} (|Δ| {d:.3e}, bound {bound:.3e})"))
    };
    let depth = (f(g, word::DEPTH), f(r, word::DEPTH));
    let depth_bound = DISTANCE_TOL * n * depth.1.abs();
    within("albedo", word::ALBEDO, ALBEDO_TOL, false)
        .or_else(|| within("normal", word::NORMAL, NORMAL_TOL, true))
        .or_else(|| within("position", word::POSITION, DISTANCE_TOL, false))
        .or_else(|| {
            let d = (depth.0 - depth.1).abs();
            (d > depth_bound || d.is_nan()).then(|| {
                format!(
                    "depth {} against {} (|Δ| {d:.3e}, bound {depth_bound:.3e})",
                    depth.0, depth.1
                )
            })
        })
}

/// The check on one scene with `program` as the AOV kernel.
pub fn scene_with_program(ctx: &GpuContext, name: &str, scene: &Scene, program: &str) -> Outcome {
    let renderer = gpu::GpuRenderer::new(
        ctx,
        scene,
        gpu::RendererBuild::of(gpu::Variant::plain(
            reference::integrator::Integrator::Bsdf,
            gpu::Schedule::Megakernel,
        )),
    )
    .map_err(|e| format!("{name}: {e}"))?;
    let settings = settings(scene);
    let gpu = renderer
        .render_aovs_with(program, &settings, SAMPLES)
        .map_err(|e| format!("{name}: {e}"))?;
    let mut cpu = AovSums::new(settings.width, settings.height);
    render_aovs(scene, &settings, SAMPLES, &mut cpu);
    let c = compare(&gpu, &cpu).map_err(|e| format!("{name}: {e}"))?;
    let hits: u64 = cpu
        .words
        .chunks_exact(WORDS)
        .map(|w| w[word::HITS] as u64)
        .sum();
    ensure!(
        hits > 0,
        "{name}: no camera sample hit anything (the check would hold nothing)"
    );
    let allowed = (MAX_OFF_FRACTION * c.pixels as f64).floor() as usize;
    ensure!(
        c.off <= allowed,
        "{name}: {} of {} pixels off (at most {allowed}); first {}",
        c.off,
        c.pixels,
        c.first_off.as_deref().unwrap_or("")
    );
    let first = c
        .first_off
        .map(|f| format!(" (first {f})"))
        .unwrap_or_default();
    Ok(format!(
        "{name}: {} pixels × {} samples ({hits} hits): {} bit for bit, {} within the bounds, {} off{first}",
        c.pixels,
        SAMPLES.end - SAMPLES.start,
        c.identical,
        c.pixels - c.identical - c.off,
        c.off
    ))
}

/// [`scene_with_program`] with the production kernel on every scene of
/// [`scenes`].
pub fn with_program(ctx: &GpuContext, program: &str) -> Outcome {
    let mut lines = Vec::new();
    for (name, scene) in scenes()? {
        lines.push(scene_with_program(ctx, &name, &scene, program)?);
    }
    Ok(lines.join("\n"))
}

/// The check with the production kernel (`twintrace selftest`).
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    with_program(ctx, &gpu::aov::aov_source())
}
