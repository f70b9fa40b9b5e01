//! Property: the BVH traversal returns exactly what a scan over every
//! primitive returns — the same primitive id and the bitwise-identical t —
//! on random scenes full of coplanar, touching and duplicated primitives,
//! for random rays, rays aimed at vertices and along edges, axis-parallel
//! rays, rays starting on surfaces and rays spawned from hits, with open
//! and finite intervals. Both paths use the same intersection routines and
//! break ties in t by the smaller id, so any difference is a traversal bug
//! (a box culled that held the winner). Failing cases are persisted under
//! proptest-regressions/.

use crate::common;
use crate::common::{
    build_scene, fixture_names, load, queries, scene_spec, short, Query, ShapeSpec,
};
use glam::Vec3;
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;
use reference::bvh::{Bvh, BvhNode};
use reference::material::AlphaMode;
use reference::scene::{primitive_tag, Scene};

/// The first query on which the BVH and the brute-force scan differ.
fn first_mismatch(scene: &Scene, qs: &[Query]) -> Option<String> {
    for (i, q) in qs.iter().enumerate() {
        let fast = scene.intersect(&q.ray, q.t_min, q.t_max);
        let slow = scene.intersect_brute_force(&q.ray, q.t_min, q.t_max);
        let same = match (fast, slow) {
            (Some(f), Some(s)) => {
                f.prim == s.prim && f.t.to_bits() == s.t.to_bits() && f.uv == s.uv
            }
            (None, None) => true,
            _ => false,
        };
        if !same {
            return Some(format!(
                "query {i} ({:?}): {q:?}\n  bvh:         {fast:?}\n  brute force: {slow:?}",
                q.kind
            ));
        }
    }
    None
}

/// `cases` per run; PROPTEST_CASES overrides it for a longer soak.
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(cases),
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "proptest-regressions/bvh_property.txt",
        ))),
        ..ProptestConfig::default()
    }
}

proptest! {
    // 1,000 scenes of up to 48 shapes (up to ~1,300 primitives with the
    // icospheres) × 512 queries: ~5·10^5 queries per run, a few seconds.
    // A soak of 20,000 cases (PROPTEST_CASES=20000) passed.
    #![proptest_config(config(1000))]

    #[test]
    fn bvh_equals_brute_force_on_random_scenes(spec in scene_spec(48), seed in any::<u64>()) {
        let Some(scene) = build_scene(&spec) else { return Ok(()) };
        let qs = queries(&scene, seed, 512);
        if let Some(m) = first_mismatch(&scene, &qs) {
            prop_assert!(false, "{} ({}): {m}", scene.primitives().len(), common::describe(&scene));
        }
    }

    /// The triangle meshes cut by a coverage (a MASK checker of holes, or
    /// BLEND at one half): every walk rejects an uncovered hit where it
    /// accepts one (four-wide leaf blocks, entry by entry, the scan), so
    /// they still agree bit for bit. 300 scenes × 512 queries.
    #[test]
    fn bvh_equals_brute_force_with_alpha(spec in scene_spec(48), blend in any::<bool>(), seed in any::<u64>()) {
        let mode = if blend { AlphaMode::Blend } else { AlphaMode::Mask { cutoff: 0.5 } };
        let Some(scene) = common::build_scene_alpha(&spec, mode) else { return Ok(()) };
        let qs = queries(&scene, seed, 512);
        if let Some(m) = first_mismatch(&scene, &qs) {
            prop_assert!(false, "{mode:?}, {} ({}): {m}", scene.primitives().len(), common::describe(&scene));
        }
    }

    /// Many copies of few shapes: every hit ties in t with its copies and
    /// the SAH build sees coincident centroids.
    #[test]
    fn bvh_equals_brute_force_with_coincident_primitives(spec in scene_spec(4), copies in 2usize..40, seed in any::<u64>()) {
        let repeated: Vec<_> = (0..copies).flat_map(|_| spec.iter().cloned()).collect();
        let Some(scene) = build_scene(&repeated) else { return Ok(()) };
        let qs = queries(&scene, seed, 256);
        if let Some(m) = first_mismatch(&scene, &qs) {
            prop_assert!(false, "{m}");
        }
    }
}

