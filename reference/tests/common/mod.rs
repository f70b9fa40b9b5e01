//! Shared by the intersection test files: random scenes (as proptest
//! strategies), ray generators that aim at the hard cases (vertices,
//! edges, surface points, axis-parallel directions), and the fixture list.
#![allow(dead_code)]

use glam::{Quat, Vec3};
use proptest::prelude::*;
use reference::geometry::{spawn_origin, Ray};
use reference::material::{Alpha, AlphaMode, Material};
use reference::scene::{primitive_tag, MeshInput, Scene, SceneBuilder, Transform};
use reference::texture::Texture;

/// Every scene the repository ships: the built-ins and the JSON fixtures.
pub fn fixture_names() -> Vec<String> {
    let mut names: Vec<String> = reference::builtin::NAMES
        .iter()
        .map(|s| s.to_string())
        .collect();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/scenes");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert!(
        files.len() >= 8,
        "expected the fixture scenes under {}",
        dir.display()
    );
    names.extend(files);
    names
}

pub fn load(name: &str) -> Scene {
    reference::load_scene(name).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Short display name of a fixture (file stem or built-in name).
pub fn short(name: &str) -> &str {
    std::path::Path::new(name)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or(name)
}

/// SplitMix64: the rays' randomness (a test-local generator, so ray sets
/// depend only on the seed proptest persists).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    pub fn unit_vector(&mut self) -> Vec3 {
        let u = glam::Vec2::new(self.f32(), self.f32());
        reference::sampling::sample_uniform_sphere(u)
    }

    pub fn point_in(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }
}

/// A material-less description of one object of a random scene.
#[derive(Clone, Debug)]
pub enum ShapeSpec {
    Sphere {
        center: Vec3,
        radius: f32,
    },
    Quad {
        corner: Vec3,
        u: Vec3,
        v: Vec3,
    },
    Cuboid {
        min: Vec3,
        size: Vec3,
        rotate_y: f32,
    },
    Triangle {
        p: [Vec3; 3],
    },
    /// An `n x n` grid of triangle pairs in the parallelogram (corner, u, v):
    /// shared edges and vertices.
    Grid {
        corner: Vec3,
        u: Vec3,
        v: Vec3,
        n: u32,
    },
    Icosphere {
        center: Vec3,
        radius: f32,
        subdivisions: u32,
    },
    /// An exact copy of an earlier shape (index modulo the count so far).
    Duplicate(usize),
}

/// Coordinates: half of them snapped to a coarse lattice, so that random
/// scenes contain coplanar faces, shared edges, touching and coincident
/// primitives; the rest anywhere in the box.
pub fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![(-8i32..=8).prop_map(|k| k as f32 * 0.5), -6.0f32..6.0]
}

pub fn point() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Edge vectors: often axis-parallel (coplanar with lattice planes).
pub fn edge() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        (
            0usize..3,
            prop_oneof![Just(-2.0f32), Just(-1.0), Just(0.5), Just(1.0), Just(3.0)]
        )
            .prop_map(|(axis, len)| {
                let mut v = Vec3::ZERO;
                v[axis] = len;
                v
            }),
        (-4.0f32..4.0, -4.0f32..4.0, -4.0f32..4.0).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
    ]
}

pub fn shape() -> impl Strategy<Value = ShapeSpec> {
    prop_oneof![
        2 => (point(), prop_oneof![0.01f32..3.0, Just(0.5), Just(1.0)], any::<bool>())
            .prop_map(|(center, r, inward)| ShapeSpec::Sphere { center, radius: if inward { -r } else { r } }),
        3 => (point(), edge(), edge()).prop_map(|(corner, u, v)| ShapeSpec::Quad { corner, u, v }),
        1 => (point(), (0.1f32..3.0, 0.1f32..3.0, 0.1f32..3.0), prop_oneof![Just(0.0f32), -90.0f32..90.0])
            .prop_map(|(min, (x, y, z), rotate_y)| ShapeSpec::Cuboid { min, size: Vec3::new(x, y, z), rotate_y }),
        3 => (point(), point(), point()).prop_map(|(a, b, c)| ShapeSpec::Triangle { p: [a, b, c] }),
        1 => (point(), edge(), edge(), 1u32..5).prop_map(|(corner, u, v, n)| ShapeSpec::Grid { corner, u, v, n }),
        1 => (point(), 0.2f32..3.0, 0u32..3).prop_map(|(center, radius, subdivisions)| ShapeSpec::Icosphere { center, radius, subdivisions }),
        2 => any::<usize>().prop_map(ShapeSpec::Duplicate),
    ]
}

