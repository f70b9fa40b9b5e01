//! The trusted kernels (`gpu::Checks::Trusted`: wgpu's loop bounding left
//! out) against the checked ones (wgpu's default, the oracle): every
//! fixture and built-in scene, both estimators, the same program, films
//! equal word for word. The two modules differ only in what wgpu adds
//! around the loops, so any difference is a kernel whose loops the
//! driver compiled to something else than the program says: a loop that
//! does not end, or code after one that the driver took as unreachable.
//! The default variant's path megakernel is held to the megakernel by
//! `super::wavefront`, trusted on both sides of that rule.

use super::harness::Outcome;
use super::specialization::{
    every_variant, features_used, gate_features, gate_kernel_words, gate_scenes, oracle_build,
    own_oracle, scene_specs, variant_film, Build, SIZE,
};
use gpu::{Checks, GpuContext};
use reference::integrator::Integrator;
use reference::Scene;

/// The trusted megakernel's film of `scene` (over `program`, the
/// megakernel's WGSL or an edit) against the checked production
/// megakernel's, one estimator, both built for the scene's own features:
/// `Ok((0, 0))` where every word is equal,
/// else the first pixel that differs and the count.
pub fn compare_scene(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    integrator: Integrator,
    program: &str,
) -> Result<(usize, u64), String> {
    let (build, oracle) = own_oracle(
        (ctx, spec, scene),
        integrator,
        program,
        "the checked kernel",
    )?;
    compare_with((ctx, spec, scene), &oracle, build)
}

/// [`compare_scene`] against the checked kernel's film already rendered.
fn compare_with(
    (ctx, spec, scene): (&GpuContext, &str, &Scene),
    oracle: &[u64],
    build: Build,
) -> Result<(usize, u64), String> {
    let integrator = build.integrator;
    let trusted = Build {
        checks: Checks::Trusted,
        ..build
    };
    let film = variant_film(ctx, scene, trusted)?;
    let words = super::film_words::WORDS_PER_PIXEL;
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

/// The scenes `specs` (fixture paths or built-in names), under
/// [`super::specialization::gate_estimators`]:
/// trusted == checked, word for word, with the kernels the all-scenes
/// gates build ([`super::specialization::gate_features`]: on a software
/// adapter their checked films are those gates' oracles); the first
/// failure.
pub fn some_scenes(ctx: &GpuContext, specs: &[&str]) -> Outcome {
    let program = gpu::shader::render_source();
    let used = features_used(&scene_specs()?)?;
    for spec in specs {
        let scene = reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))?;
        for &integrator in super::specialization::gate_estimators(ctx) {
            let features = gate_features(ctx, &scene, used);
            let (build, oracle) = oracle_build(
                (ctx, spec, &scene),
                (integrator, features),
                &program,
                "the checked kernel",
            )?;
            compare_with((ctx, spec, &scene), &oracle, build)?;
        }
    }
    Ok(format!(
        "{} scenes × {}: the trusted kernel's films equal the checked kernel's word for word ({})",
        specs.len(),
        super::specialization::estimator_words(ctx),
        gate_kernel_words(ctx)
    ))
}

/// Every fixture and built-in scene, under
/// [`super::specialization::gate_estimators`]: trusted == checked,
/// word for word. Every scene is compared; the error lists each failure.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let program = gpu::shader::render_source();
    let scenes = gate_scenes(ctx, "the checked kernel")?;
    let (films, _) = every_variant(&scenes, &[()], |s, integrator, ()| {
        Some(compare_with(
            (ctx, &s.spec, &s.scene),
            s.oracle(integrator),
            s.build(&program, integrator),
        ))
    })?;
    let (width, height, _) = SIZE;
    Ok(format!(
        "{} scenes × {}: the trusted kernel's films equal the checked kernel's word for word ({} pixels; {})",
        scenes.len(),
        super::specialization::estimator_words(ctx),
        films * (width * height) as usize,
        gate_kernel_words(ctx)
    ))
}