#[test]
fn bvh_equals_brute_force_on_every_fixture() {
    for name in fixture_names() {
        let scene = load(&name);
        // The scan costs one test per primitive: fewer rays where there are many.
        let n = (4_000_000 / scene.primitives().len()).clamp(500, 20_000);
        let qs = queries(&scene, 0x5eed ^ scene.primitives().len() as u64, n);
        let hits = qs
            .iter()
            .filter(|q| scene.intersect(&q.ray, q.t_min, q.t_max).is_some())
            .count();
        assert!(
            hits * 5 > n,
            "{}: only {hits} of {n} queries hit: the test is not exercising the BVH",
            short(&name)
        );
        if let Some(m) = first_mismatch(&scene, &qs) {
            panic!("{}: {m}", short(&name));
        }
    }
}

/// The property must be able to fail: drop one primitive from one BVH leaf
/// (the gates' standard mutant: "a BVH child dropped") and the same
/// queries must find a difference, for each way a leaf is tested: a leaf
/// of quads and one of triangles (four at a time) and a leaf of quads and
/// spheres (entry by entry).
#[test]
fn a_dropped_bvh_leaf_entry_is_caught() {
    // 72 triangles, so that the queries hit each of them.
    let grid = ShapeSpec::Grid {
        corner: Vec3::new(-1.0, -1.0, 0.0),
        u: Vec3::new(2.0, 0.0, 0.0),
        v: Vec3::new(0.0, 2.0, 0.0),
        n: 6,
    };
    // Pairs of a quad and a sphere with the same centroid (no split can
    // part them), the pairs far apart: leaves of both kinds.
    let mixed: Vec<ShapeSpec> = (0..8)
        .flat_map(|i| {
            let x = i as f32 * 10.0;
            [
                ShapeSpec::Quad {
                    corner: Vec3::new(x, 0.0, 0.0),
                    u: Vec3::X,
                    v: Vec3::Y,
                },
                ShapeSpec::Sphere {
                    center: Vec3::new(x + 0.5, 0.5, 0.0),
                    radius: 0.5,
                },
            ]
        })
        .collect();
    let tags = [
        ("cornell", vec![primitive_tag::QUAD]),
        ("a grid of triangles", vec![primitive_tag::TRIANGLE]),
        (
            "quads and spheres",
            vec![primitive_tag::QUAD, primitive_tag::SPHERE],
        ),
    ];
    for (name, want) in tags {
        let scene = match name {
            "cornell" => load(name),
            "a grid of triangles" => build_scene(std::slice::from_ref(&grid)).expect("the grid"),
            _ => build_scene(&mixed).expect("the quads and spheres"),
        };
        let order = scene.bvh().prim_order().to_vec();
        let mut nodes = scene.bvh().nodes().to_vec();
        // The leaf's set of primitive kinds is exactly `want`.
        let kinds_are = |n: &BvhNode| {
            let mut tags: Vec<u32> = order[n.index as usize..(n.index + n.count()) as usize]
                .iter()
                .map(|&p| scene.primitives()[p as usize].tag)
                .collect();
            tags.sort_unstable();
            tags.dedup();
            let mut want = want.clone();
            want.sort_unstable();
            tags == want
        };
        let leaf = nodes
            .iter()
            .position(|n| n.is_leaf() && (2..=4).contains(&n.count()) && kinds_are(n))
            .unwrap_or_else(|| panic!("{name}: no leaf of two to four of those kinds"));
        nodes[leaf].meta -= 1 << 2; // count - 1: the last primitive of the leaf is never tested
        let scene = scene
            .with_bvh(Bvh::from_parts(nodes, order).unwrap())
            .unwrap();
        let qs = queries(&scene, 7, 20_000);
        assert!(
            first_mismatch(&scene, &qs).is_some(),
            "{name}: dropping a primitive from leaf {leaf} went unnoticed"
        );
    }
}
