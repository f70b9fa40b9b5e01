//! The wavefront variant (`gpu::wavefront`: generate / extend / shade /
//! accumulate kernels over compacted queues of live paths) renders every
//! fixture and built-in scene as the megakernel does (bit for bit, but
//! for means a few ulp apart where a driver contracts the two programs'
//! arithmetic differently: `twintrace::twins::wavefront`), with
//! either estimator, either path layout and either shade order, its
//! renders split into waves three ways (the sorted ones one way) (`twintrace::twins::wavefront`, also run by `twintrace
//! selftest`). Mutants of the wavefront's WGSL prove the comparison can
//! fail: each is a plausible bookkeeping slip of a wavefront renderer.

use crate::common;
use gpu::features::{feature, Features};
use gpu::{PathLayout, Schedule, ShadeOrder};
use reference::integrator::Integrator;
use twintrace::twins::wavefront::{all_scenes, compare_poisoned, compare_schedules};

#[test]
fn wavefront_renders_every_scene_as_the_megakernel() {
    match all_scenes(common::gpu()) {
        Ok(summary) => println!("{summary}"),
        Err(e) => panic!("{e}"),
    }
}

/// (what the slip is, WGSL replaced, its replacement, scene, estimator,
/// the schedules whose kernels run the code: a mutant is compiled for
/// those only, each of its kernels a compile no shader cache holds).
type Mutant = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    Integrator,
    &'static [Schedule],
);

/// Every wave schedule, for a mutant of code their kernels share (the
/// first schedule that fails ends the comparison).
const ALL: &[Schedule] = &Schedule::WAVES;

/// A sorted wavefront ([`gpu::ShadeOrder::Material`]), for mutants of
/// its sort (both path layouts run the same sort).
const SORTED: &[Schedule] = &[Schedule::Wavefront(PathLayout::Aos, ShadeOrder::Material)];

const MUTANTS: &[Mutant] = &[
    (
        "the accumulate kernel reads the slots pixel-major (they are sample-major)",
        "let slot = j * params.wave_pixel_count + p;",
        "let slot = p * params.sample_count + j;",
        "cornell",
        Integrator::Bsdf,
        ALL,
    ),
    (
        "a shadow ray is queued as its path's extension ray",
        "wave_queues.entries[r] = (slot << 1u) | 1u;",
        "wave_queues.entries[r] = slot << 1u;",
        "cornell",
        Integrator::Mis,
        ALL,
    ),
    (
        "a run of pixels forgets where it starts (only a split render shows it)",
        "return params.band_row * params.width + params.wave_pixel_start + slot % params.wave_pixel_count;",
        "return params.band_row * params.width + slot % params.wave_pixel_count;",
        "cornell",
        Integrator::Bsdf,
        ALL,
    ),
    (
        "a shaded vertex draws the randoms of the vertex before it",
        "let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);\n    let s = wrapped_scatter",
        "let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, segment);\n    let s = wrapped_scatter",
        "rtow-final",
        Integrator::Bsdf,
        ALL,
    ),
    (
        "the sky's light on a BSDF path 10^-6 too bright (8 ulp: beyond the ulp rule)",
        "(*v).radiance += (*v).throughput * evaluate_background(ray.direction);",
        "(*v).radiance += (*v).throughput * evaluate_background(ray.direction) * 1.000001;",
        "rtow-final",
        Integrator::Bsdf,
        ALL,
    ),
    (
        "the path megakernel traces the next sample's camera ray",
        "let l = trace(camera_ray(pixel % params.width, pixel / params.width, sample), pixel, sample);",
        "let l = trace(camera_ray(pixel % params.width, pixel / params.width, sample + 1u), pixel, sample);",
        "cornell",
        Integrator::Bsdf,
        &[Schedule::PathMegakernel],
    ),
    (
        "the MIS weight of emission forgets the BSDF density of the ray that found it",
        "v.from_pdf = path_f(slot, PF_FROM_PDF);",
        "v.from_pdf = 0.0;",
        "cornell",
        Integrator::Mis,
        ALL,
    ),
    (
        "the sort's bucket starts are inclusive sums (each run starts a bucket late)",
        "wg_bucket_start[lid] -= n;",
        "",
        "rtow-final",
        Integrator::Bsdf,
        SORTED,
    ),
    (
        "the sort's bucket counts are not cleared for the next bounce",
        "atomicStore(&wave_queues.bucket_count[b], 0u);",
        "",
        "rtow-final",
        Integrator::Bsdf,
        SORTED,
    ),
    (
        "a workgroup's paths in a bucket may share a rank (read before the add, not returned by it)",
        "rank = atomicAdd(&wg_bucket_paths[bucket], 1u);",
        "rank = atomicLoad(&wg_bucket_paths[bucket]);\n        atomicAdd(&wg_bucket_paths[bucket], 1u);",
        "cornell",
        Integrator::Mis,
        SORTED,
    ),
];

