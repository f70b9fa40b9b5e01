//! The specialized render kernel against the general one: the kernel
//! built without the code of the features a scene does not use
//! (`gpu::features`) must render every fixture and built-in scene bit for
//! bit as the kernel with every feature's code does, with either
//! estimator (the same film: every pixel's count, rejected samples, mean
//! and moments). Not a CPU twin: the general kernel is the oracle, and
//! this holds a user's driver to what lavapipe and the H100 do (its
//! compiler could fuse or order the two kernels' shared code differently).

use super::Outcome;
use crate::compare::gate::workspace_root;
use gpu::features::{Features, Kernel};
use gpu::{Dispatch, GpuContext, LeafLayout, NodeLayout, Schedule, Traversal};
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};

/// Every fixture scene (its path) and built-in (its name), as
/// `reference::load_scene` takes them: fixtures sorted, then built-ins.
pub fn scene_specs() -> Result<Vec<String>, String> {
    let dir = workspace_root().join("fixtures/scenes");
    let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut specs = Vec::new();
    for e in entries {
        let path = e.map_err(|e| e.to_string())?.path();
        if path.extension().is_some_and(|x| x == "json") {
            specs.push(path.to_string_lossy().into_owned());
        }
    }
    specs.sort();
    specs.extend(reference::builtin::NAMES.iter().map(|s| s.to_string()));
    Ok(specs)
}

/// Width, height and samples per pixel of the compared renders (depth 8):
/// 384 paths a scene reach every feature each of these scenes uses
/// (tests/gpu_specialization.rs leaves each one out in turn and sees the
/// film change); the comparison is exact, so more samples would only
/// reach rarer paths.
pub const SIZE: (u32, u32, u32) = (16, 12, 2);

/// The film of `scene` rendered by the kernel built for `features`, as
/// words: per pixel the count, the rejected samples, then the mean, M2
/// and M3 as f64 bits ([`WORDS_PER_PIXEL`]).
pub fn film_bits(
    ctx: &GpuContext,
    scene: &Scene,
    integrator: Integrator,
    features: Features,
) -> Result<Vec<u64>, String> {
    let program = gpu::shader::render_source();
    let build = Build::megakernel(&program, integrator, features);
    let mut films = variant_film_bits(ctx, scene, build, &[None])?;
    Ok(films.remove(0))
}

/// The oracle's film of `scene` for the GPU-against-GPU gates (the
/// megakernel, switch dispatch, binary walk over indexed leaves, kernel
/// specialized to the scene), checked not to be vacuous: every sample
/// counted, none rejected (a poisoned sample in both films would compare
/// equal). `oracle` names it in the error.
pub fn oracle_film(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    integrator: Integrator,
    oracle: &str,
) -> Result<Vec<u64>, String> {
    let features = Kernel::Specialized.features(scene);
    let film = film_bits(ctx, scene, integrator, features)?;
    let (width, height, spp) = SIZE;
    let (counted, rejected) = counts(&film);
    if counted != (width * height * spp) as u64 || rejected != 0 {
        return Err(format!(
            "{spec} ({}): {oracle}'s film counted {counted} samples and rejected {rejected}",
            integrator.name()
        ));
    }
    Ok(film)
}

/// Runs `compare` on every scene of [`scene_specs`] with both estimators
/// and gathers what was not bit for bit: the number of scenes, or every
/// failure joined. Every scene is compared, so the error lists each one
/// that fails.
pub fn every_scene(
    compare: impl Fn(&str, &Scene, Integrator) -> Result<(usize, u64), String> + Sync,
) -> Result<(usize, super::wavefront::Inexact), String> {
    let specs = scene_specs()?;
    let mut failures = Vec::new();
    let mut inexact = super::wavefront::Inexact::default();
    // Scenes in parallel (super::par_map), each with both estimators.
    let outcomes = super::par_map(&specs, |spec| {
        let scene = reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))?;
        Ok::<_, String>(
            Integrator::ALL
                .map(|integrator| compare(spec, &scene, integrator))
                .to_vec(),
        )
    });
    for outcome in outcomes {
        for found in outcome? {
            match found {
                Ok(found) => inexact.add(found),
                Err(e) => failures.push(e),
            }
        }
    }
    if !failures.is_empty() {
        return Err(failures.join("; "));
    }
    Ok((specs.len(), inexact))
}

/// What a compared render is built with.
#[derive(Clone, Copy, Debug)]
pub struct Build<'a> {
    /// The schedule's WGSL (`gpu::shader::render_source` or
    /// `wavefront_source`), or a test's edit of it.
    pub program: &'a str,
    pub integrator: Integrator,
    pub features: Features,
    pub schedule: Schedule,
    pub traversal: Traversal,
    pub nodes: NodeLayout,
    pub leaves: LeafLayout,
    pub dispatch: Dispatch,
    pub checks: gpu::Checks,
}

