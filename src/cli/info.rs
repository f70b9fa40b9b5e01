//! `twintrace info`: what a scene holds (its primitives, materials,
//! lights, render defaults and BVH) and the GPU adapters this machine has.

use super::common::{load_scene, print_stdout};
use anyhow::Result;
use clap::Args;
use reference::Scene;
use std::fmt::Write as _;

/// `twintrace info [SCENE]`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// A scene file (.json, .gltf, .glb, Mitsuba .xml) or a built-in scene name; without
    /// one, only the GPU adapters are listed.
    pub scene: Option<String>,
}

/// Prints the summary of `args`' scene (if any) and the adapters.
pub(super) fn info(args: &InfoArgs) -> Result<()> {
    let mut text = String::new();
    if let Some(spec) = &args.scene {
        let scene = load_scene(spec)?;
        text += &scene_summary(spec, &scene);
    }
    text += &adapter_summary(&gpu::list_adapters());
    print_stdout(&text)
}

/// The adapter list `twintrace info` prints.
pub fn adapter_summary(adapters: &[gpu::AdapterSummary]) -> String {
    if adapters.is_empty() {
        return "GPU adapters: none (the gpu backend needs a Vulkan, Metal, DX12 or GL driver; Mesa lavapipe is one: apt-get install mesa-vulkan-drivers)\n"
            .into();
    }
    let mut o = format!("GPU adapters: {}\n", adapters.len());
    for (i, a) in adapters.iter().enumerate() {
        let _ = writeln!(
            o,
            "  {i}: {} ({}, {}; {}): max storage buffer binding {} MiB, max buffer {} MiB, {} storage buffers per stage, {} invocations per workgroup, timestamps {}",
            a.name,
            a.backend,
            a.device_type,
            a.driver,
            a.max_storage_buffer_binding_size >> 20,
            a.max_buffer_size >> 20,
            a.max_storage_buffers_per_shader_stage,
            a.max_compute_invocations_per_workgroup,
            if a.timestamp_queries { "yes" } else { "no" }
        );
    }
    o
}

/// `writeln!` into a `String`, which cannot fail.
macro_rules! say {
    ($o:expr, $($t:tt)*) => {{
        let _ = writeln!($o, $($t)*);
    }};
}

/// The text `twintrace info` prints.
pub fn scene_summary(name: &str, scene: &Scene) -> String {
    let mut o = String::new();
    say!(o, "scene: {name}");
    geometry_summary(&mut o, scene);
    material_summary(&mut o, scene);
    light_summary(&mut o, scene);
    view_summary(&mut o, scene);
    o
}

