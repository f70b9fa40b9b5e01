//! The GPU's walks (`gpu::traversal`): the four-wide BVH walk, the
//! compressed eight-wide walk, brute force and the node and leaf layouts
//! return the binary walk's hit records bit for bit and render the
//! same films (`twintrace::twins::traversal`, also run by `twintrace
//! selftest`). Mutants of the wide and compressed walks' WGSL and of the
//! records the host packs prove the comparisons can fail.

use crate::common;
use gpu::scene_buffers::PackedScene;
use gpu::traversal::WIDE_EMPTY;
use gpu::{LeafLayout, NodeLayout, Traversal};
use reference::integrator::Integrator;
use twintrace::twins::traversal::{
    all_scenes, compare_compressed_boxes, compare_films, compare_hits, compare_packed_films_with,
    packed,
};

#[test]
fn every_walk_finds_the_binary_walks_hits_and_renders_its_films() {
    match all_scenes(common::gpu()) {
        Ok(summary) => println!("{summary}"),
        Err(e) => panic!("{e}"),
    }
}

/// (what the slip is, WGSL replaced, its replacement).
const WIDE_MUTANTS: &[(&str, &str, &str)] = &[
    (
        "the fourth lane of every wide node is never tested",
        "var d = wide_lane(base + 3u, ray.origin, inv_dir, pad, best.t);",
        "var d = WideLane(F32_MAX, WIDE_EMPTY);",
    ),
    (
        "the second-nearest hit lane is never stacked (the third stacked twice)",
        "stack[sp] = b.entry;",
        "stack[sp] = c.entry;",
    ),
    // Each slip keeps the walk finite: a real GPU has no loop limit (a
    // stacked leaf reading the record before its own met an unused lane's
    // count, 2^30 - 1, and held the H100 for minutes; lavapipe's loop
    // limit had cut it short).
    (
        "a stacked leaf's entries are read from one past their start",
        "best = intersect_leaf(n.index, n.meta_bits >> 2u, ray, inv_dir, pad, t_min, best);\n        } else {\n            let base",
        "best = intersect_leaf(n.index + 1u, n.meta_bits >> 2u, ray, inv_dir, pad, t_min, best);\n        } else {\n            let base",
    ),
    (
        "a leaf takes only its first entry",
        "best = intersect_leaf(n.index, n.meta_bits >> 2u, ray, inv_dir, pad, t_min, best);\n        } else {\n            let base",
        "best = intersect_leaf(n.index, 1u, ray, inv_dir, pad, t_min, best);\n        } else {\n            let base",
    ),
];

fn rtow() -> reference::Scene {
    reference::load_scene("rtow-final").unwrap()
}

#[test]
fn wide_walk_mutants_fail_the_hit_records() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let scene = rtow();
    let wide = packed(
        &scene,
        (Traversal::Wide, NodeLayout::Aos, LeafLayout::Indexed),
    )
    .unwrap();
    let hits = compare_hits(ctx, "rtow-final", &scene, &wide, &library).unwrap();
    assert!(hits > 4096, "only {hits} rays hit: a weak comparison");
    for &(slip, from, to) in WIDE_MUTANTS {
        assert_eq!(
            library.matches(from).count(),
            1,
            "{slip}: `{from}` not found once"
        );
        let mutant = library.replace(from, to);
        let e = compare_hits(ctx, "rtow-final", &scene, &wide, &mutant).expect_err(slip);
        assert!(e.contains(", ray "), "{slip}: not a hit difference: {e}");
        println!("{slip}: {e}");
    }
}

