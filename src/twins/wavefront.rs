//! The wave schedules against the megakernel: the same scene, estimator
//! and kernel features rendered by the wavefront's kernels (either path
//! layout, the paths shaded in queue order or sorted by material) and by
//! the path megakernel (`gpu::wavefront::Schedule`) must
//! give the megakernel's film: each path
//! takes the same keyed randoms through the same functions, and the film
//! folds every pixel's samples in sample order. Run on every fixture and
//! built-in scene, with the renders split into waves three ways (one
//! wave; several samples a wave; runs of pixels, one sample a wave), so
//! the wave bookkeeping is compared too. GPU against GPU, like
//! [`super::specialization`]: it holds a user's driver to the same rule.
//!
//! The films are held to [`super::film_words`] (counts exact, means bit for
//! bit or a few ulp apart where the driver contracts the two programs'
//! shared arithmetic differently).
//! The summary line says how many pixels were not bit for bit.

use super::film_words::{compare_films, counts, Inexact};
use super::harness::Outcome;
use super::specialization::{
    every_variant, film_bits, gate_kernel_words, gate_scenes, own_oracle, variant_film_bits, Build,
    SIZE,
};
use gpu::{GpuContext, Schedule};
use reference::integrator::Integrator;
use reference::Scene;

/// Slots per wave of the compared renders (`SIZE`: 192 pixels, 2 samples;
/// a wave holds both samples of its pixels, `gpu::wavefront::Waves`): the
/// adapter's default (one wave), 200 (runs of 100 and 92 pixels: two
/// waves), 100 (runs of 50 pixels: four waves).
pub const WAVE_SLOTS: [Option<u32>; 3] = [None, Some(200), Some(100)];

/// The splits of a sorted wavefront (`gpu::ShadeOrder::Material`): its
/// waves are the unsorted wavefront's, whose three splits hold the wave
/// bookkeeping; what the sort adds runs every bounce of every wave, and
/// four waves of 50 pixels give it a short last wave and counts cleared
/// from wave to wave (a third of the renders, where CI's time is short).
pub const SORTED_WAVE_SLOTS: [Option<u32>; 1] = [Some(100)];

/// The wave schedules the gates compare on `ctx`: every one of
/// `Schedule::WAVES` on hardware (the H100 suite, `selftest`); on a
/// software adapter (CI) all but the sorted wavefront over the
/// structure-of-arrays path state, whose two parts each run there (the
/// sort over the array-of-structs state, the path state's reads in
/// `wavefront-soa`) and whose kernels cost CI's time a compile each.
/// `TWINTRACE_GATES=full` asks for all of them on a software adapter too
/// ([`super::harness::full_gates`]).
pub fn gate_schedules(ctx: &GpuContext) -> Vec<Schedule> {
    let full = super::harness::full_gates(ctx);
    let soa_sorted = Schedule::Wavefront(gpu::PathLayout::Soa, gpu::ShadeOrder::Material);
    Schedule::WAVES
        .into_iter()
        .filter(|&s| full || s != soa_sorted)
        .collect()
}

/// The splits a schedule is compared in.
pub fn wave_slots(schedule: Schedule) -> &'static [Option<u32>] {
    match schedule {
        Schedule::Wavefront(_, gpu::ShadeOrder::Material) => &SORTED_WAVE_SLOTS,
        _ => &WAVE_SLOTS,
    }
}

/// The megakernel's film and those of the wave schedules `schedules`
/// (`Schedule::WAVES`: each path layout and shade order, and the path
/// megakernel), each split as [`wave_slots`] says, for one scene and
/// estimator under the module's rule, every kernel built for the scene's
/// own features; `program` is the wavefront's WGSL
/// (`gpu::shader::wavefront_source`, or a test's edit, compiled for the
/// schedules that run it only: each kernel of a mutated program is a
/// compile no shader cache holds). Returns the pixels not bit for bit and
/// their largest mean difference in ulp.
pub fn compare_schedules(
    ctx: &GpuContext,
    (spec, scene): (&str, &Scene),
    integrator: Integrator,
    program: &str,
    schedules: &[Schedule],
) -> Result<(usize, u64), String> {
    let (mega_build, mega) = own_oracle((ctx, spec, scene), integrator, program, "the megakernel")?;
    let mut inexact = Inexact::default();
    for &schedule in schedules {
        let build = Build {
            schedule,
            ..mega_build
        };
        inexact.add(compare_schedule((ctx, spec, scene), &mega, build)?);
    }
    Ok((inexact.pixels, inexact.mean_ulp))
}

