//! The trusted kernels (`gpu::Checks::Trusted`: wgpu's loop bounding left
//! out) against the checked ones (wgpu's default, the oracle): every
//! fixture and built-in scene, both estimators, the same program, films
//! equal word for word. The two modules differ only in what wgpu adds
//! around the loops, so any difference is a kernel whose loops the
//! driver compiled to something else than the program says: a loop that
//! does not end, or code after one that the driver took as unreachable.
//! The default variant's path megakernel is held to the megakernel by
//! `super::wavefront`, trusted on both sides of that rule.

use super::specialization::{every_scene, oracle_film, variant_film_bits, Build, SIZE};
use super::Outcome;
use gpu::features::Kernel;
use gpu::{Checks, GpuContext};
use reference::integrator::Integrator;
use reference::Scene;

/// The trusted megakernel's film of `scene` (over `program`, the
/// megakernel's WGSL or an edit) against the checked production
/// megakernel's, one estimator: `Ok((0, 0))` where every word is equal,
/// else the first pixel that differs and the count.
pub fn compare_scene(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    integrator: Integrator,
    program: &str,
) -> Result<(usize, u64), String> {
    let features = Kernel::Specialized.features(scene);
    let oracle = oracle_film(ctx, spec, scene, integrator, "the checked kernel")?;
    let trusted = Build {
        checks: Checks::Trusted,
        ..Build::megakernel(program, integrator, features)
    };
    let film = variant_film_bits(ctx, scene, trusted, &[None])?.remove(0);
    let words = super::specialization::WORDS_PER_PIXEL;
    let differ: Vec<usize> = (0..oracle.len() / words)
        .filter(|p| oracle[p * words..(p + 1) * words] != film[p * words..(p + 1) * words])
        .collect();
    match differ.first() {
        None if oracle.len() == film.len() => Ok((0, 0)),
        None => Err(format!(
            "{spec} ({}, trusted kernel): {} film words against {}",
            integrator.name(),
            film.len(),
            oracle.len()
        )),
        Some(p) => Err(format!(
            "{spec} ({}, trusted kernel): pixel {p} differs from the checked kernel's ({} of {} pixels differ)",
            integrator.name(),
            differ.len(),
            oracle.len() / words
        )),
    }
}

/// The scenes `specs` (fixture paths or built-in names), both estimators:
/// trusted == checked, word for word; the first failure.
pub fn some_scenes(ctx: &GpuContext, specs: &[&str]) -> Outcome {
    let program = gpu::shader::render_source();
    for spec in specs {
        let scene = reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))?;
        for integrator in Integrator::ALL {
            compare_scene(ctx, spec, &scene, integrator, &program)?;
        }
    }
    Ok(format!(
        "{} scenes × 2 estimators: the trusted kernel's films equal the checked kernel's word for word",
        specs.len()
    ))
}

/// Every fixture and built-in scene, both estimators: trusted == checked,
/// word for word. Every scene is compared; the error lists each failure.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let program = gpu::shader::render_source();
    let (scenes, _) = every_scene(|spec, scene, integrator| {
        compare_scene(ctx, spec, scene, integrator, &program)
    })?;
    let (width, height, _) = SIZE;
    Ok(format!(
        "{scenes} scenes × 2 estimators: the trusted kernel's films equal the checked kernel's word for word ({} pixels)",
        scenes * 2 * (width * height) as usize
    ))
}
