//! The specialized render kernel against the general one: the kernel
//! built without the code of the features a scene does not use
//! (`gpu::features`) must render every fixture and built-in scene as the
//! kernel with every feature's code does, with either estimator, under
//! [`super::film_words`]'s rule (every pixel's count and rejected samples
//! equal; means, M2 and M3 bit for bit, or the means a few ulp apart where
//! the driver contracts the two programs' shared arithmetic differently:
//! lavapipe renders them bit for bit). Not a CPU twin: the general kernel
//! is the oracle (on a software adapter, the kernel of every gate scene's
//! features: [`gate_oracle_features`]), and this holds a user's driver to
//! what lavapipe and the H100 do.

use super::film_words::{compare_words, counts, film_words, Inexact};
use super::harness::Outcome;
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
/// (tests/gpu/gpu_specialization.rs leaves each one out in turn and sees the
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
/// megakernel, switch dispatch, binary walk over indexed leaves, built
/// for `features`: the scene's own, [`Features::of`], where one scene is
/// judged; [`GateScene::features`] where every gate scene is), checked
/// not to be vacuous: every sample counted, none rejected (a poisoned
/// sample in both films would compare equal). `oracle` names it in the
/// error.
pub fn oracle_film(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    (integrator, features): (Integrator, Features),
    oracle: &str,
) -> Result<Vec<u64>, String> {
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

/// The oracle's build of `scene` at `features` over `program` (what a
/// gate changes one axis of), and its film ([`oracle_film`]; `oracle`
/// names it in errors).
pub fn oracle_build<'a>(
    (ctx, spec, scene): (&GpuContext, &str, &Scene),
    (integrator, features): (Integrator, Features),
    program: &'a str,
    oracle: &str,
) -> Result<(Build<'a>, Vec<u64>), String> {
    let build = Build::megakernel(program, integrator, features);
    let film = oracle_film(ctx, spec, scene, (integrator, features), oracle)?;
    Ok((build, film))
}

/// [`oracle_build`] for a gate that judges one scene (a mutant's): at the
/// scene's own features ([`Features::of`], the smallest kernel that runs
/// its code).
pub fn own_oracle<'a>(
    (ctx, spec, scene): (&GpuContext, &str, &Scene),
    integrator: Integrator,
    program: &'a str,
    oracle: &str,
) -> Result<(Build<'a>, Vec<u64>), String> {
    let features = Features::of(scene);
    oracle_build((ctx, spec, scene), (integrator, features), program, oracle)
}

/// The features the GPU-against-GPU gates ([`super::checks`],
/// [`super::dispatch`], [`super::traversal`]'s films,
/// [`super::wavefront`]) build a scene's kernels for when they judge
/// every gate scene ([`gate_scenes`]) on `ctx`, given `used`, every
/// feature some gate scene uses. On hardware the scene's own (the default
/// variant's specialization, a compile a scene). On a software adapter
/// (lavapipe, CI) `used` for every scene: one kernel a variant serves
/// them all, where a compile costs seconds to tens of seconds of CPU and
/// was most of what those gates cost. Not the general kernel
/// ([`Features::ALL`]): the code of features no gate scene uses (the
/// Mitsuba models among them) would never run, and it tripled each compile (the
/// Cornell box's checked megakernel, MIS, lavapipe's cache off: 36.3 s
/// general, 12.3 s for the gate scenes' features, 4.2 s specialized).
/// The specialized kernel is held to the general one on every scene by
/// [`all_scenes`], so what those gates show on lavapipe of a variant
/// holds for it specialized too, but for a slip that only specialization
/// and the variant together make: the H100 suite and `selftest` on a GPU
/// run the specialized kernels. `TWINTRACE_GATES=full` asks for them on a
/// software adapter too. A gate that judges one scene (a mutant's) builds
/// that scene's own kernels anywhere: the smallest that run its code.
pub fn gate_features(ctx: &GpuContext, scene: &Scene, used: Features) -> Features {
    if super::harness::full_gates(ctx) {
        Features::of(scene)
    } else {
        used
    }
}