/// (what the slip is, WGSL replaced, its replacement). Each keeps the
/// walk finite: a wrong child's index is still a later node, clamped to
/// the last (which has no interior children) where it runs past the end.
const COMPRESSED_MUTANTS: &[(&str, &str, &str)] = &[
    (
        "the eighth slot of every compressed node is never tested",
        "\n            | cw_slot(n, 7u, oct, ray.origin, inv_dir, pad, best.t);",
        ";",
    ),
    (
        "what is left of a group is never stacked (overwritten by the next)",
        "            sp += 1u;\n        }\n        let n = cw_node(node);",
        "        }\n        let n = cw_node(node);",
    ),
    (
        "a leaf child's entries read from one past their start",
        "let first = n.leaf_base + (m & ((1u << CW_LEAF_COUNT_SHIFT) - 1u));",
        "let first = n.leaf_base + (m & ((1u << CW_LEAF_COUNT_SHIFT) - 1u)) + 1u;",
    ),
    (
        "an interior child's node counts its own slot among those before it",
        "countOneBits(group.y & ((1u << slot) - 1u))",
        "countOneBits(group.y & ((2u << slot) - 1u))",
    ),
    (
        "a box maximum dequantized one grid step low",
        "let q = vec3<u32>(cw_byte(n.q1.z, n.q1.w, s), cw_byte(n.q2.x, n.q2.y, s), cw_byte(n.q2.z, n.q2.w, s));",
        "let q = max(vec3<u32>(cw_byte(n.q1.z, n.q1.w, s), cw_byte(n.q2.x, n.q2.y, s), cw_byte(n.q2.z, n.q2.w, s)), vec3<u32>(1u)) - vec3<u32>(1u);",
    ),
];

fn compressed(scene: &reference::Scene) -> PackedScene {
    packed(
        scene,
        (Traversal::Compressed, NodeLayout::Aos, LeafLayout::Indexed),
    )
    .unwrap()
}

#[test]
fn compressed_walk_mutants_fail_the_hit_records() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let scene = rtow();
    let cw = compressed(&scene);
    let hits = compare_hits(ctx, "rtow-final", &scene, &cw, &library).unwrap();
    assert!(hits > 4096, "only {hits} rays hit: a weak comparison");
    for &(slip, from, to) in COMPRESSED_MUTANTS {
        assert_eq!(
            library.matches(from).count(),
            1,
            "{slip}: `{from}` not found once"
        );
        let mutant = library.replace(from, to);
        let e = compare_hits(ctx, "rtow-final", &scene, &cw, &mutant).expect_err(slip);
        assert!(e.contains(", ray "), "{slip}: not a hit difference: {e}");
        println!("{slip}: {e}");
    }
}

/// The kernel's dequantized boxes are the host's, bit for bit, in both
/// node layouts; a grid step built from the wrong exponent bias (half
/// the step) is caught.
#[test]
fn compressed_boxes_are_the_hosts_and_a_wrong_step_is_caught() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let scene = rtow();
    for nodes in NodeLayout::ALL {
        let p = packed(&scene, (Traversal::Compressed, nodes, LeafLayout::Inline)).unwrap();
        let n = compare_compressed_boxes(ctx, "rtow-final", &scene, &p, &library).unwrap();
        assert!(n >= 5 * p.compressed.len(), "{n} boxes");
    }
    let (from, to) = ("vec3<i32>(127)", "vec3<i32>(126)");
    assert_eq!(library.matches(from).count(), 1, "`{from}` not found once");
    let e = compare_compressed_boxes(
        ctx,
        "rtow-final",
        &scene,
        &compressed(&scene),
        &library.replace(from, to),
    )
    .expect_err("boxes on half the grid step passed");
    assert!(e.contains("is not the host's"), "{e}");
    println!("half the grid step: {e}");
}

/// Boxes quantized inward (a minimum rounded up, a maximum down: floor
/// and ceil swapped) no longer contain their children: the equality
/// gates fail, as hit records and as films.
#[test]
fn boxes_quantized_inward_fail_the_hit_records_and_the_films() {
    use gpu::compressed::{compress, Rounding};
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let program = gpu::shader::render_source();
    for spec in ["rtow-final", "cornell"] {
        let scene = reference::load_scene(spec).unwrap();
        let cw = compressed(&scene);
        let bvh = scene.bvh();
        let inward = compress(bvh.nodes(), bvh.prim_order(), Rounding::Inward).unwrap();
        // Only the boxes differ from the production records.
        let outward = compress(bvh.nodes(), bvh.prim_order(), Rounding::Outward).unwrap();
        assert_eq!(cw.compressed, outward.nodes);
        assert_eq!(inward.order, outward.order);
        assert_ne!(inward.nodes, outward.nodes);
        let mutant = PackedScene {
            compressed: inward.nodes,
            ..cw.clone()
        };
        let e = compare_hits(ctx, spec, &scene, &mutant, &library)
            .expect_err("inward boxes passed the hit records");
        assert!(e.contains(", ray "), "not a hit difference: {e}");
        println!("inward boxes, hit records: {e}");
        let integrator = Integrator::Mis;
        let (_, binary) = twintrace::twins::specialization::own_oracle(
            (ctx, spec, &scene),
            integrator,
            &program,
            "the binary walk",
        )
        .unwrap();
        compare_packed_films_with(ctx, spec, &scene, &binary, (&cw, integrator), &program).unwrap();
        let e =
            compare_packed_films_with(ctx, spec, &scene, &binary, (&mutant, integrator), &program)
                .expect_err("inward boxes passed the film comparison");
        assert!(e.contains(": pixel "), "not a film difference: {e}");
        println!("inward boxes, films: {e}");
    }
}