pub fn scene_spec(max_shapes: usize) -> impl Strategy<Value = Vec<ShapeSpec>> {
    proptest::collection::vec(shape(), 1..=max_shapes)
}

fn grid_mesh(corner: Vec3, u: Vec3, v: Vec3, n: u32) -> MeshInput {
    let mut m = MeshInput::default();
    for j in 0..=n {
        for i in 0..=n {
            m.positions
                .push(corner + u * (i as f32 / n as f32) + v * (j as f32 / n as f32));
        }
    }
    let id = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            m.indices.extend([
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j),
                id(i + 1, j + 1),
                id(i, j + 1),
            ]);
        }
    }
    m
}

/// Builds the scene; degenerate shapes the builder rejects (parallel quad
/// edges, zero radius) are left out, as a scene file with them would fail.
pub fn build_scene(spec: &[ShapeSpec]) -> Option<Scene> {
    build_scene_placed(spec, &Transform::default())
}

/// As [`build_scene`], every shape placed by `placement`.
pub fn build_scene_placed(spec: &[ShapeSpec], placement: &Transform) -> Option<Scene> {
    build(spec, placement, None)
}

/// As [`build_scene`], the triangle meshes' material with a coverage:
/// MASK (cutoff 0.5) over a 3-D checker of alpha 0 and 1 (no texture
/// coordinates needed: holes in every mesh), or BLEND at alpha 0.5.
pub fn build_scene_alpha(spec: &[ShapeSpec], mode: AlphaMode) -> Option<Scene> {
    build(spec, &Transform::default(), Some(mode))
}

fn build(spec: &[ShapeSpec], placement: &Transform, alpha: Option<AlphaMode>) -> Option<Scene> {
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::splat(0.7)).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: white })
        .unwrap();
    let mesh_material = match alpha {
        None => m,
        Some(mode) => {
            let mt = b
                .add_material(Material::Lambertian { albedo: white })
                .unwrap();
            let texture = match mode {
                AlphaMode::Mask { .. } => {
                    let odd = b.constant(Vec3::ZERO).unwrap();
                    let even = b.constant(Vec3::ONE).unwrap();
                    b.add_texture(Texture::Checker {
                        scale: 3.0,
                        even,
                        odd,
                    })
                    .unwrap()
                }
                AlphaMode::Blend => b.constant(Vec3::splat(0.5)).unwrap(),
            };
            b.set_alpha(mt, Alpha { texture, mode }).unwrap();
            mt
        }
    };
    let mut placed = 0;
    for (k, s) in spec.iter().enumerate() {
        // Resolve duplicates to a concrete earlier shape (the index strictly
        // decreases, so this ends; a duplicate at index 0 adds nothing).
        let (mut s, mut j) = (s, k);
        while let ShapeSpec::Duplicate(i) = *s {
            if j == 0 {
                break;
            }
            j = i % j;
            s = &spec[j];
        }
        let ok = match *s {
            ShapeSpec::Sphere { center, radius } => {
                b.add_sphere(center, radius, m, placement).is_ok()
            }
            ShapeSpec::Quad { corner, u, v } => b.add_quad(corner, u, v, m, placement).is_ok(),
            ShapeSpec::Cuboid {
                min,
                size,
                rotate_y,
            } => {
                let t = Transform {
                    matrix: placement.matrix
                        * Transform::from_parts(
                            Vec3::ONE,
                            Quat::from_rotation_y(rotate_y.to_radians()),
                            Vec3::ZERO,
                        )
                        .matrix,
                };
                b.add_box(min, min + size, m, &t).is_ok()
            }
            ShapeSpec::Triangle { p } => b
                .add_mesh(
                    &MeshInput {
                        positions: p.to_vec(),
                        indices: vec![0, 1, 2],
                        ..Default::default()
                    },
                    mesh_material,
                    placement,
                )
                .is_ok(),
            ShapeSpec::Grid { corner, u, v, n } => b
                .add_mesh(&grid_mesh(corner, u, v, n), mesh_material, placement)
                .is_ok(),
            ShapeSpec::Icosphere {
                center,
                radius,
                subdivisions,
            } => {
                let t = Transform {
                    matrix: placement.matrix
                        * Transform::from_parts(Vec3::splat(radius), Quat::IDENTITY, center).matrix,
                };
                b.add_mesh(
                    &reference::procedural::icosphere(subdivisions),
                    mesh_material,
                    &t,
                )
                .is_ok()
            }
            ShapeSpec::Duplicate(_) => false,
        };
        placed += ok as usize;
    }
    if placed == 0 {
        return None;
    }
    let c = placement.point(Vec3::new(0.0, 0.0, 30.0));
    b.camera.look_from = c;
    b.camera.look_at = placement.point(Vec3::ZERO);
    b.build().ok()
}

