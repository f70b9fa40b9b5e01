//! Rays per second of the reference BVH traversal (`Scene::intersect`)
//! against Embree 4's `rtcIntersect1` (through `reference::embree`), on one
//! thread, on the same incoherent rays. A benchmark, never a test:
//!
//! ```sh
//! # after `cargo xtask test` has unpacked Embree into target/embree/lib:
//! LIBRARY_PATH=$PWD/target/embree/lib LD_LIBRARY_PATH=$PWD/target/embree/lib \
//!     cargo bench -p reference --features embree --bench traversal
//! ```
//!
//! Scenes: rtow-final (488 spheres; rays from random points among the small
//! spheres, 0.05–3 above the ground, in uniform directions), and closed
//! meshes with rays from random interior points in uniform directions:
//! tori of exactly 10^4 and 10^6 triangles, and the bumpy spheres that
//! docs/benchmarks.md's Embree anchors name, at the icosphere levels on either side
//! of its 10^4 and 10^6 triangles (`bumpy_sphere` levels 4, 5, 7 and 8:
//! 5,120, 20,480, 327,680 and 1,310,720 triangles). `TWINTRACE_BENCH_RAYS` sets
//! the ray count (default 10^6), `TWINTRACE_BENCH_ONLY` a substring of the
//! scene names to run (only those scenes are built). Each figure is the
//! best of three passes after a warm-up.

use glam::Vec3;
use reference::embree::EmbreeScene;
use reference::geometry::Ray;
use reference::material::Material;
use reference::scene::{MeshInput, Scene, SceneBuilder, Transform};
use std::hint::black_box;
use std::time::Instant;

/// SplitMix64 (the same generator the tests use).
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    fn unit(&mut self) -> Vec3 {
        reference::sampling::sample_uniform_sphere(glam::Vec2::new(self.f32(), self.f32()))
    }
}

fn mesh_scene(mesh: &MeshInput) -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::splat(0.7)).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: white })
        .unwrap();
    b.add_mesh(mesh, m, &Transform::default()).unwrap();
    b.camera.look_from = Vec3::new(0.0, 0.0, 5.0);
    b.build().unwrap()
}

fn rays(n: usize, seed: u64, origin: impl Fn(&mut Rng) -> Vec3) -> Vec<Ray> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| Ray::new(origin(&mut rng), rng.unit()))
        .collect()
}

/// Best of three timed passes (after one warm-up) in rays per second, and
/// the number of hits (which must match between the two intersectors).
fn measure(rays: &[Ray], mut intersect: impl FnMut(&Ray) -> bool) -> (f64, usize) {
    let mut hits = 0;
    let mut best = f64::INFINITY;
    for pass in 0..4 {
        let t0 = Instant::now();
        let mut h = 0usize;
        for r in rays {
            h += intersect(black_box(r)) as usize;
        }
        let dt = t0.elapsed().as_secs_f64();
        if pass > 0 {
            best = best.min(dt);
        }
        hits = black_box(h);
    }
    (rays.len() as f64 / best, hits)
}

fn main() {
    let n: usize = std::env::var("TWINTRACE_BENCH_RAYS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000);
    let in_tube = |major: f32, minor: f32| {
        move |r: &mut Rng| {
            let phi = r.f32() * std::f32::consts::TAU;
            Vec3::new(phi.cos(), 0.0, phi.sin()) * major + r.unit() * (0.8 * minor * r.f32().cbrt())
        }
    };
    let in_ball = |radius: f32| move |r: &mut Rng| r.unit() * (radius * r.f32().cbrt());
    type Case = (&'static str, Box<dyn Fn() -> (Scene, Vec<Ray>)>);
    let torus = |segments: u32, rings: u32, seed: u64| {
        move || {
            (
                mesh_scene(&reference::procedural::torus(1.0, 0.35, segments, rings)),
                rays(n, seed, in_tube(1.0, 0.35)),
            )
        }
    };
    let bumpy = |level: u32, seed: u64| {
        move || {
            (
                mesh_scene(&reference::procedural::bumpy_sphere(level, 0.08, 6.0)),
                rays(n, seed, in_ball(0.5)),
            )
        }
    };
    // Built lazily: only the scenes `TWINTRACE_BENCH_ONLY` selects.
    let cases: Vec<Case> = vec![
        (
            "rtow-final (488 spheres)",
            Box::new(move || {
                let rays = rays(n, 1, |r| {
                    Vec3::new(
                        24.0 * r.f32() - 12.0,
                        0.05 + 2.95 * r.f32(),
                        24.0 * r.f32() - 12.0,
                    )
                });
                (reference::builtin::load("rtow-final").unwrap(), rays)
            }),
        ),
        ("torus, 10^4 triangles", Box::new(torus(100, 50, 2))),
        ("torus, 10^6 triangles", Box::new(torus(1000, 500, 3))),
        ("bumpy sphere, 5,120 triangles", Box::new(bumpy(4, 4))),
        ("bumpy sphere, 20,480 triangles", Box::new(bumpy(5, 6))),
        ("bumpy sphere, 327,680 triangles", Box::new(bumpy(7, 5))),
        ("bumpy sphere, 1,310,720 triangles", Box::new(bumpy(8, 7))),
    ];
    println!("{n} incoherent rays per scene, one thread, best of 3 passes\n");
    println!("| scene | reference rays/s | Embree rtcIntersect1 rays/s | reference / Embree |");
    println!("|---|---|---|---|");
    let only = std::env::var("TWINTRACE_BENCH_ONLY").unwrap_or_default();
    for (name, make) in cases.iter().filter(|c| c.0.contains(only.as_str())) {
        let (scene, rays) = make();
        let (scene, rays) = (&scene, &rays);
        let embree = EmbreeScene::new(scene).expect("embree scene");
        let (ref_rate, ref_hits) =
            measure(rays, |r| scene.intersect(r, 0.0, f32::INFINITY).is_some());
        let (emb_rate, emb_hits) =
            measure(rays, |r| embree.intersect(r, 0.0, f32::INFINITY).is_some());
        // The same rays, so the same number of hits (closed meshes: all).
        let differ = ref_hits.abs_diff(emb_hits);
        assert!(
            differ * 10_000 <= rays.len(),
            "{name}: reference {ref_hits} hits, Embree {emb_hits}"
        );
        println!(
            "| {name} | {:.3}·10^6 | {:.3}·10^6 | {:.2}× |",
            ref_rate / 1e6,
            emb_rate / 1e6,
            ref_rate / emb_rate
        );
    }
}
