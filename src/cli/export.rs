//! `twintrace export-mitsuba SCENE -o DIR`: the scene as a Mitsuba 3 scene
//! (`DIR/scene.xml`, with its meshes as binary PLY files and the sky as a
//! latitude-longitude EXR), for rendering the same image with an
//! independent renderer and judging the two with `twintrace diff`.
//!
//! Only what Mitsuba 3 renders *identically* in expectation is exported;
//! anything else is an error naming the feature, never an approximation:
//!
//! | twintrace | Mitsuba 3 |
//! |---|---|
//! | `lambertian`, constant albedo | `twosided` `diffuse` |
//! | `metal`, `fuzz` 0, constant albedo | `twosided` `conductor`, `material="none"` (a perfect mirror) × albedo |
//! | `diffuse_light` | `area` emitter (one-sided, along the geometric normal) on a black `diffuse` |
//! | `sphere` (negative radius: inward normal) | `sphere` (`flip_normals`) |
//! | `quad`, `box`, mesh triangles without normals | `ply` with face normals, vertex order kept (so the geometric normal is the same) |
//! | `solid` background | `constant` emitter (nothing when black) |
//! | `sky` background | `envmap` of a 4096-row lat-long map; the gradient is linear in `cos θ`, so bilinear lookup errs by about 10^-7 |
//! | thin-lens camera | `perspective` (`aperture` 0) or `thinlens` (radius = aperture / 2), `fov_axis="y"` |
//! | box pixel filter, `max_depth` ray segments | `box` rfilter, `path` integrator's `max_depth` (1 = emitters seen directly in both) |
//! | Russian roulette from hit `roulette_depth` on | `rr_depth` = `roulette_depth − 1` (Mitsuba rolls after hit `rr_depth`) |
//! | point light (radiant intensity) | `point` emitter, `intensity` |
//! | directional light (irradiance) | `directional` emitter, `irradiance` |
//! | spot light whose inner cone holds the scene's bounds | `spot` emitter, `cutoff_angle` = outer, `beam_width` = inner (degrees), pointed by `lookat` |
//!
//! A spot's falloff between its cones differs: glTF's `t²` of a ramp in
//! the cosine (`reference::light::PunctualLight::falloff`), Mitsuba's
//! linear in the angle. The two agree only where both are 1 (inside the
//! inner cone) or 0 (outside the outer), so a spot is exported only when
//! its inner cone holds every corner of the scene's bounding box (then,
//! the cone being convex, all the geometry it lights): else it is refused.
//!
//! Not exported: fuzzy metal (Ray Tracing in One Weekend's ball
//! perturbation has no Mitsuba counterpart), dielectrics (Schlick's
//! Fresnel, where Mitsuba uses the exact one), the `ggx` material (its
//! Schlick-weighted Lambertian base), textures, environment maps (their
//! orientation and filtering conventions differ) and shading normals.
//!
//! Mitsuba's `path` integrator samples emitters with MIS, where twintrace
//! samples the BSDF only: a different estimator of the same integral, so
//! the two images agree in expectation and differ in noise.
//!
//! Coordinates are the scene's render space (the world minus
//! `Scene::render_origin`, camera and shapes alike, as twintrace traces
//! them; the XML says the origin in a comment): Mitsuba then traces the
//! f32 numbers twintrace traces, not their world rounding.

use super::outputs;
use anyhow::{bail, Context, Result};
use clap::Args;
use glam::Vec3;
use reference::background::Background;
use reference::material::Material;
use reference::texture::Texture;
use reference::Scene;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twintrace::image_io::{self, RenderImage, RenderMetadata};

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// A scene file (.json, .gltf, .glb) or a built-in scene name.
    pub scene: String,
    /// The folder to write `scene.xml` and its files into (created if missing; its parent must exist).
    #[arg(short = 'o', long = "output", value_name = "DIR")]
    pub output: PathBuf,
    /// Image size as WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Path depth in ray segments (default: the scene's).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Samples per pixel written into the sampler (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
}