/// `n`, and how many of each kind in `names` (`of(i)` names the `i`-th's
/// kind) where any.
fn count_kinds(names: &[&'static str], of: &dyn Fn(usize) -> &'static str, n: usize) -> String {
    let kinds: Vec<String> = names
        .iter()
        .filter_map(|&k| {
            let c = (0..n).filter(|&i| of(i) == k).count();
            (c > 0).then(|| format!("{c} {k}"))
        })
        .collect();
    if kinds.is_empty() {
        n.to_string()
    } else {
        format!("{n} ({})", kinds.join(", "))
    }
}

/// The primitives, the instances and the bounds.
fn geometry_summary(o: &mut String, scene: &Scene) {
    say!(o,
        "primitives: {} ({} spheres, {} quads, {} triangles, {} quadrics, {} grid cells; {} mesh vertices)",
        scene.primitives().len(),
        scene.spheres().len(),
        scene.quads().len(),
        scene.triangles().len(),
        scene.quadrics().len(),
        scene.sdf_voxels().len(),
        scene.mesh().positions.len()
    );
    // A group's triangles are counted once above, however many instances
    // draw them.
    if !scene.instances().is_empty() {
        let grouped: u32 = scene
            .groups()
            .iter()
            .map(|g| g.triangles().len() as u32)
            .sum();
        say!(
            o,
            "instances: {} of {} groups ({grouped} of the triangles, kept once)",
            scene.instances().len(),
            scene.groups().len()
        );
    }
    // The box in the file's coordinates (the scene is traced in render
    // space, about the camera).
    let b = scene.bounds();
    let (lo, hi) = (scene.to_world(b.min), scene.to_world(b.max));
    say!(o, "bounds: {} .. {}", lo.as_vec3(), hi.as_vec3());
}

/// The materials, their wrappers, the textures and the images.
fn material_summary(o: &mut String, scene: &Scene) {
    use reference::material::Material;
    use reference::texture::Texture;
    let material_kind = |i: usize| match scene.materials()[i] {
        Material::Lambertian { .. } => "lambertian",
        Material::Metal { .. } => "metal",
        Material::Dielectric { .. } => "dielectric",
        Material::DiffuseLight { .. } => "diffuse light",
        Material::Conductor { .. } => "conductor",
        Material::RoughConductor { .. } => "rough conductor",
        Material::SmoothDielectric { .. } => "smooth dielectric",
        Material::ThinDielectric { .. } => "thin dielectric",
        Material::RoughDielectric { .. } => "rough dielectric",
        Material::Plastic { .. } => "plastic",
        Material::RoughPlastic { .. } => "rough plastic",
        Material::Ggx { .. } => "ggx",
        Material::Principled { thin: false, .. } => "principled",
        Material::Principled { thin: true, .. } => "thin principled",
    };
    say!(
        o,
        "materials: {}",
        count_kinds(
            &[
                "lambertian",
                "metal",
                "dielectric",
                "diffuse light",
                "conductor",
                "rough conductor",
                "smooth dielectric",
                "thin dielectric",
                "rough dielectric",
                "plastic",
                "rough plastic",
                "ggx",
                "principled",
                "thin principled"
            ],
            &material_kind,
            scene.materials().len()
        )
    );
    // Mitsuba's wrappers, where some material has one.
    let n = scene.materials().len() as u32;
    let masked = (0..n)
        .filter(|&m| scene.wrappers(m).opacity.is_some())
        .count();
    let one_sided = (0..n).filter(|&m| scene.wrappers(m).one_sided).count();
    let blends = (0..n)
        .filter(|&m| scene.wrappers(m).blend.is_some())
        .count();
    if masked + one_sided + blends > 0 {
        say!(o, "  of which {one_sided} one-sided, {masked} masked, {blends} blends (each blend's second BSDF is one of the materials)");
    }
    let texture_kind = |i: usize| match scene.textures()[i] {
        Texture::Constant(_) => "constant",
        Texture::Checker { .. } => "checker",
        Texture::UvChecker { .. } => "uv checker",
        Texture::Image { .. } => "image",
        Texture::VertexColor { .. } => "vertex colour",
    };
    say!(
        o,
        "textures: {}",
        count_kinds(
            &[
                "constant",
                "checker",
                "uv checker",
                "image",
                "vertex colour"
            ],
            &texture_kind,
            scene.textures().len()
        )
    );
    let sizes: Vec<String> = scene
        .images()
        .iter()
        .map(|im| format!("{}x{}", im.width, im.height))
        .collect();
    if sizes.is_empty() {
        say!(o, "images: 0");
    } else {
        say!(o, "images: {} ({})", sizes.len(), sizes.join(", "));
    }
}

/// The punctual lights and the background.
fn light_summary(o: &mut String, scene: &Scene) {
    use reference::background::Background;
    let light_kind = |i: usize| match scene.punctual_lights()[i].tag {
        reference::light::punctual_tag::POINT => "point",
        reference::light::punctual_tag::SPOT => "spot",
        reference::light::punctual_tag::SPOT_LINEAR => "Mitsuba spot",
        reference::light::punctual_tag::PROJECTOR => "projector",
        _ => "directional",
    };
    say!(
        o,
        "punctual lights: {}",
        count_kinds(
            &["point", "spot", "Mitsuba spot", "projector", "directional"],
            &light_kind,
            scene.punctual_lights().len()
        )
    );
    match scene.background() {
        Background::Solid(c) => say!(o, "background: solid {c}"),
        Background::Sky { horizon, zenith } => {
            say!(
                o,
                "background: sky gradient, horizon {horizon}, zenith {zenith}"
            )
        }
        Background::Envmap {
            image,
            intensity,
            to_map,
            rows,
        } => {
            let size = scene
                .images()
                .get(image as usize)
                .map(|im| format!("{}x{}", im.width, im.height))
                .unwrap_or_default();
            let turn = match reference::background::angle_about_y(to_map) {
                Some(a) => format!("rotated {a}° about +y"),
                None => format!("rotated into its frame by {to_map}"),
            };
            let rows = match rows {
                reference::background::EnvRows::Bands => "",
                reference::background::EnvRows::Poles => ", rows at the poles (Mitsuba's envmap)",
            };
            say!(o, "background: environment map, image {image} ({size}), intensity {intensity}, {turn}{rows}");
        }
    }
}

/// The camera, the render defaults and the BVH.
fn view_summary(o: &mut String, scene: &Scene) {
    let c = &scene.camera_settings();
    match c.projection {
        reference::camera::Projection::Perspective => say!(
            o,
            "camera: from {} looking at {}, up {}, vfov {}°, aperture {}, focus distance {}",
            c.look_from,
            c.look_at,
            c.up,
            c.vfov,
            c.aperture,
            c.focus_distance
        ),
        reference::camera::Projection::Orthographic { height } => say!(
            o,
            "camera: orthographic, from {} looking at {}, up {}, window {height} high",
            c.look_from,
            c.look_at,
            c.up
        ),
    }
    let r = &scene.render_settings();
    say!(o,
        "render defaults: {}x{}, {} spp, max depth {}, seed {}, Russian roulette from depth {}, {} sampler",
        r.width,
        r.height,
        r.spp,
        r.max_depth,
        r.seed,
        r.roulette_depth,
        r.sampler.name()
    );
    let s = &scene.bvh_stats();
    say!(o,
        "bvh: built in {:.3} ms, {} primitives, {} nodes, {} leaves, max depth {}, max leaf size {}, SAH cost {:.3}",
        s.build_time.as_secs_f64() * 1e3,
        s.primitives,
        s.nodes,
        s.leaves,
        s.max_depth,
        s.max_leaf_size,
        s.sah_cost
    );
}