/// Points worth aiming at: every triangle and quad vertex, quad centres,
/// sphere poles and centres.
pub fn feature_points(scene: &Scene) -> Vec<Vec3> {
    let mut pts = Vec::new();
    for s in scene.spheres() {
        pts.push(s.center);
        pts.push(s.center + Vec3::Y * s.radius.abs());
        pts.push(s.center - Vec3::X * s.radius.abs());
    }
    for q in scene.quads() {
        pts.extend([
            q.corner,
            q.corner + q.u,
            q.corner + q.v,
            q.corner + q.u + q.v,
            q.corner + 0.5 * (q.u + q.v),
        ]);
    }
    for t in scene.triangles() {
        pts.extend(t.vertices.map(|i| scene.mesh().positions[i as usize]));
    }
    pts
}

/// Edges worth aiming along and at: triangle edges and quad edges.
pub fn feature_edges(scene: &Scene) -> Vec<(Vec3, Vec3)> {
    let mut edges = Vec::new();
    for q in scene.quads() {
        let c = [
            q.corner,
            q.corner + q.u,
            q.corner + q.u + q.v,
            q.corner + q.v,
        ];
        for i in 0..4 {
            edges.push((c[i], c[(i + 1) % 4]));
        }
    }
    for t in scene.triangles() {
        let p = t.vertices.map(|i| scene.mesh().positions[i as usize]);
        for i in 0..3 {
            edges.push((p[i], p[(i + 1) % 3]));
        }
    }
    edges
}

/// One query: a ray and its open interval.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    pub ray: Ray,
    pub t_min: f32,
    pub t_max: f32,
    /// Which generator made it (for failure messages and statistics).
    pub kind: RayKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// Random origin in the (slightly grown) scene bounds, random direction.
    Random,
    /// Aimed exactly at a vertex or feature point.
    AtVertex,
    /// Aimed at a point on an edge.
    AtEdge,
    /// Axis-parallel direction from a lattice-snapped origin.
    AxisParallel,
    /// Starting exactly on a surface (the f32 point `o + t·d` of a hit), t_min = 0.
    OnSurface,
    /// Spawned from a hit by `spawn_origin`, as the tracer does.
    Spawned,
    /// A random ray with `t_min > 0` and a finite `t_max`.
    Interval,
}

/// Every kind of query.
pub const ALL_KINDS: &[RayKind] = &[
    RayKind::Random,
    RayKind::AtVertex,
    RayKind::AtEdge,
    RayKind::AxisParallel,
    RayKind::OnSurface,
    RayKind::Spawned,
    RayKind::Interval,
];

/// The hard cases: every kind but the uniformly random one.
pub const TARGETED_KINDS: &[RayKind] = &[
    RayKind::AtVertex,
    RayKind::AtEdge,
    RayKind::AxisParallel,
    RayKind::OnSurface,
    RayKind::Spawned,
    RayKind::Interval,
];

/// `n` queries of every kind, deterministic in `seed`.
pub fn queries(scene: &Scene, seed: u64, n: usize) -> Vec<Query> {
    queries_of(scene, seed, n, ALL_KINDS)
}

