//! The GPU's walks against each other (`gpu::traversal`): the four-wide
//! walk, the compressed eight-wide walk (`gpu::compressed`: quantized
//! boxes that contain the exact ones), brute force, the
//! structure-of-arrays node layout and the inline
//! leaf layouts (AoS and SoA) must return the binary walk's hit records (over
//! array-of-structs nodes and indexed leaves) bit for bit (flag, primitive,
//! t, uv) on the rays of [`super::hits`], on every scene, and render every
//! fixture and built-in scene as it does with either estimator. Not a CPU
//! twin: the binary walk is the oracle (itself held to the reference by
//! [`super::hits`]).
//!
//! Why bit for bit: every walk offers the same primitives to the same
//! test (`intersect_primitive`, or `intersect_inline` on copies of the
//! same floats, with the admits box) and keeps the closest
//! hit, ties in t to the smaller primitive id; a box only decides what is
//! skipped, and a box test is conservative (it never hides a hit the
//! primitive test would report). So the order of the walk cannot change
//! the hit. The films are compared under the wavefront's rule
//! ([`super::film_words::compare_words`]: counts exact, means bit for bit
//! or a few ulp apart where a driver contracts the shading code of two
//! programs differently); the summary line says how many pixels were not
//! bit for bit.

use super::film_words::compare_words;
use super::harness::{camera_and_random_rays, run_kernel_walking, Outcome};
use super::hits::{ray_words, scenes, HIT_WORDS, SNIPPET};
use super::specialization::{
    every_variant, gate_kernel_words, gate_scenes, own_oracle, packed_film_bits, variant_film,
    Build, SIZE,
};
use gpu::scene_buffers::PackedScene;
use gpu::{Features, GpuContext, LeafLayout, NodeLayout, Traversal};
use reference::integrator::Integrator;
use reference::Scene;

/// A walk and the node and leaf layouts it reads.
pub type Walk = (Traversal, NodeLayout, LeafLayout);

/// The walks compared with the binary one over array-of-structs nodes
/// and indexed leaves.
pub const VARIANTS: [Walk; 9] = [
    (Traversal::Wide, NodeLayout::Aos, LeafLayout::Indexed),
    (Traversal::Compressed, NodeLayout::Aos, LeafLayout::Indexed),
    (Traversal::Compressed, NodeLayout::Soa, LeafLayout::Inline),
    (Traversal::BruteForce, NodeLayout::Aos, LeafLayout::Indexed),
    (Traversal::Binary, NodeLayout::Soa, LeafLayout::Indexed),
    (Traversal::Binary, NodeLayout::Aos, LeafLayout::Inline),
    (Traversal::Binary, NodeLayout::Aos, LeafLayout::InlineSoa),
    (Traversal::Wide, NodeLayout::Aos, LeafLayout::Inline),
    (Traversal::Wide, NodeLayout::Soa, LeafLayout::Inline),
];

/// The estimators a walk's films are compared under where the gates
/// specialize (hardware): both for the walks, MIS only (its paths trace
/// both kinds of ray, closest hit and shadow) for a layout of the same
/// records under the binary walk, which changes only where `bvh_node` and
/// the inline test read their words, and for the compressed walk's
/// records in other layouts than array-of-structs nodes and indexed
/// leaves (the hit records check every read). On a software adapter
/// ([`gate_estimators`]) MIS only for every walk.
pub fn film_estimators((traversal, nodes, leaves): Walk) -> &'static [Integrator] {
    let layout_only = match traversal {
        Traversal::Binary => nodes == NodeLayout::Soa || leaves == LeafLayout::InlineSoa,
        Traversal::Compressed => nodes == NodeLayout::Soa || leaves != LeafLayout::Indexed,
        _ => false,
    };
    if layout_only {
        &[Integrator::Mis]
    } else {
        &Integrator::ALL
    }
}

/// The estimators a walk's films are compared under on this adapter:
/// [`film_estimators`] where the gates specialize; on a software adapter
/// those of every GPU-against-GPU gate there
/// ([`super::specialization::gate_estimators`]: MIS alone, whose paths
/// trace both kinds of ray through the walk; the hit records hold every
/// walk to the binary one ray by ray whatever the estimator).
pub fn gate_estimators(ctx: &GpuContext, walk: Walk) -> &'static [Integrator] {
    if super::harness::full_gates(ctx) {
        film_estimators(walk)
    } else {
        super::specialization::gate_estimators(ctx)
    }
}