/// A mutant is caught when the gate reports a film difference (not when
/// the mutant fails to compile or the oracle fails).
fn caught(outcome: Result<(), String>) -> bool {
    matches!(outcome, Err(e) if e.contains(": pixel "))
}

#[test]
fn wavefront_mutants_are_caught() {
    let ctx = common::gpu();
    let program = gpu::shader::wavefront_source();
    for &(slip, from, to, spec, integrator, schedules) in MUTANTS {
        assert_eq!(
            program.matches(from).count(),
            1,
            "{slip}: `{from}` not found once"
        );
        let mutant = program.replace(from, to);
        let scene = reference::load_scene(spec).unwrap();
        let outcome =
            compare_schedules(ctx, (spec, &scene), integrator, &mutant, schedules).map(|_| ());
        assert!(
            caught(outcome.clone()),
            "{slip}: the wavefront gate passed it ({outcome:?})"
        );
    }
}

/// The Cornell box's kernels without Lambertian (shading poisons) or
/// without quads (the traversal poisons).
fn poisoning_features(scene: &reference::Scene) -> Vec<Features> {
    let all = Features::of(scene);
    [feature::LAMBERTIAN, feature::QUADS]
        .into_iter()
        .map(|bit| Features(all.0 & !bit))
        .collect()
}

#[test]
fn wave_schedules_count_poisoned_samples_as_the_megakernel_does() {
    let ctx = common::gpu();
    let program = gpu::shader::wavefront_source();
    let scene = reference::load_scene("cornell").unwrap();
    for features in poisoning_features(&scene) {
        for integrator in Integrator::ALL {
            if let Err(e) = compare_poisoned(ctx, "cornell", &scene, integrator, &program, features)
            {
                panic!("{e}");
            }
        }
    }
}

#[test]
fn a_traversal_poison_lost_between_kernels_is_caught() {
    let ctx = common::gpu();
    let program = gpu::shader::wavefront_source();
    let from = "select(0u, HIT_FOUND, h.hit) | select(0u, HIT_POISONED, poisoned)";
    assert_eq!(program.matches(from).count(), 1);
    let mutant = program.replace(from, "select(0u, HIT_FOUND, h.hit)");
    let scene = reference::load_scene("cornell").unwrap();
    let without_quads = poisoning_features(&scene)[1];
    let outcome = compare_poisoned(
        ctx,
        "cornell",
        &scene,
        Integrator::Bsdf,
        &mutant,
        without_quads,
    );
    assert!(
        caught(outcome.clone()),
        "the dropped poison passed ({outcome:?})"
    );
}