/// `n` queries, each of a kind drawn from `kinds`, deterministic in `seed`.
pub fn queries_of(scene: &Scene, seed: u64, n: usize, kinds: &[RayKind]) -> Vec<Query> {
    let mut rng = Rng::new(seed);
    let b = scene.bounds();
    let pad = (b.max - b.min).max(Vec3::splat(1e-3)) * 0.1;
    let (lo, hi) = (b.min - pad, b.max + pad);
    let pts = feature_points(scene);
    let edges = feature_edges(scene);
    let mut out = Vec::with_capacity(n);
    let inf = f32::INFINITY;
    // Kinds that start from a hit need the scene to be hit at all; give up
    // (with fewer queries) rather than loop on a scene nothing hits.
    let mut attempts = 0usize;
    while out.len() < n && attempts < 100 * n {
        attempts += 1;
        let o = rng.point_in(lo, hi);
        let q = match kinds[rng.below(kinds.len())] {
            RayKind::Random => Query {
                ray: Ray::new(o, rng.unit_vector()),
                t_min: 0.0,
                t_max: inf,
                kind: RayKind::Random,
            },
            RayKind::AtVertex => {
                let target = pts[rng.below(pts.len())];
                Query {
                    ray: Ray::new(o, target - o),
                    t_min: 0.0,
                    t_max: inf,
                    kind: RayKind::AtVertex,
                }
            }
            RayKind::AtEdge if !edges.is_empty() => {
                let (a, e) = edges[rng.below(edges.len())];
                let target = a.lerp(e, rng.f32());
                Query {
                    ray: Ray::new(o, target - o),
                    t_min: 0.0,
                    t_max: inf,
                    kind: RayKind::AtEdge,
                }
            }
            RayKind::AtEdge => continue,
            RayKind::AxisParallel => {
                let mut d = Vec3::ZERO;
                d[rng.below(3)] = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                // Snap the origin to the lattice of `coord()` on the two
                // other axes: the ray then runs through shared edges.
                let snapped = (o * 2.0).round() * 0.5;
                let o = Vec3::select(d.abs().cmpgt(Vec3::ZERO), o, snapped);
                Query {
                    ray: Ray::new(o, d),
                    t_min: 0.0,
                    t_max: inf,
                    kind: RayKind::AxisParallel,
                }
            }
            k @ (RayKind::OnSurface | RayKind::Spawned) => {
                let first = Ray::new(o, rng.unit_vector());
                let Some(hit) = scene.intersect(&first, 0.0, inf) else {
                    continue;
                };
                let dir = rng.unit_vector();
                if k == RayKind::OnSurface {
                    Query {
                        ray: Ray::new(first.at(hit.t), dir),
                        t_min: 0.0,
                        t_max: inf,
                        kind: RayKind::OnSurface,
                    }
                } else {
                    let si = scene.surface_interaction(&first, &hit);
                    let n = si.geometric_normal;
                    let side = if dir.dot(n) >= 0.0 { n } else { -n };
                    Query {
                        ray: Ray::new(spawn_origin(si.p, side, si.p_error), dir),
                        t_min: 0.0,
                        t_max: inf,
                        kind: RayKind::Spawned,
                    }
                }
            }
            RayKind::Interval => {
                let d = rng.unit_vector();
                let span = (hi - lo).length();
                let t_min = rng.range(0.0, 0.5) * span;
                let t_max = t_min + rng.range(0.0, 1.0) * span;
                Query {
                    ray: Ray::new(o, d),
                    t_min,
                    t_max,
                    kind: RayKind::Interval,
                }
            }
        };
        if q.ray.direction.length_squared() > 0.0 && q.ray.direction.is_finite() {
            out.push(q);
        }
    }
    out
}

/// Primitive counts by kind, for messages.
pub fn describe(scene: &Scene) -> String {
    let count = |tag| scene.primitives().iter().filter(|p| p.tag == tag).count();
    format!(
        "{} spheres, {} quads, {} triangles",
        count(primitive_tag::SPHERE),
        count(primitive_tag::QUAD),
        count(primitive_tag::TRIANGLE)
    )
}