/// Whether [`all_scenes`] compares `walk`'s films on this adapter: every
/// walk where the gates specialize (hardware, `TWINTRACE_GATES=full`); on
/// a software adapter each walk that departs from the binary walk's
/// records in one way (another traversal, SoA nodes, or inline leaves:
/// 6 of the 9), each a render kernel to compile. The three combinations
/// (cwbvh8 with SoA nodes and inline leaves, bvh4 with inline leaves and
/// with both) keep their hit records in CI, every ray against the binary
/// walk's, and their films on hardware: CI misses only a slip that
/// shows in a film (a shadow ray's bounded walk) and in neither the
/// combination's hit records nor its parts' films.
pub fn films_judged(ctx: &GpuContext, (traversal, nodes, leaves): Walk) -> bool {
    super::harness::full_gates(ctx)
        || [
            traversal != Traversal::Binary,
            nodes != NodeLayout::Aos,
            leaves != LeafLayout::Indexed,
        ]
        .into_iter()
        .filter(|&d| d)
        .count()
            <= 1
}

/// A walk's name in the messages: `bvh4`, `bvh2-soa`, `bvh2-inline`.
pub fn walk_name((traversal, nodes, leaves): Walk) -> String {
    let mut name = traversal.name().to_string();
    if nodes != NodeLayout::Aos {
        name = format!("{name}-{}", nodes.name());
    }
    if leaves != LeafLayout::Indexed {
        name = format!("{name}-{}", leaves.name());
    }
    name
}

/// `scene`'s records for a walk; an error where it was refused
/// (`PackedScene::traversal_note`).
pub fn packed(scene: &Scene, (traversal, nodes, leaves): Walk) -> Result<PackedScene, String> {
    let packed = PackedScene::for_walk(scene, traversal, leaves).with_node_layout(nodes);
    match &packed.traversal_note {
        Some(why) => Err(why.clone()),
        None => Ok(packed),
    }
}

/// The hit-record kernel's output ([`HIT_WORDS`] a ray) for `scene`'s
/// records as packed, over `library` (the production WGSL, or an edit).
pub fn hit_words(
    ctx: &GpuContext,
    scene: &Scene,
    packed: &PackedScene,
    library: &str,
) -> Result<Vec<u32>, String> {
    let rays = camera_and_random_rays(scene, 64, 4096, 5);
    run_kernel_walking(
        ctx,
        (scene, packed),
        (SNIPPET, "hits_main"),
        &ray_words(&rays),
        (rays.len(), rays.len() * HIT_WORDS),
        library,
    )
}

/// The hit records of `packed` (a walk's records, or a test's edit of
/// them) against the binary walk's, over `library`: the number of rays
/// that hit, or the first ray whose records differ.
pub fn compare_hits(
    ctx: &GpuContext,
    name: &str,
    scene: &Scene,
    packed: &PackedScene,
    library: &str,
) -> Result<usize, String> {
    let oracle = binary_hit_words(ctx, scene)?;
    compare_hits_with(ctx, name, scene, &oracle, packed, library)
}

/// The binary walk's hit records of `scene` (production WGSL): the
/// oracle of [`compare_hits`].
pub fn binary_hit_words(ctx: &GpuContext, scene: &Scene) -> Result<Vec<u32>, String> {
    let production = gpu::shader::library_source();
    hit_words(ctx, scene, &PackedScene::new(scene), &production)
}

/// [`compare_hits`] against the binary walk's records already made
/// ([`binary_hit_words`]).
pub fn compare_hits_with(
    ctx: &GpuContext,
    name: &str,
    scene: &Scene,
    oracle: &[u32],
    packed: &PackedScene,
    library: &str,
) -> Result<usize, String> {
    let words = hit_words(ctx, scene, packed, library)?;
    let walk = walk_name((packed.traversal, packed.node_layout, packed.leaves));
    for (i, (b, w)) in oracle
        .chunks(HIT_WORDS)
        .zip(words.chunks(HIT_WORDS))
        .enumerate()
    {
        if b != w {
            let show = |r: &[u32]| {
                format!(
                    "hit {} prim {} (triangle {}) t {} uv ({}, {})",
                    r[0],
                    r[1],
                    r[5],
                    f32::from_bits(r[2]),
                    f32::from_bits(r[3]),
                    f32::from_bits(r[4])
                )
            };
            return Err(format!(
                "{name}, ray {i}: the {walk} walk gives {}, the binary walk {}",
                show(w),
                show(b)
            ));
        }
    }
    Ok(oracle.chunks(HIT_WORDS).filter(|r| r[0] == 1).count())
}

/// A walk's films of `scene` against the binary walk's (the
/// megakernel, kernel specialized to the scene) for one estimator, over
/// `program` (the megakernel's WGSL, or an edit): the pixels not bit for
/// bit and their largest mean difference in ulp.
pub fn compare_films(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    (walk, integrator): (Walk, Integrator),
    program: &str,
) -> Result<(usize, u64), String> {
    let (build, binary) = own_oracle((ctx, spec, scene), integrator, program, "the binary walk")?;
    compare_films_with((ctx, spec, scene), &binary, walk, build)
}