/// The scene file in the output folder.
const XML_FILE: &str = "scene.xml";
/// The sky's lat-long map in the output folder.
const SKY_FILE: &str = "sky.exr";

/// The PLY file of mesh `i` in the output folder.
fn mesh_file(i: usize) -> String {
    format!("mesh_{i}.ply")
}

/// Rows of the sky's lat-long map (columns: 8; the sky does not vary
/// with azimuth).
const SKY_ROWS: usize = 4096;

pub fn run(args: &ExportArgs) -> Result<()> {
    let scene = super::load_scene(&args.scene)?;
    let (mut width, mut height) = (
        scene.render_settings().width,
        scene.render_settings().height,
    );
    if let Some(size) = &args.size {
        (width, height) = image_io::parse_size(size)?;
    }
    let max_depth = args.max_depth.unwrap_or(scene.render_settings().max_depth);
    let spp = args.spp.unwrap_or(scene.render_settings().spp);
    let export = MitsubaScene::new(&scene).with_context(|| {
        format!(
            "`{}` cannot be exported to Mitsuba 3 without changing the image",
            args.scene
        )
    })?;
    // Nothing written may be the scene or a file it reads (nor the
    // folder itself one of them).
    let mut inputs = Vec::new();
    let scene_file = Path::new(&args.scene);
    if scene_file.exists() {
        inputs.push(outputs::input_file("scene", scene_file));
    }
    inputs.extend(scene.sources().iter().map(|f| {
        outputs::input(
            format!("`{}`, which the scene reads", f.display()),
            f.clone(),
        )
    }));
    let arg = format!("-o {}", args.output.display());
    let mut written = vec![outputs::output(arg.clone(), &args.output)];
    written.extend(
        export
            .files()
            .into_iter()
            .map(|f| outputs::output(arg.clone(), args.output.join(f))),
    );
    outputs::check(&inputs, &written)?;
    image_io::existing_parent_dir(&args.output)?;
    let dir = args.output.clone();
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create `{}`", dir.display()))?;
    let xml = export.write(&dir, width, height, max_depth, spp)?;
    image_io::write_atomic(&dir.join(XML_FILE), |f| {
        use std::io::Write as _;
        f.write_all(xml.as_bytes())?;
        Ok(())
    })?;
    println!(
        "exported {} to {} ({width}x{height}, {spp} spp, depth {max_depth}): {} shapes, {} spheres",
        args.scene,
        dir.join(XML_FILE).display(),
        export.meshes.len(),
        export.spheres.len()
    );
    Ok(())
}

/// A BSDF (and emitter) Mitsuba renders as twintrace does.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Surface {
    Diffuse(Vec3),
    Mirror(Vec3),
    Light(Vec3),
}

impl Surface {
    fn xml(self) -> String {
        let rgb = |name: &str, c: Vec3| format!(r#"<rgb name="{name}" value="{}"/>"#, triple(c));
        match self {
            Surface::Diffuse(c) => format!(
                r#"<bsdf type="twosided"><bsdf type="diffuse">{}</bsdf></bsdf>"#,
                rgb("reflectance", c)
            ),
            Surface::Mirror(c) => format!(
                r#"<bsdf type="twosided"><bsdf type="conductor"><string name="material" value="none"/>{}</bsdf></bsdf>"#,
                rgb("specular_reflectance", c)
            ),
            Surface::Light(e) => format!(
                r#"<bsdf type="diffuse">{}</bsdf><emitter type="area">{}</emitter>"#,
                rgb("reflectance", Vec3::ZERO),
                rgb("radiance", e)
            ),
        }
    }
}

struct MitsubaScene<'s> {
    scene: &'s Scene,
    surfaces: Vec<Surface>,
    /// Triangles per material: positions, three per triangle.
    meshes: Vec<(u32, Vec<Vec3>)>,
    spheres: Vec<(Vec3, f32, u32)>,
}