impl<'a> Build<'a> {
    /// The megakernel with the binary walk and indexed leaves, checked by
    /// wgpu at run time (the oracle of the others).
    pub fn megakernel(program: &'a str, integrator: Integrator, features: Features) -> Self {
        Build {
            program,
            integrator,
            features,
            schedule: Schedule::Megakernel,
            traversal: Traversal::Binary,
            nodes: NodeLayout::Aos,
            leaves: LeafLayout::Indexed,
            dispatch: Dispatch::Switch,
            checks: gpu::Checks::Checked,
        }
    }
}

/// [`film_bits`] for any variant: rendered once for each of `wave_slots`
/// (the wave schedules' slots per wave; `None`, the adapter's default),
/// with one compiled kernel.
pub fn variant_film_bits(
    ctx: &GpuContext,
    scene: &Scene,
    build: Build,
    wave_slots: &[Option<u32>],
) -> Result<Vec<Vec<u64>>, String> {
    let packed = gpu::scene_buffers::PackedScene::for_walk(scene, build.traversal, build.leaves)
        .with_node_layout(build.nodes);
    if let Some(why) = &packed.traversal_note {
        return Err(why.clone());
    }
    packed_film_bits(ctx, scene, &packed, build, wave_slots)
}

/// [`variant_film_bits`] of records already packed (a walk's, or a
/// test's edit of them): `build`'s walk and layouts are `packed`'s.
pub fn packed_film_bits(
    ctx: &GpuContext,
    scene: &Scene,
    packed: &gpu::scene_buffers::PackedScene,
    build: Build,
    wave_slots: &[Option<u32>],
) -> Result<Vec<Vec<u64>>, String> {
    let spec = gpu::KernelSpec {
        integrator: build.integrator,
        features: build.features,
        schedule: build.schedule,
        dispatch: build.dispatch,
        checks: build.checks,
    };
    let mut renderer = gpu::GpuRenderer::build_scheduled(ctx, packed, scene, build.program, spec)
        .map_err(|e| e.to_string())?;
    let (width, height, spp) = SIZE;
    let settings = RenderSettings {
        width,
        height,
        spp,
        max_depth: 8,
        ..scene.render_settings()
    };
    let mut films = Vec::new();
    for &slots in wave_slots {
        renderer.set_wave_slots(slots);
        let film = renderer
            .render(&settings, &|_, _| {})
            .map_err(|e| e.to_string())?
            .film;
        films.push(film_words(&film));
    }
    Ok(films)
}

/// A film as words: per pixel the count, the rejected samples, then the
/// mean, M2 and M3 as f64 bits ([`WORDS_PER_PIXEL`]).
pub fn film_words(film: &reference::film::Film) -> Vec<u64> {
    film.pixels
        .iter()
        .flat_map(|p| {
            let moments = [p.mean, p.m2, p.m3].map(|v| v.to_array().map(f64::to_bits));
            [p.count as u64, p.nonfinite as u64]
                .into_iter()
                .chain(moments.into_iter().flatten())
        })
        .collect()
}

/// The first pixel where two [`film_bits`] films differ.
pub fn first_difference(a: &[u64], b: &[u64]) -> usize {
    a.chunks(WORDS_PER_PIXEL)
        .zip(b.chunks(WORDS_PER_PIXEL))
        .position(|(x, y)| x != y)
        .unwrap_or(0)
}

/// Words per pixel of [`film_bits`].
pub const WORDS_PER_PIXEL: usize = 11;

/// The samples counted and rejected in a [`film_bits`] film.
pub fn counts(bits: &[u64]) -> (u64, u64) {
    bits.chunks(WORDS_PER_PIXEL)
        .fold((0, 0), |(n, r), p| (n + p[0], r + p[1]))
}

/// Every scene of [`scene_specs`], both estimators: specialized == general.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let specs = scene_specs()?;
    let (width, height, spp) = SIZE;
    // Scenes in parallel (super::par_map); the first failure in scene order.
    let outcomes = super::par_map(&specs, |spec| -> Result<(), String> {
        let scene = reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))?;
        let features = Kernel::Specialized.features(&scene);
        for integrator in Integrator::ALL {
            let general = film_bits(ctx, &scene, integrator, Features::ALL)?;
            let special = film_bits(ctx, &scene, integrator, features)?;
            // Not a vacuous comparison: the general kernel counted every
            // sample (a poisoned or non-finite one in both films would
            // compare equal).
            let (counted, rejected) = counts(&general);
            if counted != (width * height * spp) as u64 || rejected != 0 {
                return Err(format!(
                    "{spec} ({}): the general kernel's film counted {counted} samples and rejected {rejected}",
                    integrator.name()
                ));
            }
            if general != special {
                let pixel = first_difference(&general, &special);
                return Err(format!(
                    "{spec} ({}, features {:?}): the specialized kernel's film differs from the general kernel's, first at pixel {pixel}",
                    integrator.name(),
                    features.names()
                ));
            }
        }
        Ok(())
    });
    outcomes.into_iter().collect::<Result<Vec<()>, String>>()?;
    Ok(format!(
        "{} scenes × 2 estimators: the specialized kernel's films equal the general kernel's bit for bit",
        specs.len()
    ))
}