/// [`compare_schedules`] for one wave schedule (`build`'s), against the
/// megakernel's film already rendered.
fn compare_schedule(
    (ctx, spec, scene): (&GpuContext, &str, &Scene),
    mega: &[u64],
    build: Build,
) -> Result<(usize, u64), String> {
    let (integrator, schedule) = (build.integrator, build.schedule);
    let films = variant_film_bits(ctx, scene, build, wave_slots(schedule))?;
    let mut inexact = Inexact::default();
    for (wave, &slots) in films.iter().zip(wave_slots(schedule)) {
        compare_films(mega, wave, &mut inexact).map_err(|e| {
            format!(
                "{spec} ({}, {}, {} slots a wave): {e}",
                integrator.name(),
                schedule.name(),
                slots.map_or("default".to_string(), |s| s.to_string()),
            )
        })?;
    }
    Ok((inexact.pixels, inexact.mean_ulp))
}

/// The megakernel's film and each wave schedule's ([`gate_schedules`]) for a kernel built for
/// `features`, which lack one the scene uses, so that samples are
/// poisoned: every schedule must count the poisoned samples as the
/// megakernel does (the poison of a traversal or a shading step crosses
/// the wavefront's kernels in its hit records and path flags).
pub fn compare_poisoned(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    integrator: Integrator,
    program: &str,
    features: gpu::Features,
) -> Result<(), String> {
    let mega = film_bits(ctx, scene, integrator, features)?;
    let (_, rejected) = counts(&mega);
    if rejected == 0 {
        return Err(format!(
            "{spec} ({}, features {:?}): the megakernel poisoned no sample",
            integrator.name(),
            features.names()
        ));
    }
    let mut inexact = Inexact::default();
    for schedule in gate_schedules(ctx) {
        let build = Build {
            schedule,
            ..Build::megakernel(program, integrator, features)
        };
        let films = variant_film_bits(ctx, scene, build, &[None])?;
        compare_films(&mega, &films[0], &mut inexact).map_err(|e| {
            format!(
                "{spec} ({}, {}, features {:?}): {e}",
                integrator.name(),
                schedule.name(),
                features.names()
            )
        })?;
    }
    Ok(())
}

/// Every scene of [`super::specialization::scene_specs`], under
/// [`super::specialization::gate_estimators`]: wavefront == megakernel
/// under [`super::film_words`]. Every scene is compared; the error lists each
/// one that fails.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let program = gpu::shader::wavefront_source();
    let scenes = gate_scenes(ctx, "the megakernel")?;
    let schedules = gate_schedules(ctx);
    let (_, inexact) = every_variant(&scenes, &schedules, |s, integrator, schedule| {
        let build = Build {
            schedule,
            ..s.build(&program, integrator)
        };
        Some(compare_schedule(
            (ctx, &s.spec, &s.scene),
            s.oracle(integrator),
            build,
        ))
    })?;
    let (width, height, _) = SIZE;
    let renders: usize = schedules.iter().map(|&s| wave_slots(s).len()).sum();
    let estimators = super::specialization::gate_estimators(ctx).len();
    let compared = scenes.len() * estimators * renders * (width * height) as usize;
    let names: Vec<String> = schedules
        .iter()
        .map(|&s| {
            let n = wave_slots(s).len();
            format!("{} ({n} split{})", s.name(), if n == 1 { "" } else { "s" })
        })
        .collect();
    Ok(format!(
        "{} scenes × {} × the wave schedules {}: their films equal the megakernel's {} ({})",
        scenes.len(),
        super::specialization::estimator_words(ctx),
        names.join(", "),
        inexact.exactness(compared),
        gate_kernel_words(ctx)
    ))
}