fn triple(v: Vec3) -> String {
    format!("{:?}, {:?}, {:?}", v.x, v.y, v.z)
}

fn constant(scene: &Scene, texture: u32, what: &str) -> Result<Vec3> {
    match scene.textures().get(texture as usize) {
        Some(Texture::Constant(c)) => Ok(*c),
        _ => bail!("{what} is textured (textures are not exported)"),
    }
}

impl<'s> MitsubaScene<'s> {
    fn new(scene: &'s Scene) -> Result<Self> {
        let surfaces = scene
            .materials()
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let what = format!("material {i}");
                if scene.added_emission(i as u32).is_some() {
                    bail!("{what} emits as well as reflects (emission added to its BSDF is not exported)");
                }
                Ok(match *m {
                    Material::Lambertian { albedo } => {
                        Surface::Diffuse(constant(scene, albedo, &what)?)
                    }
                    Material::Metal { albedo, fuzz: 0.0 } => {
                        Surface::Mirror(constant(scene, albedo, &what)?)
                    }
                    Material::Metal { .. } => {
                        bail!("{what} is a fuzzy metal (no Mitsuba counterpart)")
                    }
                    Material::DiffuseLight { emission } => {
                        Surface::Light(constant(scene, emission, &what)?)
                    }
                    Material::Dielectric { .. } => bail!(
                        "{what} is a dielectric (Schlick's Fresnel; Mitsuba's is exact)"
                    ),
                    Material::Ggx { .. } => {
                        bail!("{what} is `ggx` (its Schlick-weighted base has no Mitsuba counterpart)")
                    }
                })
            })
            .collect::<Result<Vec<_>>>()?;
        // Refused here, before `write` creates any file.
        if let Background::Envmap { .. } = scene.background() {
            bail!("the background is an environment map (not exported)");
        }
        let b = scene.bounds();
        for (i, l) in scene.punctual_lights().iter().enumerate() {
            if l.tag != reference::light::punctual_tag::SPOT {
                continue;
            }
            let corners = (0..8).map(|k| {
                Vec3::new(
                    if k & 1 == 0 { b.min.x } else { b.max.x },
                    if k & 2 == 0 { b.min.y } else { b.max.y },
                    if k & 4 == 0 { b.min.z } else { b.max.z },
                )
            });
            let outside = corners
                .filter(|&c| {
                    let to = (c - l.position).as_dvec3();
                    let cos = to.dot(l.direction.as_dvec3()) / to.length();
                    cos.is_nan() || cos <= l.cos_inner as f64
                })
                .count();
            if outside > 0 {
                bail!(
                    "spot light {i}: {outside} of the 8 corners of the scene's bounds lie outside its inner cone, where glTF's falloff (t² of a ramp in the cosine) and Mitsuba's spot (linear in the angle) differ"
                );
            }
        }
        let mut meshes: Vec<(u32, Vec<Vec3>)> = Vec::new();
        let mut add =
            |material: u32, tri: [Vec3; 3]| match meshes.iter_mut().find(|(m, _)| *m == material) {
                Some((_, p)) => p.extend(tri),
                None => meshes.push((material, tri.to_vec())),
            };
        for q in scene.quads() {
            let (c, u, v) = (q.corner, q.u, q.v);
            // Both triangles wind as (u, v), so their normal is u × v.
            add(q.material, [c, c + u, c + u + v]);
            add(q.material, [c, c + u + v, c + v]);
        }
        for (i, t) in scene.triangles().iter().enumerate() {
            if t.flags & reference::shapes::TRIANGLE_HAS_NORMALS != 0 {
                bail!("triangle {i} has shading normals (not exported)");
            }
            add(
                t.material,
                t.vertices.map(|v| scene.mesh().positions[v as usize]),
            );
        }
        let spheres = scene
            .spheres()
            .iter()
            .map(|s| (s.center, s.radius, s.material))
            .collect();
        Ok(Self {
            scene,
            surfaces,
            meshes,
            spheres,
        })
    }

    /// The names of the files [`MitsubaScene::write`] and the XML take in
    /// the output folder.
    fn files(&self) -> Vec<String> {
        let mut files = vec![XML_FILE.to_string()];
        files.extend((0..self.meshes.len()).map(mesh_file));
        if matches!(self.scene.background(), Background::Sky { .. }) {
            files.push(SKY_FILE.to_string());
        }
        files
    }

    /// Writes the PLY files and the sky map into `dir`; returns the XML.
    fn write(
        &self,
        dir: &Path,
        width: u32,
        height: u32,
        max_depth: u32,
        spp: u32,
    ) -> Result<String> {
        let cam = &self.scene.render_camera_settings();
        let mut x = String::from("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n");
        writeln!(
            x,
            "<!-- Exported by twintrace {} (export-mitsuba). -->",
            env!("CARGO_PKG_VERSION")
        )?;
        let o = self.scene.render_origin();
        writeln!(
            x,
            "<!-- Render space: world coordinates minus ({:?}, {:?}, {:?}). -->",
            o.x, o.y, o.z
        )?;
        x += "<scene version=\"3.0.0\">\n";
        // Russian roulette from the same vertex: twintrace rolls at the
        // k-th surface hit when k ≥ roulette_depth, Mitsuba's `path` when
        // k > rr_depth (its depth counts hits); both survive with the
        // throughput's largest component capped at 0.95.
        let rr_depth = self.scene.render_settings().roulette_depth.max(1) - 1;
        writeln!(
            x,
            r#"  <integrator type="path"><integer name="max_depth" value="{max_depth}"/><integer name="rr_depth" value="{rr_depth}"/></integrator>"#
        )?;
        let lens = if cam.aperture > 0.0 {
            format!(
                r#"<float name="aperture_radius" value="{:?}"/><float name="focus_distance" value="{:?}"/>"#,
                0.5 * cam.aperture,
                cam.focus_distance
            )
        } else {
            String::new()
        };
        writeln!(
            x,
            r#"  <sensor type="{}">{lens}<float name="fov" value="{:?}"/><string name="fov_axis" value="y"/><float name="near_clip" value="1e-4"/>"#,
            if cam.aperture > 0.0 {
                "thinlens"
            } else {
                "perspective"
            },
            cam.vfov
        )?;
        writeln!(
            x,
            r#"    <transform name="to_world"><lookat origin="{}" target="{}" up="{}"/></transform>"#,
            triple(cam.look_from),
            triple(cam.look_at),
            triple(cam.up)
        )?;
        writeln!(
            x,
            r#"    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>"#
        )?;
        writeln!(
            x,
            r#"    <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/><string name="pixel_format" value="rgb"/><rfilter type="box"/></film>"#
        )?;
        x += "  </sensor>\n";
        for (i, (material, positions)) in self.meshes.iter().enumerate() {
            let file = mesh_file(i);
            write_ply(&dir.join(&file), positions)?;
            writeln!(
                x,
                r#"  <shape type="ply"><string name="filename" value="{file}"/><boolean name="face_normals" value="true"/>{}</shape>"#,
                self.surfaces[*material as usize].xml()
            )?;
        }
        for (center, radius, material) in &self.spheres {
            writeln!(
                x,
                r#"  <shape type="sphere"><point name="center" value="{}"/><float name="radius" value="{:?}"/><boolean name="flip_normals" value="{}"/>{}</shape>"#,
                triple(*center),
                radius.abs(),
                *radius < 0.0,
                self.surfaces[*material as usize].xml()
            )?;
        }
        for l in self.scene.punctual_lights() {
            use reference::light::punctual_tag;
            let rgb =
                |name: &str, c: Vec3| format!(r#"<rgb name="{name}" value="{}"/>"#, triple(c));
            match l.tag {
                punctual_tag::POINT => writeln!(
                    x,
                    r#"  <emitter type="point"><point name="position" value="{}"/>{}</emitter>"#,
                    triple(l.position),
                    rgb("intensity", l.intensity)
                )?,
                punctual_tag::SPOT => {
                    let up = if l.direction.y.abs() < 0.9 {
                        Vec3::Y
                    } else {
                        Vec3::Z
                    };
                    writeln!(
                        x,
                        r#"  <emitter type="spot"><transform name="to_world"><lookat origin="{}" target="{}" up="{}"/></transform>{}<float name="cutoff_angle" value="{:?}"/><float name="beam_width" value="{:?}"/></emitter>"#,
                        triple(l.position),
                        triple(l.position + l.direction),
                        triple(up),
                        rgb("intensity", l.intensity),
                        (l.cos_outer as f64).acos().to_degrees(),
                        (l.cos_inner as f64).acos().to_degrees()
                    )?
                }
                _ => writeln!(
                    x,
                    r#"  <emitter type="directional"><vector name="direction" value="{}"/>{}</emitter>"#,
                    triple(l.direction),
                    rgb("irradiance", l.intensity)
                )?,
            }
        }
        match self.scene.background() {
            Background::Solid(c) if c == Vec3::ZERO => {}
            Background::Solid(c) => writeln!(
                x,
                r#"  <emitter type="constant"><rgb name="radiance" value="{}"/></emitter>"#,
                triple(c)
            )?,
            Background::Sky { horizon, zenith } => {
                write_sky(&dir.join(SKY_FILE), horizon, zenith)?;
                writeln!(
                    x,
                    r#"  <emitter type="envmap"><string name="filename" value="{SKY_FILE}"/></emitter>"#
                )?;
            }
            Background::Envmap { .. } => {
                bail!("the background is an environment map (not exported)")
            }
        }
        x += "</scene>\n";
        Ok(x)
    }
}