/// (what the slip is, WGSL replaced, its replacement, scene).
const INLINE_MUTANTS: &[(&str, &str, &str, &str)] = &[
    (
        "an inline sphere's radius read from the word after it",
        "h = intersect_sphere(a, b.x, ray, t_min, t_max);",
        "h = intersect_sphere(a, b.y, ray, t_min, t_max);",
        "rtow-final",
    ),
    (
        "an inline entry's id keeps its kind's bits",
        "prim = r0.x & (INLINE_ALPHA - 1u);",
        "prim = r0.x;",
        "cornell",
    ),
    (
        "an inline quad's u and v read swapped",
        "h = intersect_quad(a, b, c, ray, t_min, t_max);",
        "h = intersect_quad(a, c, b, ray, t_min, t_max);",
        "cornell",
    ),
];

#[test]
fn inline_leaf_mutants_fail_the_hit_records() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    for &(slip, from, to, spec) in INLINE_MUTANTS {
        let scene = reference::load_scene(spec).unwrap();
        let inline = packed(
            &scene,
            (Traversal::Binary, NodeLayout::Aos, LeafLayout::Inline),
        )
        .unwrap();
        compare_hits(ctx, spec, &scene, &inline, &library).unwrap();
        assert_eq!(
            library.matches(from).count(),
            1,
            "{slip}: `{from}` not found once"
        );
        let mutant = library.replace(from, to);
        let e = compare_hits(ctx, spec, &scene, &inline, &mutant).expect_err(slip);
        assert!(e.contains(", ray "), "{slip}: not a hit difference: {e}");
        println!("{slip}: {e}");
    }
    // Packed wrong: a triangle's second and third vertices swapped in its
    // inline entry (words 10 to 12 and 13 to 15 of its sixteen).
    let scene =
        reference::load_scene(&twintrace::compare::gate::fixture_scene("gltf-mesh.json")).unwrap();
    let mut inline = packed(
        &scene,
        (Traversal::Binary, NodeLayout::Aos, LeafLayout::Inline),
    )
    .unwrap();
    for e in inline.leaf_entries.chunks_mut(4) {
        let mut w: Vec<u32> = e.iter().flatten().copied().collect();
        let (b, c): (Vec<u32>, Vec<u32>) = (w[10..13].to_vec(), w[13..16].to_vec());
        w[10..13].copy_from_slice(&c);
        w[13..16].copy_from_slice(&b);
        for (k, r) in e.iter_mut().enumerate() {
            r.copy_from_slice(&w[4 * k..4 * k + 4]);
        }
    }
    let e = compare_hits(ctx, "gltf-mesh", &scene, &inline, &library)
        .expect_err("swapped triangle vertices passed");
    println!("inline triangle vertices swapped: {e}");
}

/// The structure-of-arrays node records: a read of the wrong words, and
/// the host's words in the other layout's order, are caught by the hit
/// records. Each slip keeps the walk finite (a record's `meta` still comes
/// from a binary node, never an unused wide lane's 2^32 - 1).
#[test]
fn soa_node_mutants_fail_the_hit_records() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let scene = rtow();
    let soa = packed(
        &scene,
        (Traversal::Binary, NodeLayout::Soa, LeafLayout::Indexed),
    )
    .unwrap();
    compare_hits(ctx, "rtow-final", &scene, &soa, &library).unwrap();
    let (from, to) = (
        "hi = nodes[(arrayLength(&nodes) >> 1u) + i];",
        "hi = nodes[(arrayLength(&nodes) >> 1u) + i].yxzw;",
    );
    assert_eq!(library.matches(from).count(), 1, "`{from}` not found once");
    let e = compare_hits(ctx, "rtow-final", &scene, &soa, &library.replace(from, to))
        .expect_err("SoA box maximum read with x and y swapped passed");
    assert!(e.contains(", ray "), "not a hit difference: {e}");
    println!("SoA box maximum x and y swapped: {e}");
    // The host's words: each record's maximum x and y swapped.
    let mut swapped = soa.clone();
    for n in &mut swapped.nodes {
        n.max.swap(0, 1);
    }
    let e = compare_hits(ctx, "rtow-final", &scene, &swapped, &library)
        .expect_err("SoA records with swapped maxima passed");
    println!("SoA records with swapped maxima: {e}");
}