/// [`compare_films`] against the binary walk's film already rendered
/// (`oracle_film`), `build` (the oracle's) changed to `walk`.
fn compare_films_with(
    (ctx, spec, scene): (&GpuContext, &str, &Scene),
    binary: &[u64],
    walk: Walk,
    build: Build,
) -> Result<(usize, u64), String> {
    let integrator = build.integrator;
    let build = Build {
        traversal: walk.0,
        nodes: walk.1,
        leaves: walk.2,
        ..build
    };
    let film = variant_film(ctx, scene, build)?;
    compare_words(binary, &film).map_err(|e| {
        format!(
            "{spec} ({}, {} walk): {e}",
            integrator.name(),
            walk_name(walk)
        )
    })
}

/// [`compare_films`] for records already packed (a test's edit of a
/// walk's records): their film against the binary walk's `binary`
/// ([`super::specialization::own_oracle`]'s film: this builds at the
/// scene's own features too).
pub fn compare_packed_films_with(
    ctx: &GpuContext,
    spec: &str,
    scene: &Scene,
    binary: &[u64],
    (packed, integrator): (&PackedScene, Integrator),
    program: &str,
) -> Result<(usize, u64), String> {
    let walk = (packed.traversal, packed.node_layout, packed.leaves);
    let build = Build {
        traversal: walk.0,
        nodes: walk.1,
        leaves: walk.2,
        ..Build::megakernel(program, integrator, Features::of(scene))
    };
    let film = packed_film_bits(ctx, scene, packed, build, &[None])?.remove(0);
    compare_words(binary, &film).map_err(|e| {
        format!(
            "{spec} ({}, {} walk): {e}",
            integrator.name(),
            walk_name(walk)
        )
    })
}

/// The compressed nodes' boxes as the kernel dequantizes them
/// (`cw_box_min`, `cw_box_max`): six words (minimum, maximum) for each
/// `(node << 3) | slot` of the input.
const BOXES_SNIPPET: &str = "
@compute @workgroup_size(64)
fn cw_boxes_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) {
        return;
    }
    let n = cw_node(input[i] >> 3u);
    let lo = cw_box_min(n, input[i] & 7u);
    let hi = cw_box_max(n, input[i] & 7u);
    output[6u * i] = bitcast<u32>(lo.x);
    output[6u * i + 1u] = bitcast<u32>(lo.y);
    output[6u * i + 2u] = bitcast<u32>(lo.z);
    output[6u * i + 3u] = bitcast<u32>(hi.x);
    output[6u * i + 4u] = bitcast<u32>(hi.y);
    output[6u * i + 5u] = bitcast<u32>(hi.z);
}
";

/// Every occupied slot's box of `packed`'s compressed nodes as the kernel
/// dequantizes it (over `library`) against the host's
/// (`gpu::compressed::CompressedNode::child_box`, the boxes the host
/// checked contain the exact ones), bit for bit: the boxes compared, or
/// the first that differs.
pub fn compare_compressed_boxes(
    ctx: &GpuContext,
    name: &str,
    scene: &Scene,
    packed: &PackedScene,
    library: &str,
) -> Result<usize, String> {
    let slots: Vec<(usize, usize)> = (packed.compressed.iter().enumerate())
        .flat_map(|(w, n)| {
            (0..gpu::compressed::WIDTH)
                .filter(|&s| n.is_live(s))
                .map(move |s| (w, s))
        })
        .collect();
    if slots.is_empty() {
        return Err(format!("{name}: no compressed boxes to compare"));
    }
    let input: Vec<u32> = slots.iter().map(|&(w, s)| ((w << 3) | s) as u32).collect();
    let out = run_kernel_walking(
        ctx,
        (scene, packed),
        (BOXES_SNIPPET, "cw_boxes_main"),
        &input,
        (slots.len(), slots.len() * 6),
        library,
    )?;
    for (&(w, s), g) in slots.iter().zip(out.chunks(6)) {
        let (lo, hi) = packed.compressed[w].child_box(s);
        let host: Vec<u32> = lo.iter().chain(&hi).map(|x| x.to_bits()).collect();
        if host != g {
            let show = |v: &[u32]| {
                format!(
                    "{:?}",
                    v.iter().map(|&b| f32::from_bits(b)).collect::<Vec<_>>()
                )
            };
            return Err(format!(
                "{name}: compressed node {w} slot {s}: the kernel's box {} is not the host's {}",
                show(g),
                show(&host)
            ));
        }
    }
    Ok(slots.len())
}

