//! The wavefront variant against the megakernel: the same scene, estimator
//! and kernel features rendered by the wavefront's kernels (either path
//! layout, `gpu::wavefront`) must give the megakernel's film bit for bit
//! (every pixel's count, rejected samples, mean and moments): each path
//! takes the same keyed randoms through the same functions, and the film
//! folds every pixel's samples in sample order. Run on every fixture and
//! built-in scene, with the renders split into waves three ways (one
//! wave; several samples a wave; runs of pixels, one sample a wave), so
//! the wave bookkeeping is compared too. GPU against GPU, like
//! [`super::specialization`]: it holds a user's driver to the same rule.

use super::specialization::{counts, first_difference, scene_specs, variant_film_bits, SIZE};
use super::Outcome;
use gpu::features::Kernel;
use gpu::{GpuContext, Schedule};
use reference::integrator::Integrator;
use reference::Scene;

/// Slots per wave of the compared renders (`SIZE`: 192 pixels, 2 samples):
/// the adapter's default (one wave of both samples), 200 (a wave
/// a sample), 100 (runs of 100 and 92 pixels, one sample a wave: four
/// waves).
pub const WAVE_SLOTS: [Option<u32>; 3] = [None, Some(200), Some(100)];

/// The megakernel's film and the wavefront's (each path layout, each of
/// [`WAVE_SLOTS`]) for one scene and estimator; `program` is the
/// wavefront's WGSL (`gpu::shader::wavefront_source`, or a test's edit).
pub fn compare_scene(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    integrator: Integrator,
    program: &str,
) -> Outcome {
    let features = Kernel::Specialized.features(scene);
    let mega = variant_film_bits(
        ctx,
        scene,
        &gpu::shader::render_source(),
        integrator,
        features,
        Schedule::Megakernel,
        &[None],
    )?
    .remove(0);
    // Not a vacuous comparison: the megakernel counted every sample.
    let (width, height, spp) = SIZE;
    let (counted, rejected) = counts(&mega);
    if counted != (width * height * spp) as u64 || rejected != 0 {
        return Err(format!(
            "{spec} ({}): the megakernel's film counted {counted} samples and rejected {rejected}",
            integrator.name()
        ));
    }
    for schedule in Schedule::ALL {
        if schedule == Schedule::Megakernel {
            continue;
        }
        let films = variant_film_bits(
            ctx,
            scene,
            program,
            integrator,
            features,
            schedule,
            &WAVE_SLOTS,
        )?;
        for (wave, slots) in films.iter().zip(WAVE_SLOTS) {
            if *wave != mega {
                return Err(format!(
                    "{spec} ({}, {}, {} slots a wave): the wavefront's film differs from the megakernel's, first at pixel {}",
                    integrator.name(),
                    schedule.name(),
                    slots.map_or("default".to_string(), |s| s.to_string()),
                    first_difference(&mega, wave)
                ));
            }
        }
    }
    Ok(String::new())
}

/// Every scene of [`scene_specs`], both estimators: wavefront == megakernel.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let specs = scene_specs()?;
    let program = gpu::shader::wavefront_source();
    for spec in &specs {
        let scene = reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))?;
        for integrator in Integrator::ALL {
            compare_scene(ctx, spec, &scene, integrator, &program)?;
        }
    }
    Ok(format!(
        "{} scenes × 2 estimators × 2 path layouts × 3 wave splits: the wavefront's films equal the megakernel's bit for bit",
        specs.len()
    ))
}