/// A wave of more than 65,535 workgroups of 64 paths is dispatched as a
/// two-dimensional grid (the kernels' flat index): one wave of 4,218,880
/// paths of the path megakernel (4 words a slot: 69 MB, within lavapipe's
/// 128 MB binding limit; the wavefront's 168-byte slots are not) on a
/// scene whose rays nearly all miss (a small far sphere under a sky), so
/// that lavapipe renders it in seconds, against the megakernel. A flat
/// index that ignored the second row leaves the last 24,640 paths (samples
/// 1024–1029) untraced: their zeros change every pixel's mean.
#[test]
fn a_wave_dispatched_as_a_two_dimensional_grid_renders_as_the_megakernel() {
    let ctx = common::gpu();
    let scene = twintrace::twins::hits::far_small_shapes(0)
        .edited(|a| {
            a.background = reference::background::Background::Sky {
                horizon: glam::Vec3::ONE,
                zenith: glam::Vec3::new(0.5, 0.7, 1.0),
            }
        })
        .unwrap();
    // 64 · 64 · 1030 = 4,218,880 paths: 65,920 workgroups, two rows.
    let settings = reference::RenderSettings {
        width: 64,
        height: 64,
        spp: 1030,
        max_depth: 4,
        ..scene.render_settings()
    };
    let paths = 64 * 64 * 1030u32;
    assert!(gpu::wavefront::grid(paths as u64).1 == 2);
    let film = |schedule| {
        let variant = gpu::Variant::plain(Integrator::Bsdf, schedule);
        let mut r = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(variant)).unwrap();
        r.set_wave_slots(Some(paths));
        let out = r.render(&settings, &|_, _| {}).unwrap();
        twintrace::twins::film_words::film_words(&out.film)
    };
    let mega = film(gpu::Schedule::Megakernel);
    // Not vacuous: every pixel sees the sky (a path left untraced would
    // fold a zero).
    for p in mega.chunks(twintrace::twins::film_words::WORDS_PER_PIXEL) {
        assert!(f64::from_bits(p[2]) > 0.0, "a pixel's mean is not positive");
    }
    let paths_film = film(gpu::Schedule::PathMegakernel);
    if let Err(e) = twintrace::twins::film_words::compare_words(&mega, &paths_film) {
        panic!("{e}");
    }
}

/// The buckets of the paths the sorted wavefront's last bounce shaded, in
/// the order it shaded them: rtow-final (480 materials in 63 buckets, and
/// the sky's misses in the last), BSDF paths (they queue no shadow ray, so
/// every live path's bucket is its extension hit's, which its hit record
/// still holds after the shade), three bounces, built from `program`.
fn shaded_buckets(ctx: &gpu::GpuContext, program: &str) -> Vec<u32> {
    let (buckets, once) = shaded(ctx, program);
    if let Err(e) = once {
        panic!("{e}");
    }
    buckets
}