/// What the gates' summary lines say of [`gate_features`].
pub fn gate_kernel_words(ctx: &GpuContext) -> &'static str {
    if super::harness::full_gates(ctx) {
        "kernels specialized to each scene"
    } else {
        "one kernel a variant for every scene, built for the features they use (a software adapter)"
    }
}

/// A scene of [`scene_specs`], the features its kernels are built for
/// ([`gate_features`]) and its oracle's films ([`oracle_film`]), one for
/// each estimator of [`gate_estimators`].
pub struct GateScene {
    pub spec: String,
    pub scene: Scene,
    pub features: Features,
    oracle: Vec<(Integrator, Vec<u64>)>,
}

impl GateScene {
    /// The oracle's film with `integrator`, one of [`gate_estimators`].
    pub fn oracle(&self, integrator: Integrator) -> &[u64] {
        let film = self.oracle.iter().find(|(i, _)| *i == integrator);
        &film.expect("the oracle rendered every gate estimator").1
    }

    /// What a gate builds for this scene with `integrator` over `program`:
    /// [`Build::megakernel`] at the scene's features, one axis of which
    /// the gate changes.
    pub fn build<'a>(&self, program: &'a str, integrator: Integrator) -> Build<'a> {
        Build::megakernel(program, integrator, self.features)
    }
}

/// Every feature some scene of `scenes` uses.
fn union_of<'s>(scenes: impl IntoIterator<Item = &'s Scene>) -> Features {
    Features(
        scenes
            .into_iter()
            .fold(0, |bits, s| bits | Features::of(s).0),
    )
}

/// Every feature some scene of `specs` uses.
pub fn features_used(specs: &[String]) -> Result<Features, String> {
    let mut scenes = Vec::with_capacity(specs.len());
    for spec in specs {
        scenes.push(reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))?);
    }
    Ok(union_of(&scenes))
}

/// Every scene of [`scene_specs`] with its oracle's films (`oracle` names
/// the oracle in errors): an estimator at a time, the scenes in parallel
/// ([`super::harness::par_map`]), so that a kernel shared by every scene
/// ([`gate_features`]) is compiled once for all of them.
pub fn gate_scenes(ctx: &GpuContext, oracle: &str) -> Result<Vec<GateScene>, String> {
    let specs = scene_specs()?;
    let loaded = super::harness::par_map(&specs, |spec| {
        reference::load_scene(spec).map_err(|e| format!("{spec}: {e}"))
    });
    let loaded = loaded.into_iter().collect::<Result<Vec<_>, String>>()?;
    let used = union_of(&loaded);
    let mut scenes: Vec<GateScene> = specs
        .into_iter()
        .zip(loaded)
        .map(|(spec, scene)| GateScene {
            features: gate_features(ctx, &scene, used),
            spec,
            scene,
            oracle: Vec::new(),
        })
        .collect();
    for &integrator in gate_estimators(ctx) {
        let films = super::harness::par_map(&scenes, |s| {
            oracle_film(ctx, &s.spec, &s.scene, (integrator, s.features), oracle)
        });
        for (s, film) in scenes.iter_mut().zip(films) {
            s.oracle.push((integrator, film?));
        }
    }
    Ok(scenes)
}

/// The estimators the GPU-against-GPU gates compare films under: both
/// where the gates specialize (hardware, `TWINTRACE_GATES=full`); on a
/// software adapter the default's alone (MIS, what `render`, `selftest`
/// and `perf` run; its paths sample the BSDF, the lights and both kinds
/// of ray through the walk), as CI's statistical gates judge the default
/// variant. Each estimator's film there is a kernel of tens of seconds to
/// compile for every variant; the BSDF estimator's path loop is held to
/// the reference by the statistical gates of `mis_matches_bsdf`, and its
/// variants are compared on hardware.
pub fn gate_estimators(ctx: &GpuContext) -> &'static [Integrator] {
    const DEFAULT: [Integrator; 1] = [gpu::Variant::DEFAULT.integrator];
    if super::harness::full_gates(ctx) {
        &Integrator::ALL
    } else {
        &DEFAULT
    }
}