/// Inline entries as a structure of arrays: the entries regrouped word by
/// word, and a read with the wrong stride caught by the hit records.
#[test]
fn inline_soa_entries_are_regrouped_and_a_wrong_stride_is_caught() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let scene = reference::load_scene("cornell").unwrap();
    let walk = |leaves| packed(&scene, (Traversal::Binary, NodeLayout::Aos, leaves)).unwrap();
    let (inline, soa) = (walk(LeafLayout::Inline), walk(LeafLayout::InlineSoa));
    let n = inline.leaf_entries.len() / 4;
    assert_eq!(n, scene.primitives().len());
    assert_eq!(soa.leaf_entries.len(), 4 * n);
    for i in 0..n {
        for k in 0..4 {
            assert_eq!(soa.leaf_entries[k * n + i], inline.leaf_entries[4 * i + k]);
        }
    }
    compare_hits(ctx, "cornell", &scene, &soa, &library).unwrap();
    let (from, to) = (
        "step = arrayLength(&leaf_entries) / INLINE_WORDS;",
        "step = arrayLength(&leaf_entries) / INLINE_WORDS + 1u;",
    );
    assert_eq!(library.matches(from).count(), 1, "`{from}` not found once");
    let e = compare_hits(ctx, "cornell", &scene, &soa, &library.replace(from, to))
        .expect_err("SoA inline entries read with a stride one too long passed");
    assert!(e.contains(", ray "), "not a hit difference: {e}");
    println!("SoA inline entries, stride one too long: {e}");
}

#[test]
fn compressed_soa_words_are_the_aos_words_regrouped() {
    use gpu::compressed::{CompressedNode, HEADER_WORDS, NODE_WORDS};
    use gpu::traversal::compressed_words;
    let scene = rtow();
    let p = compressed(&scene);
    let (root, nodes) = (&p.nodes[0], &p.compressed);
    let (aos, soa) = (
        compressed_words(root, nodes, NodeLayout::Aos),
        compressed_words(root, nodes, NodeLayout::Soa),
    );
    let n = nodes.len();
    assert_eq!(aos.len(), HEADER_WORDS + NODE_WORDS * n);
    assert_eq!(soa.len(), aos.len());
    assert_eq!(&aos[..HEADER_WORDS], &soa[..HEADER_WORDS]);
    assert_eq!(aos[0][..3], root.min.map(f32::to_bits));
    assert_eq!(aos[1][..3], root.max.map(f32::to_bits));
    for (i, node) in nodes.iter().enumerate() {
        let words: [[u32; 4]; NODE_WORDS] =
            std::array::from_fn(|k| aos[HEADER_WORDS + NODE_WORDS * i + k]);
        assert_eq!(CompressedNode::from_words(&words), *node, "node {i}");
        for (k, w) in words.iter().enumerate() {
            assert_eq!(soa[HEADER_WORDS + k * n + i], *w, "node {i} word {k}");
        }
    }
}

#[test]
fn soa_words_are_the_aos_words_regrouped() {
    use gpu::traversal::node_words;
    let scene = rtow();
    let nodes = &PackedScene::new(&scene).nodes;
    let (aos, soa) = (
        node_words(nodes, NodeLayout::Aos),
        node_words(nodes, NodeLayout::Soa),
    );
    let n = nodes.len();
    assert_eq!((aos.len(), soa.len()), (2 * n, 2 * n));
    for i in 0..n {
        assert_eq!(
            (aos[2 * i], aos[2 * i + 1]),
            (soa[i], soa[n + i]),
            "record {i}"
        );
    }
    assert_eq!(aos[1][3], nodes[0].meta);
    assert_eq!(aos[0][3], nodes[0].index);
}

