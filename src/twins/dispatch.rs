//! The kernel that picks a primitive's intersection and a material's
//! sampling code by a chain of tag tests (`gpu::Dispatch::Branches`)
//! against the one that switches on the tag (the baseline): every fixture
//! and built-in scene, both estimators, films under the wavefront's rule
//! ([`super::film_words::compare_words`]: counts exact, means bit for bit
//! or a few ulp apart where a driver contracts two programs' shared code
//! differently). Both run the same per-kind functions; only the selection
//! differs, so any difference beyond the rule is a selection slip (a kind
//! sent to another's code, or lost).

use super::film_words::compare_words;
use super::harness::Outcome;
use super::specialization::{
    every_variant, gate_kernel_words, gate_scenes, own_oracle, variant_film, Build, SIZE,
};
use gpu::{Dispatch, GpuContext};
use reference::integrator::Integrator;
use reference::Scene;

/// The branch-dispatch film of `scene` (over `program`, the megakernel's
/// WGSL or an edit) against the switch's (production), one estimator,
/// both built for the scene's own features: the
/// pixels not bit for bit and their largest mean difference in ulp.
pub fn compare_scene(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    integrator: Integrator,
    program: &str,
) -> Result<(usize, u64), String> {
    let (build, oracle) = own_oracle((ctx, spec, scene), integrator, program, "the switch kernel")?;
    compare_with((ctx, spec, scene), &oracle, build)
}

/// [`compare_scene`] against the switch kernel's film already rendered.
fn compare_with(
    (ctx, spec, scene): (&GpuContext, &str, &Scene),
    oracle: &[u64],
    build: Build,
) -> Result<(usize, u64), String> {
    let integrator = build.integrator;
    let branches = Build {
        dispatch: Dispatch::Branches,
        ..build
    };
    let film = variant_film(ctx, scene, branches)?;
    compare_words(oracle, &film)
        .map_err(|e| format!("{spec} ({}, branch dispatch): {e}", integrator.name()))
}

/// Every fixture and built-in scene, under
/// [`super::specialization::gate_estimators`]: branches == switch
/// under the rule. Every scene is compared; the error lists each failure.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let program = gpu::shader::render_source();
    let scenes = gate_scenes(ctx, "the switch kernel")?;
    let (films, inexact) = every_variant(&scenes, &[()], |s, integrator, ()| {
        Some(compare_with(
            (ctx, &s.spec, &s.scene),
            s.oracle(integrator),
            s.build(&program, integrator),
        ))
    })?;
    let (width, height, _) = SIZE;
    Ok(format!(
        "{} scenes × {}: the branch-dispatch kernel's films equal the switch kernel's {} ({})",
        scenes.len(),
        super::specialization::estimator_words(ctx),
        inexact.exactness(films * (width * height) as usize),
        gate_kernel_words(ctx)
    ))
}