/// Whether [`all_scenes`] runs `walk` on `scene`: brute force takes tiny
/// scenes only (the renderer refuses more; its hit records on a mesh of
/// thousands of triangles took most of the gate's time on lavapipe).
fn brute_force_takes(scene: &Scene, (traversal, _, _): Walk) -> bool {
    traversal != Traversal::BruteForce
        || scene.primitives().len() <= gpu::renderer::BRUTE_FORCE_MAX_PRIMITIVES
}

/// Hit records on every scene of [`scenes`] and films of every scene of
/// [`super::specialization::scene_specs`], both estimators, each walk of [`VARIANTS`] against the
/// binary one. Every case is compared; the error lists each one that
/// fails.
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let library = gpu::shader::library_source();
    let program = gpu::shader::render_source();
    let mut failures = Vec::new();
    let mut hit_lines = Vec::new();
    // Scenes in parallel (super::harness::par_map), each scene's walks in turn.
    let hit_scenes = scenes()?;
    // Each scene's binary hit records, then every (scene, walk) against
    // them: the items in parallel (super::harness::par_map), so that no one scene's
    // walks make the gate's critical path.
    let oracles = super::harness::par_map(&hit_scenes, |(_, scene)| binary_hit_words(ctx, scene));
    let oracles = oracles.into_iter().collect::<Result<Vec<_>, String>>()?;
    let hit_items: Vec<(usize, Walk)> = hit_scenes
        .iter()
        .enumerate()
        .flat_map(|(i, (_, scene))| {
            VARIANTS
                .into_iter()
                .filter(move |&w| brute_force_takes(scene, w))
                .map(move |w| (i, w))
        })
        .collect();
    let outcomes = super::harness::par_map(&hit_items, |&(i, walk)| {
        let (name, scene) = &hit_scenes[i];
        packed(scene, walk)
            .and_then(|p| compare_hits_with(ctx, name, scene, &oracles[i], &p, &library))
    });
    let mut hits: Vec<Option<usize>> = vec![None; hit_scenes.len()];
    for (&(i, _), outcome) in hit_items.iter().zip(outcomes) {
        match outcome {
            Ok(n) => hits[i] = Some(n),
            Err(e) => failures.push(e),
        }
    }
    for ((name, _), n) in hit_scenes.iter().zip(hits) {
        if let Some(n) = n {
            hit_lines.push(format!("{name} {n}"));
        }
    }
    // The compressed walk's boxes as the kernel computes them are the
    // ones the host checked to contain the exact boxes.
    let boxes = super::harness::par_map(&hit_scenes, |(name, scene)| {
        let walk = (Traversal::Compressed, NodeLayout::Aos, LeafLayout::Indexed);
        packed(scene, walk).and_then(|p| compare_compressed_boxes(ctx, name, scene, &p, &library))
    });
    let mut compressed_boxes = 0;
    for outcome in boxes {
        match outcome {
            Ok(n) => compressed_boxes += n,
            Err(e) => failures.push(e),
        }
    }
    let scenes = gate_scenes(ctx, "the binary walk")?;
    let films = every_variant(&scenes, &VARIANTS, |s, integrator, walk| {
        (brute_force_takes(&s.scene, walk)
            && films_judged(ctx, walk)
            && gate_estimators(ctx, walk).contains(&integrator))
        .then(|| {
            let binary = s.oracle(integrator);
            let build = s.build(&program, integrator);
            compare_films_with((ctx, &s.spec, &s.scene), binary, walk, build)
        })
    });
    let (films, inexact) = match films {
        Ok(found) => found,
        Err(e) => {
            failures.push(e);
            (0, Default::default())
        }
    };
    if !failures.is_empty() {
        return Err(failures.join("; "));
    }
    let (width, height, _) = SIZE;
    let compared = films * (width * height) as usize;
    let exactness = inexact.exactness(compared);
    Ok(format!(
        "bvh4, cwbvh8, brute force (scenes of at most {} primitives), SoA nodes (bvh2, bvh4, cwbvh8) and inline leaves (bvh2, bvh4, cwbvh8; SoA on bvh2): hit records equal the binary walk's bit for bit (rays that hit: {}); \
         cwbvh8's {compressed_boxes} dequantized boxes on those scenes equal the host's bit for bit; \
         {} scenes ({films} films: brute force on the scenes of at most {} primitives, {}; {}): films equal the binary walk's {exactness}",
        gpu::renderer::BRUTE_FORCE_MAX_PRIMITIVES,
        hit_lines.join(", "),
        scenes.len(),
        gpu::renderer::BRUTE_FORCE_MAX_PRIMITIVES,
        if !super::harness::full_gates(ctx) {
            "the walks of one change from the binary walk's records, with MIS only"
        } else {
            "the layouts under the binary and cwbvh8 walks with MIS only, the other walks with both estimators"
        },
        gate_kernel_words(ctx)
    ))
}