#[test]
fn a_wide_walk_mutant_fails_the_film_comparison() {
    let ctx = common::gpu();
    let (slip, from, to) = WIDE_MUTANTS[0];
    let program = gpu::shader::render_source();
    assert_eq!(program.matches(from).count(), 1);
    let mutant = program.replace(from, to);
    let scene = reference::load_scene("cornell").unwrap();
    compare_films(
        ctx,
        "cornell",
        &scene,
        (
            (Traversal::Wide, NodeLayout::Aos, LeafLayout::Indexed),
            Integrator::Mis,
        ),
        &program,
    )
    .unwrap();
    let e = compare_films(
        ctx,
        "cornell",
        &scene,
        (
            (Traversal::Wide, NodeLayout::Aos, LeafLayout::Indexed),
            Integrator::Mis,
        ),
        &mutant,
    )
    .expect_err(slip);
    assert!(e.contains(": pixel "), "{slip}: not a film difference: {e}");
}

#[test]
fn records_packed_wrong_fail_the_hit_records() {
    let ctx = common::gpu();
    let library = gpu::shader::library_source();
    let scene = rtow();
    // Every interior lane's box shrunk to the middle half of each axis.
    let mut wide = packed(
        &scene,
        (Traversal::Wide, NodeLayout::Aos, LeafLayout::Indexed),
    )
    .unwrap();
    for lane in wide.nodes[1..].iter_mut() {
        if lane.meta != WIDE_EMPTY && !lane.is_leaf() {
            for k in 0..3 {
                let (lo, hi) = (lane.min[k], lane.max[k]);
                lane.min[k] = lo + (hi - lo) / 4.0;
                lane.max[k] = hi - (hi - lo) / 4.0;
            }
        }
    }
    let e = compare_hits(ctx, "rtow-final", &scene, &wide, &library)
        .expect_err("shrunk wide boxes passed");
    println!("wide boxes shrunk: {e}");
    // Brute force over half the primitives.
    let mut brute = packed(
        &scene,
        (Traversal::BruteForce, NodeLayout::Aos, LeafLayout::Indexed),
    )
    .unwrap();
    assert_eq!(brute.nodes.len(), 1);
    brute.nodes[0].meta = ((brute.nodes[0].count() / 2) << 2) | 3;
    let e = compare_hits(ctx, "rtow-final", &scene, &brute, &library)
        .expect_err("brute force over half the primitives passed");
    println!("brute force over half: {e}");
}

/// Every walk and layout builds and reports itself: those whose films
/// the gate renders on this adapter (`twins::traversal::VARIANTS` where
/// `films_judged`, and the binary walk, its oracle) are checked where it
/// builds them (`twins::specialization::packed_film_bits`, in
/// `every_walk_finds_the_binary_walks_hits_and_renders_its_films`), the
/// others here, one kernel each; and the brute-force records: one leaf of
/// every primitive, in id order.
#[test]
fn renderers_report_the_walk_they_run() {
    let ctx = common::gpu();
    // Each walk's kernel is a compile: specialized to 17 small spheres and
    // quads of one Lambertian material, the 20 took 17 s on lavapipe with
    // its cache empty (2 cores), against 119 s specialized to rtow.
    let small = twintrace::twins::hits::far_small_shapes(16);
    let oracle = (Traversal::Binary, NodeLayout::Aos, LeafLayout::Indexed);
    let gate_renders = |walk| {
        walk == oracle
            || (twintrace::twins::traversal::VARIANTS.contains(&walk)
                && twintrace::twins::traversal::films_judged(ctx, walk))
    };
    let mut built = 0;
    for traversal in Traversal::ALL {
        for leaves in LeafLayout::ALL {
            for nodes in NodeLayout::ALL {
                let walk = (traversal, nodes, leaves);
                if gate_renders(walk) {
                    continue;
                }
                let variant = gpu::Variant {
                    integrator: Integrator::Bsdf,
                    kernel: gpu::Kernel::Specialized,
                    schedule: gpu::Schedule::PathMegakernel,
                    traversal,
                    nodes,
                    leaves,
                    dispatch: gpu::Dispatch::Switch,
                    checks: gpu::Checks::Trusted,
                };
                let r =
                    gpu::GpuRenderer::new(ctx, &small, gpu::RendererBuild::of(variant)).unwrap();
                assert_eq!(r.traversal(), (traversal, None));
                assert_eq!(r.node_layout(), nodes);
                assert_eq!(r.leaves(), leaves);
                built += 1;
            }
        }
    }
    let judged = twintrace::twins::traversal::VARIANTS
        .into_iter()
        .filter(|&w| twintrace::twins::traversal::films_judged(ctx, w))
        .count();
    assert_eq!(built, 24 - 1 - judged);
    let scene = rtow();
    let p = PackedScene::for_walk(&scene, Traversal::BruteForce, LeafLayout::Indexed);
    assert_eq!(p.nodes[0].count() as usize, scene.primitives().len());
    let ids: Vec<u32> = p.leaf_entries.iter().flatten().copied().collect();
    assert!(ids[..scene.primitives().len()]
        .iter()
        .enumerate()
        .all(|(i, &q)| i as u32 == q));
}