/// Binary little-endian PLY: float vertices, three per face, in order.
fn write_ply(path: &Path, positions: &[Vec3]) -> Result<()> {
    let faces = positions.len() / 3;
    image_io::write_atomic(path, |f| {
        use std::io::Write as _;
        let mut w = std::io::BufWriter::new(f);
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n",
            positions.len()
        )?;
        for p in positions {
            for c in p.to_array() {
                w.write_all(&c.to_le_bytes())?;
            }
        }
        for i in 0..faces as i32 {
            w.write_all(&[3u8])?;
            for k in 0..3 {
                w.write_all(&(3 * i + k).to_le_bytes())?;
            }
        }
        w.flush()?;
        Ok(())
    })
}

/// The sky as a lat-long map in Mitsuba's convention: row `j` holds the
/// direction at polar angle `θ = π (j + ½) / rows` from +y.
fn write_sky(path: &Path, horizon: Vec3, zenith: Vec3) -> Result<()> {
    const COLUMNS: usize = 8;
    let mut mean = Vec::with_capacity(SKY_ROWS * COLUMNS);
    for j in 0..SKY_ROWS {
        let theta = std::f64::consts::PI * (j as f64 + 0.5) / SKY_ROWS as f64;
        let t = (0.5 * (theta.cos() + 1.0)) as f32;
        mean.extend(std::iter::repeat_n(horizon.lerp(zenith, t), COLUMNS));
    }
    let image = RenderImage {
        width: COLUMNS as u32,
        height: SKY_ROWS as u32,
        mean,
        variance: None,
        skewness: None,
        metadata: RenderMetadata {
            software: Some(format!(
                "twintrace {} export-mitsuba",
                env!("CARGO_PKG_VERSION")
            )),
            ..RenderMetadata::default()
        },
    };
    image_io::write_exr(path, &image)
}