/// "both estimators", or the one [`gate_estimators`] names.
pub fn estimator_words(ctx: &GpuContext) -> String {
    match gate_estimators(ctx) {
        [one] => format!("the {} estimator alone", one.name()),
        all => format!("{} estimators", all.len()),
    }
}

/// Runs `compare(scene, estimator, variant)` for every variant of
/// `variants`, the estimators of the scenes' oracle films
/// ([`gate_estimators`]) and every scene of `scenes`, variant by
/// variant and estimator by estimator with the scenes in parallel (one
/// kernel a variant and estimator, where [`gate_features`] shares one);
/// `compare` returns `None` for a case it does not judge. Returns the
/// cases compared and the pixels not bit for bit; every case is
/// compared, and the error lists each one that fails.
pub fn every_variant<V: Copy + Sync>(
    scenes: &[GateScene],
    variants: &[V],
    compare: impl Fn(&GateScene, Integrator, V) -> Option<Result<(usize, u64), String>> + Sync,
) -> Result<(usize, super::film_words::Inexact), String> {
    let mut failures = Vec::new();
    let mut inexact = super::film_words::Inexact::default();
    let mut cases = 0;
    let estimators: Vec<Integrator> = scenes
        .first()
        .map_or(Vec::new(), |s| s.oracle.iter().map(|(i, _)| *i).collect());
    for &variant in variants {
        for &integrator in &estimators {
            let outcomes = super::harness::par_map(scenes, |s| compare(s, integrator, variant));
            for found in outcomes.into_iter().flatten() {
                cases += 1;
                match found {
                    Ok(found) => inexact.add(found),
                    Err(e) => failures.push(e),
                }
            }
        }
    }
    if !failures.is_empty() {
        return Err(failures.join("; "));
    }
    Ok((cases, inexact))
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

/// [`variant_film_bits`] rendered once, at the adapter's default wave
/// slots.
pub fn variant_film(ctx: &GpuContext, scene: &Scene, build: Build) -> Result<Vec<u64>, String> {
    Ok(variant_film_bits(ctx, scene, build, &[None])?.remove(0))
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
    let made = gpu::RendererBuild {
        variant: gpu::Variant {
            integrator: build.integrator,
            schedule: build.schedule,
            dispatch: build.dispatch,
            checks: build.checks,
            ..gpu::Variant::DEFAULT
        },
        program: Some(build.program),
        packed: Some(packed),
        features: Some(build.features),
        records_only: false,
    };
    let mut renderer = gpu::GpuRenderer::new(ctx, scene, made).map_err(|e| e.to_string())?;
    // The renderer runs the walk and layouts it was given: a film that
    // equals the binary walk's says nothing of a walk never run.
    let runs = (
        renderer.traversal(),
        renderer.node_layout(),
        renderer.leaves(),
    );
    let asked = ((packed.traversal, None), packed.node_layout, packed.leaves);
    if runs != asked {
        return Err(format!(
            "the renderer reports {runs:?} where {asked:?} was built"
        ));
    }
    let (width, height, spp) = SIZE;
    let settings = RenderSettings {
        width,
        height,
        spp,
        max_depth: 8,
        // The paths the wave schedules' ulp rule was measured on
        // (`super::film_words::MEAN_ULP_MAX`): on the H100 the Sobol'
        // sampler's paths left a pixel of four-materials 6 ulp apart
        // between the wavefront and the megakernel, where the independent
        // sampler's leave at most 2. Both samplers' numbers come from
        // the same WGSL in every variant, held to the reference's by the
        // rng twin bit for bit.
        sampler: crate::compare::gate::GATE_SAMPLER,
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

/// The scenes the specialization gate judges: every scene of
/// [`scene_specs`] where the gates judge in full (hardware, or
/// `TWINTRACE_GATES=full`: [`super::harness::full_gates`]); on a software adapter, where each scene's
/// specialized kernel is a compile of tens of seconds, the scenes in
/// order that bring a feature no earlier one has, so that every feature
/// any scene uses is still compiled out of a kernel and compared (the
/// scenes left out only combine features the others have).
pub fn gate_specs(ctx: &GpuContext) -> Result<Vec<(String, Scene)>, String> {
    let every = super::harness::full_gates(ctx);
    let mut covered = 0u64;
    let mut out = Vec::new();
    for spec in scene_specs()? {
        let scene = reference::load_scene(&spec).map_err(|e| format!("{spec}: {e}"))?;
        let features = Kernel::Specialized.features(&scene).0;
        if every || features & !covered != 0 {
            covered |= features;
            out.push((spec, scene));
        }
    }
    Ok(out)
}

/// The kernel the specialization gate holds each scene's own to: the
/// general kernel ([`Features::ALL`]) where the gates judge in full
/// (hardware, `TWINTRACE_GATES=full`); on a software adapter the kernel of
/// every feature some gate scene uses, the oracle the other
/// GPU-against-GPU gates build there ([`gate_features`]), so that CI
/// compiles no kernel for this gate's oracle alone. The general kernel's
/// further code (the features no gate scene uses: the Mitsuba models,
/// instances, ...) never runs on these scenes; what CI then does not see
/// is a slip in that code that changes the other features' results, which
/// the hardware suite and `selftest` on a GPU judge. On lavapipe the
/// general megakernel, checked, was the largest compile of CI: 96.5 s for
/// the Cornell box's BSDF kernel with the cache off (docs/benchmarks.md,
/// "CI's time").
pub fn gate_oracle_features(ctx: &GpuContext) -> Result<Features, String> {
    if super::harness::full_gates(ctx) {
        Ok(Features::ALL)
    } else {
        features_used(&scene_specs()?)
    }
}

/// The scenes of [`gate_specs`] under [`gate_estimators`]: specialized ==
/// the oracle's ([`gate_oracle_features`]: the general kernel on
/// hardware).
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let scenes = gate_specs(ctx)?;
    let oracle = gate_oracle_features(ctx)?;
    let (width, height, spp) = SIZE;
    // Scenes in parallel (super::harness::par_map); the first failure in scene order.
    let outcomes = super::harness::par_map(
        &scenes,
        |(spec, scene)| -> Result<(usize, u64), String> {
            let features = Kernel::Specialized.features(scene);
            let mut inexact = Inexact::default();
            for &integrator in gate_estimators(ctx) {
                let general = film_bits(ctx, scene, integrator, oracle)?;
                let special = film_bits(ctx, scene, integrator, features)?;
                // Not a vacuous comparison: the general kernel counted every
                // sample (a poisoned or non-finite one in both films would
                // compare equal).
                let (counted, rejected) = counts(&general);
                if counted != (width * height * spp) as u64 || rejected != 0 {
                    return Err(format!(
                    "{spec} ({}): the oracle kernel's film counted {counted} samples and rejected {rejected}",
                    integrator.name()
                ));
                }
                let found = compare_words(&general, &special).map_err(|e| {
                format!(
                    "{spec} ({}, features {:?}): the specialized kernel's film differs from the oracle kernel's: {e}",
                    integrator.name(),
                    features.names()
                )
            })?;
                inexact.add(found);
            }
            Ok((inexact.pixels, inexact.mean_ulp))
        },
    );
    let mut inexact = Inexact::default();
    for found in outcomes {
        inexact.add(found?);
    }
    let total = scene_specs()?.len();
    let compared = scenes.len() * gate_estimators(ctx).len() * (width * height) as usize;
    Ok(format!(
        "{} of {total} scenes × {} ({}): the specialized kernel's films equal {} {}",
        scenes.len(),
        estimator_words(ctx),
        if scenes.len() == total {
            "every scene"
        } else {
            "each bringing a feature the earlier ones lack, a software adapter"
        },
        if oracle == Features::ALL {
            "the general kernel's"
        } else {
            "those of the kernel of every gate scene's features (a software adapter)"
        },
        inexact.exactness(compared)
    ))
}