/// [`shaded_buckets`], and whether the sorted queue held each of the
/// bounce's live paths once.
fn shaded(ctx: &gpu::GpuContext, program: &str) -> (Vec<u32>, Result<(), String>) {
    let scene = reference::load_scene("rtow-final").unwrap();
    let packed = gpu::scene_buffers::PackedScene::for_walk(
        &scene,
        gpu::Traversal::Binary,
        gpu::LeafLayout::Indexed,
    );
    let sorted = Schedule::Wavefront(PathLayout::Aos, ShadeOrder::Material);
    let build = gpu::RendererBuild {
        program: Some(program),
        packed: Some(&packed),
        features: Some(Features::of(&scene)),
        ..gpu::RendererBuild::of(gpu::Variant::plain(Integrator::Bsdf, sorted))
    };
    let r = gpu::GpuRenderer::new(ctx, &scene, build).unwrap();
    let settings = reference::RenderSettings {
        width: 48,
        height: 32,
        spp: 2,
        max_depth: 3,
        ..scene.render_settings()
    };
    r.render(&settings, &|_, _| {}).unwrap();
    let state = r
        .last_wave_state()
        .unwrap()
        .expect("a wave schedule rendered");
    let last = gpu::wavefront::SORT_BUCKETS - 1;
    // The hit record's words in a slot (PF_HIT of shaders/wavefront.wgsl:
    // flags, t, primitive, u, v), array-of-structs path state.
    const PF_HIT: usize = 18;
    const HIT_FOUND: u32 = 1;
    let (mut sorted, mut live) = (state.sorted_queue().to_vec(), state.live_queue().to_vec());
    sorted.sort_unstable();
    live.sort_unstable();
    let once = if sorted != live {
        Err("the sorted queue is not the live paths' queue reordered".to_string())
    } else if sorted.windows(2).any(|w| w[0] == w[1]) {
        Err("a live path queued twice".to_string())
    } else {
        Ok(())
    };
    let buckets = state
        .sorted_queue()
        .iter()
        .map(|&slot| {
            let hit = slot as usize * gpu::wavefront::PATH_WORDS as usize + PF_HIT;
            if state.paths[hit] & HIT_FOUND == 0 {
                return last;
            }
            let p = packed.primitives[state.paths[hit + 2] as usize];
            let material = match p.tag {
                reference::scene::primitive_tag::SPHERE => {
                    packed.spheres[p.index as usize].material
                }
                reference::scene::primitive_tag::QUAD => packed.quads[p.index as usize].material,
                reference::scene::primitive_tag::TRIANGLE => {
                    packed.triangles[p.index as usize].material
                }
                tag => panic!("primitive tag {tag}"),
            };
            packed.materials[material as usize].shade_bucket
        })
        .collect();
    (buckets, once)
}

/// Whether buckets never decrease and more than one is used.
fn in_bucket_runs(buckets: &[u32]) -> Result<(), String> {
    if let Some(i) = buckets.windows(2).position(|w| w[0] > w[1]) {
        return Err(format!(
            "path {} of {} shaded in bucket {} after bucket {}",
            i + 1,
            buckets.len(),
            buckets[i + 1],
            buckets[i]
        ));
    }
    let mut used = buckets.to_vec();
    used.dedup();
    if used.len() < 2 {
        return Err(format!("{} buckets used", used.len()));
    }
    Ok(())
}

/// The film gate cannot see the order the paths are shaded in (any order
/// gives the same film): this reads it. The sorted wavefront shades a
/// bounce's live paths in runs of one bucket, each path once; a scatter
/// that leaves the queue's order (a sort in name only) fails, and so do
/// bucket starts that lose paths.
#[test]
fn the_sorted_wavefront_shades_a_bounce_in_runs_of_one_bucket() {
    let ctx = common::gpu();
    let program = gpu::shader::wavefront_source();
    let buckets = shaded_buckets(ctx, &program);
    // Enough live paths after three bounces to be a test (rtow-final's
    // ground and spheres keep most of 3,072 paths alive).
    assert!(buckets.len() > 500, "{} live paths", buckets.len());
    if let Err(e) = in_bucket_runs(&buckets) {
        panic!("{e}");
    }
    let mut used = buckets.clone();
    used.dedup();
    assert!(used.len() > 10, "{} buckets", used.len());
    let from = "wave_queues.entries[SORTED_QUEUE * cap + at] = wave_queues.entries[cur * cap + i];";
    assert_eq!(program.matches(from).count(), 1);
    let mutant = program.replace(
        from,
        "wave_queues.entries[SORTED_QUEUE * cap + i + 0u * at] = wave_queues.entries[cur * cap + i];",
    );
    assert!(
        in_bucket_runs(&shaded_buckets(ctx, &mutant)).is_err(),
        "a sort that keeps the queue's order passed"
    );
    // Runs a bucket late: the first bucket's places are left to the last
    // bounce's stale entries, and the last bucket's paths fall off the end.
    let from = "wg_bucket_start[lid] -= n;";
    assert_eq!(program.matches(from).count(), 1);
    assert!(
        shaded(ctx, &program.replace(from, "")).1.is_err(),
        "a sort that loses paths passed"
    );
}