#[test]
fn brute_force_is_refused_beyond_tiny_scenes_and_llvmpipes_loop_limit() {
    use gpu::renderer::{brute_force_refusal, BRUTE_FORCE_MAX_PRIMITIVES};
    assert_eq!(
        brute_force_refusal(BRUTE_FORCE_MAX_PRIMITIVES, 8, true),
        None
    );
    assert!(brute_force_refusal(BRUTE_FORCE_MAX_PRIMITIVES + 1, 8, false).is_some());
    // 1,024 primitives, 2 rays a segment: 32 segments reach 65,536.
    assert_eq!(brute_force_refusal(1024, 31, true), None);
    assert!(brute_force_refusal(1024, 32, true).is_some());
    assert_eq!(brute_force_refusal(1024, 1024, false), None);
    // The renderer refuses with one line naming the way out.
    let ctx = common::gpu();
    let scene = reference::load_scene("spheres-10k").unwrap();
    let variant = gpu::Variant {
        integrator: Integrator::Bsdf,
        kernel: gpu::Kernel::Specialized,
        schedule: gpu::Schedule::PathMegakernel,
        traversal: Traversal::BruteForce,
        nodes: NodeLayout::Aos,
        leaves: LeafLayout::Indexed,
        dispatch: gpu::Dispatch::Switch,
        checks: gpu::Checks::Trusted,
    };
    let r = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(variant)).unwrap();
    let settings = reference::RenderSettings {
        width: 4,
        height: 4,
        spp: 1,
        ..scene.render_settings()
    };
    let e = r
        .render(&settings, &|_, _| {})
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("use --traversal bvh2 or bvh4"), "{e}");
}

/// llvmpipe stops every loop of an invocation after 65,535 iterations in
/// all; the megakernel used to trace a dispatch's samples in one loop and
/// lost most of 2,048 samples of a 4x4 image there. Where the adapter is
/// a GPU this is an ordinary render, equal to the path megakernel's.
#[test]
fn many_samples_of_a_tiny_image_are_all_traced() {
    use gpu::renderer::software_samples_per_invocation as most;
    // 9 segments of 2 · (1 + 1) + 256 iterations, plus one: 2,341 a sample.
    assert_eq!(most(1, 1, 8), 65_535 / 2_341);
    assert_eq!(most(10_000, 20_000, 8), 1);
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let settings = reference::RenderSettings {
        width: 4,
        height: 4,
        spp: 2048,
        max_depth: 8,
        ..scene.render_settings()
    };
    let film = |schedule| {
        let variant = gpu::Variant {
            integrator: Integrator::Bsdf,
            kernel: gpu::Kernel::Specialized,
            schedule,
            traversal: Traversal::Binary,
            nodes: NodeLayout::Aos,
            leaves: LeafLayout::Indexed,
            dispatch: gpu::Dispatch::Switch,
            checks: gpu::Checks::Trusted,
        };
        let r = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(variant)).unwrap();
        twintrace::twins::film_words::film_words(&r.render(&settings, &|_, _| {}).unwrap().film)
    };
    let mega = film(gpu::Schedule::Megakernel);
    let paths = film(gpu::Schedule::PathMegakernel);
    twintrace::twins::film_words::compare_words(&mega, &paths).unwrap();
}
