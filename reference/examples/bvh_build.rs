//! BVH build time and shape for the meshes of reference/benches/traversal.rs:
//! `cargo run --release -p reference --example bvh_build`.

use glam::Vec3;
use reference::material::Material;
use reference::scene::{MeshInput, SceneBuilder, Transform};

/// A benchmark mesh: its name and how to make it.
type Mesh = (&'static str, Box<dyn Fn() -> MeshInput>);

fn main() {
    let meshes: [Mesh; 4] = [
        (
            "torus, 10^4 triangles",
            Box::new(|| reference::procedural::torus(1.0, 0.35, 100, 50)),
        ),
        (
            "torus, 10^6 triangles",
            Box::new(|| reference::procedural::torus(1.0, 0.35, 1000, 500)),
        ),
        (
            "bumpy sphere, 20,480 triangles",
            Box::new(|| reference::procedural::bumpy_sphere(5, 0.08, 6.0)),
        ),
        (
            "bumpy sphere, 1,310,720 triangles",
            Box::new(|| reference::procedural::bumpy_sphere(8, 0.08, 6.0)),
        ),
    ];
    println!("| mesh | build ms | nodes | leaves | max depth | SAH cost |");
    println!("|---|---|---|---|---|---|");
    for (name, mesh) in meshes {
        let mut b = SceneBuilder::new();
        let white = b.constant(Vec3::splat(0.7)).unwrap();
        let m = b
            .add_material(Material::Lambertian { albedo: white })
            .unwrap();
        b.add_mesh(&mesh(), m, &Transform::default()).unwrap();
        let s = b.build().unwrap().bvh_stats();
        println!(
            "| {name} | {:.1} | {} | {} | {} | {:.2} |",
            s.build_time.as_secs_f64() * 1e3,
            s.nodes,
            s.leaves,
            s.max_depth,
            s.sah_cost
        );
    }
}
