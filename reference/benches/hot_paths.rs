//! Criterion microbenchmarks of the reference's hot paths: the BVH
//! traversal, each intersection routine, BSDF sampling per material, the
//! sampling warps and the counter-based RNG. Benchmarks, never tests:
//! `cargo bench -p reference --bench hot_paths` (docs/benchmarks.md).
//! Each routine runs over a fixed batch of inputs (counter-based random
//! numbers), so that branch prediction cannot learn one input.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Vec2, Vec3};
use reference::geometry::{Ray, SurfaceInteraction};
use reference::material::{scatter, Material, TextureContext};
use reference::rng::{random_f32, random_u32, vertex_randoms};
use reference::sampling::{sample_cosine_hemisphere, sample_uniform_sphere};
use reference::scene::{SceneBuilder, Transform};
use reference::shapes::{
    intersect_quad, intersect_sphere, intersect_triangle, intersect_triangles4, RayShear,
    Triangles4,
};
use reference::texture::Texture;
use std::hint::black_box;

const BATCH: u32 = 1024;

fn u(i: u32, d: u32) -> f32 {
    random_f32(11, i, 0, 0, d)
}

/// Rays from points in [-2, 2]³ toward points in [-0.5, 0.5]³: most of
/// them pass near the unit-sized shapes at the origin.
fn rays() -> Vec<Ray> {
    (0..BATCH)
        .map(|i| {
            let o = Vec3::new(u(i, 0), u(i, 1), u(i, 2)) * 4.0 - 2.0;
            let t = Vec3::new(u(i, 3), u(i, 4), u(i, 5)) - 0.5;
            Ray::new(o, (t - o).normalize())
        })
        .collect()
}

fn intersections(c: &mut Criterion) {
    let rays = rays();
    let mut g = c.benchmark_group("intersect");
    g.throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("sphere", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| intersect_sphere(Vec3::ZERO, 0.5, r, 0.0, f32::INFINITY).is_some())
                .count()
        })
    });
    let (corner, qu, qv) = (Vec3::new(-0.5, -0.5, 0.0), Vec3::X, Vec3::Y);
    g.bench_function("quad", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| intersect_quad(corner, qu, qv, r, 0.0, f32::INFINITY).is_some())
                .count()
        })
    });
    let tri = [
        Vec3::new(-0.5, -0.5, 0.1),
        Vec3::new(0.5, -0.4, 0.0),
        Vec3::new(0.0, 0.5, -0.1),
    ];
    g.bench_function("triangle", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| {
                    intersect_triangle(tri[0], tri[1], tri[2], r, 0.0, f32::INFINITY).is_some()
                })
                .count()
        })
    });
    let mut four = Triangles4::EMPTY;
    for lane in 0..4 {
        let s = lane as f32 * 0.1;
        four.set(lane, tri.map(|p| p + Vec3::splat(s)));
    }
    let shears: Vec<(Ray, RayShear)> = rays
        .iter()
        .filter_map(|r| Some((*r, RayShear::new(r.direction)?)))
        .collect();
    g.throughput(Throughput::Elements(4 * shears.len() as u64));
    g.bench_function("triangles4 (four triangles per call)", |b| {
        b.iter(|| {
            shears
                .iter()
                .map(|(r, s)| intersect_triangles4(&four, r, s, 0.0, f32::INFINITY).mask)
                .sum::<u32>()
        })
    });
    g.finish();
}

fn traversal(c: &mut Criterion) {
    let mut g = c.benchmark_group("bvh");
    for (name, segments) in [
        ("torus 10^4 triangles", (100, 50)),
        ("torus 10^6 triangles", (1000, 500)),
    ] {
        let mesh = reference::procedural::torus(1.0, 0.4, segments.0, segments.1);
        let mut b = SceneBuilder::new();
        let grey = b.constant(Vec3::splat(0.5)).unwrap();
        let m = b
            .add_material(Material::Lambertian { albedo: grey })
            .unwrap();
        b.add_mesh(&mesh, m, &Transform::default()).unwrap();
        let scene = b.build().unwrap();
        // Incoherent rays from points in the torus' bounds, uniform directions.
        let (lo, hi) = (scene.bounds().min, scene.bounds().max);
        let rays: Vec<Ray> = (0..BATCH)
            .map(|i| {
                let o = lo + (hi - lo) * Vec3::new(u(i, 0), u(i, 1), u(i, 2));
                Ray::new(o, sample_uniform_sphere(Vec2::new(u(i, 3), u(i, 4))))
            })
            .collect();
        g.throughput(Throughput::Elements(BATCH as u64));
        g.bench_function(format!("closest hit, {name}"), |bch| {
            bch.iter(|| {
                rays.iter()
                    .filter(|r| scene.intersect(r, 0.0, f32::INFINITY).is_some())
                    .count()
            })
        });
    }
    let scene = reference::load_scene("rtow-final").unwrap();
    let cam = scene.camera(400, 300);
    let rays: Vec<Ray> = (0..BATCH)
        .map(|i| cam.generate_ray(Vec2::new(u(i, 0), u(i, 1)), Vec2::new(u(i, 2), u(i, 3))))
        .collect();
    g.bench_function("closest hit, rtow-final camera rays", |bch| {
        bch.iter(|| {
            rays.iter()
                .filter(|r| scene.intersect(r, 0.0, f32::INFINITY).is_some())
                .count()
        })
    });
    g.finish();
}

fn bsdf_sampling(c: &mut Criterion) {
    let textures = [Texture::Constant(Vec3::new(0.7, 0.5, 0.3))];
    let ctx = TextureContext {
        textures: &textures,
        images: &[],
    };
    let si = SurfaceInteraction {
        p: Vec3::ZERO,
        geometric_normal: Vec3::Y,
        shading_normal: Vec3::Y,
        uv: Vec2::ZERO,
        uv1: Vec2::ZERO,
        color: Vec3::ONE,
        p_error: 0.0,
        front_face: true,
        material: 0,
        tangent: Vec3::X,
        bitangent: -Vec3::Z,
        dp_du: Vec3::X,
        dp_dv: -Vec3::Z,
    };
    let dirs: Vec<Vec3> = (0..BATCH)
        .map(|i| -sample_cosine_hemisphere(Vec2::new(u(i, 0), u(i, 1))))
        .collect();
    let randoms: Vec<[f32; 8]> = (0..BATCH).map(|i| vertex_randoms(3, i, 0, 1)).collect();
    let mut g = c.benchmark_group("scatter");
    g.throughput(Throughput::Elements(BATCH as u64));
    for (name, m) in [
        ("lambertian", Material::Lambertian { albedo: 0 }),
        (
            "metal fuzz 0.2",
            Material::Metal {
                albedo: 0,
                fuzz: 0.2,
            },
        ),
        (
            "dielectric",
            Material::Dielectric {
                ior: 1.5,
                absorption: Vec3::ZERO,
            },
        ),
        (
            "ggx roughness 0.4",
            Material::Ggx {
                base_color: 0,
                metallic: 0.5,
                roughness: 0.4,
                metallic_roughness: None,
                normal_map: None,
                clearcoat: None,
            },
        ),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                dirs.iter()
                    .zip(&randoms)
                    .filter(|(d, r)| scatter(&m, ctx, **d, &si, r).is_some())
                    .count()
            })
        });
    }
    g.finish();
}

fn sampling_and_rng(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampling");
    g.throughput(Throughput::Elements(BATCH as u64));
    let us: Vec<Vec2> = (0..BATCH).map(|i| Vec2::new(u(i, 0), u(i, 1))).collect();
    g.bench_function("cosine hemisphere", |b| {
        b.iter(|| {
            us.iter()
                .map(|&x| sample_cosine_hemisphere(x))
                .sum::<Vec3>()
        })
    });
    g.bench_function("uniform sphere", |b| {
        b.iter(|| us.iter().map(|&x| sample_uniform_sphere(x)).sum::<Vec3>())
    });
    g.finish();
    let mut g = c.benchmark_group("rng");
    g.throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("random_u32", |b| {
        b.iter(|| (0..BATCH).fold(0u32, |a, i| a ^ random_u32(black_box(1), i, 2, 3, 4)))
    });
    g.bench_function("vertex_randoms (8 dimensions)", |b| {
        b.iter(|| {
            (0..BATCH)
                .map(|i| vertex_randoms(black_box(1), i, 2, 3)[7])
                .sum::<f32>()
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    intersections,
    traversal,
    bsdf_sampling,
    sampling_and_rng
);
criterion_main!(benches);
