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
//! | `lambertian` | `twosided` `diffuse` |
//! | `metal`, `fuzz` 0 | `twosided` `conductor`, `material="none"` (a perfect mirror) × albedo |
//! | `metal`, `fuzz` > 0 | `twosided` `tt_fuzzy_metal` (plugin: the ball perturbation, its closed-form density) |
//! | `dielectric` | `tt_dielectric` (plugin: Schlick's Fresnel); absorption as an interior `homogeneous` medium of albedo 0, traced by `volpath` |
//! | `ggx` (factors, textures, clear coat, vertex colours) | `twosided` `tt_ggx` (plugin: `GgxLobes`) |
//! | `ggx` normal map on triangles with tangents | `tt_normalmap` around `tt_ggx` (plugin: `normal_mapped` and the facing flip) |
//! | constant colour, 3-D `checker` | `rgb`, `tt_checker` (plugin) |
//! | image texture, one wrap mode | `bitmap` of the reference's texels (an EXR, read raw), its filter and wrap, `to_uv` = v flip ∘ KHR_texture_transform ∘ the shape's uv map |
//! | image texture, two wrap modes or the second uv set | `tt_image` (plugin: `sample_image`) |
//! | glTF alpha (MASK, BLEND) on triangles carrying it | `mask` of `tt_alpha` (plugin), traced by `volpath` (shadow rays pass the uncovered share) |
//! | triangles with shading normals | `ply` vertex normals; `tt_facing` (plugin) for the reference's facing instead of `twosided`, `tt_diffuse` for its Lambertian |
//! | `one_sided` around `lambertian`, `metal` (fuzz 0), the conductors, the plastics | the model without `twosided` (not on triangles with shading normals, where Mitsuba picks the side by the shading normal) |
//! | `mask` | `mask` of the opacity (a `float`, a `bitmap`, a `checkerboard` of numbers with its colours swapped as Mitsuba's `eval_1` reads them); not in a scene `volpath` traces (media, glTF alpha), which lets shadow rays through masks |
//! | `diffuse_light` | `area` emitter (one-sided, along the geometric normal) on a black `diffuse` |
//! | `sphere` (negative radius: inward normal) | `sphere` (`flip_normals`); a textured one placed by a matrix that turns Mitsuba's uv into the reference's |
//! | `quad`, `box`, mesh triangles | `ply`, vertex order kept (so the geometric normal is the same), the reference's uv per vertex (a quad's (α, β), a triangle's own or its barycentrics) |
//! | `solid` background | `constant` emitter (nothing when black) |
//! | `sky` background | `envmap` of a 4096-row lat-long map; the gradient is linear in `cos θ`, so bilinear lookup errs by about 10^-7 |
//! | `envmap` background | `envmap` of the map (a map of bands resampled to 2h + 1 rows at the poles, [`write_envmap`]; a map of rows at the poles as it is), `to_world` half a turn about +y then the map's own rotation, `scale` = intensity |
//! | thin-lens camera | `perspective` (`aperture` 0) or `thinlens` (radius = aperture / 2), `fov_axis="y"` |
//! | box pixel filter, `max_depth` ray segments | `box` rfilter, `path` (or `volpath`) integrator's `max_depth` (1 = emitters seen directly in both) |
//! | Russian roulette from hit `roulette_depth` on | `rr_depth` = `roulette_depth − 1` (Mitsuba rolls after hit `rr_depth`) |
//! | `render.sampler` (independent or Sobol') | the `independent` sampler: a converged image does not depend on the sequence |
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
//! The plugins (`tt_*`, xtask/mitsuba/plugins/twintrace_plugins.py) are
//! the reference's formulas in Dr.Jit; src/cli/export/materials.rs maps
//! materials and textures onto them and Mitsuba's own plugins.
//!
//! Not exported: emission added to a BSDF and textured lights, metals and
//! lights under shading normals (the metals test their reflection against
//! the geometric normal, the reference's light faces its geometric front,
//! Mitsuba's its shading normal), alpha on a dielectric or a light, a
//! texture of the second uv set on a sphere, and the shapes read from
//! Mitsuba files alone: disks, cylinders, textured Mitsuba spheres
//! (quadrics), signed distance grids and instances of shape groups
//! (refused: the scene is not written).
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
use glam::{Mat3, Vec3};
use materials::{triple, write_map, Surface};
use reference::background::{Background, EnvRows};
use reference::camera::Projection;
use reference::filter::PixelFilter;
use reference::Scene;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twintrace::image_io;

mod materials;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// A scene file (.json, .gltf, .glb, Mitsuba .xml) or a built-in scene name.
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
    // The scene file against the folder and its scene.xml first, before
    // the scene is read: an export over its own scene is refused as that,
    // whatever the file holds (all it reads is checked below).
    let scene_file = Path::new(&args.scene);
    if scene_file.exists() {
        let arg = format!("-o {}", args.output.display());
        outputs::check(
            &[outputs::input_file("scene", scene_file)],
            &[
                outputs::output(arg.clone(), &args.output),
                outputs::output(arg, args.output.join(XML_FILE)),
            ],
        )?;
    }
    let scene = super::common::load_scene(&args.scene)?;
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

struct MitsubaScene<'s> {
    scene: &'s Scene,
    /// By punctual light: the texture of a Mitsuba spot or projector.
    light_textures: Vec<Option<materials::Tex>>,
    surfaces: Vec<Surface>,
    /// Each material's coverage (glTF's alpha), if it has one.
    coverages: Vec<Option<materials::Coverage>>,
    /// Each material's wrappers (one side, a mask).
    wrappings: Vec<materials::Wrapping>,
    /// Triangles per material and vertex attributes.
    meshes: Vec<Mesh>,
    spheres: Vec<(Vec3, f32, u32)>,
    /// The image textures the surfaces read.
    images: Vec<u32>,
}

/// A PLY vertex: position, the reference's uv, and where the mesh has
/// them, the shading normal and the vertex colour.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    p: Vec3,
    uv: glam::Vec2,
    n: Vec3,
    color: Vec3,
    tangent: glam::Vec4,
    /// The second texture coordinates (0 where the mesh has none).
    uv1: glam::Vec2,
    /// The vertex colour's alpha (1 where the mesh has none).
    alpha: f32,
}

/// The triangles of one material with the same vertex attributes.
struct Mesh {
    material: u32,
    normals: bool,
    colors: bool,
    tangents: bool,
    /// Whether the PLY carries `uv1` (its material reads the second set).
    uv1: bool,
    /// Whether the triangles carry alpha under a material with a
    /// coverage: a `mask`, and the PLY carries `vertex_alpha`.
    alpha: bool,
    /// Three per triangle, in the reference's order.
    vertices: Vec<Vertex>,
}

/// Refuses a spot light whose inner cone does not hold the whole scene:
/// outside it glTF's falloff (t² of a ramp in the cosine) and Mitsuba's
/// spot (linear in the angle) differ.
fn check_spots(scene: &Scene) -> Result<()> {
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
    Ok(())
}

/// The scene's quads and triangles as Mitsuba meshes, one for each
/// material and set of vertex attributes; refuses shading normals under a
/// material that cannot take them.
fn meshes(
    scene: &Scene,
    surfaces: &[Surface],
    coverages: &[Option<materials::Coverage>],
) -> Result<Vec<Mesh>> {
    let mut meshes: Vec<Mesh> = Vec::new();
    let mut add = |material: u32, attributes: (bool, bool, bool, bool), tri: [Vertex; 3]| {
        let (normals, colors, tangents, alpha) = attributes;
        let uv1 = surfaces[material as usize].uses_uv1()
            || (alpha
                && coverages[material as usize]
                    .as_ref()
                    .is_some_and(|c| c.uses_uv1()));
        match meshes.iter_mut().find(|m| {
            (m.material, m.normals, m.colors, m.tangents, m.alpha)
                == (material, normals, colors, tangents, alpha)
        }) {
            Some(m) => m.vertices.extend(tri),
            None => meshes.push(Mesh {
                material,
                normals,
                colors,
                tangents,
                uv1,
                alpha,
                vertices: tri.to_vec(),
            }),
        }
    };
    let vertex = |p: Vec3, uv: glam::Vec2| Vertex {
        p,
        uv,
        n: Vec3::ZERO,
        color: Vec3::ONE,
        tangent: glam::Vec4::ZERO,
        uv1: glam::Vec2::ZERO,
        alpha: 1.0,
    };
    use glam::Vec2;
    for q in scene.quads() {
        let (c, u, v) = (q.corner, q.u, q.v);
        // Both triangles wind as (u, v), so their normal is u × v; the
        // uv is the quad's (α, β), linear over each triangle.
        let (c0, c1, c2, c3) = (
            vertex(c, Vec2::ZERO),
            vertex(c + u, Vec2::X),
            vertex(c + u + v, Vec2::ONE),
            vertex(c + v, Vec2::Y),
        );
        add(q.material, (false, false, false, false), [c0, c1, c2]);
        add(q.material, (false, false, false, false), [c0, c2, c3]);
    }
    use reference::shapes::{
        TRIANGLE_HAS_ALPHA, TRIANGLE_HAS_COLORS, TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS,
        TRIANGLE_HAS_UV1, TRIANGLE_HAS_UVS,
    };
    let m = scene.mesh();
    for (i, t) in scene.triangles().iter().enumerate() {
        let surface = &surfaces[t.material as usize];
        let normals = t.flags & TRIANGLE_HAS_NORMALS != 0;
        if let (true, Some(why)) = (normals, surface.shading_normals_refused()) {
            bail!("triangle {i} has shading normals under {why} (not exported)");
        }
        // The vertex colour scales only `ggx`'s base colour.
        let colors = t.flags & TRIANGLE_HAS_COLORS != 0 && matches!(surface, Surface::Ggx { .. });
        // Coverage applies to the triangles that carry alpha.
        let alpha = t.flags & TRIANGLE_HAS_ALPHA != 0 && coverages[t.material as usize].is_some();
        // Tangents matter only to a normal map.
        let tangents = t.flags & TRIANGLE_HAS_TANGENTS != 0
            && matches!(
                surface,
                Surface::Ggx {
                    normal_map: Some(_),
                    ..
                }
            );
        // Without uvs the reference's uv is the barycentrics (b1, b2).
        let corners = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let tri = std::array::from_fn(|k| {
            let v = t.vertices[k] as usize;
            Vertex {
                p: m.positions[v],
                uv: if t.flags & TRIANGLE_HAS_UVS != 0 {
                    m.uvs[v]
                } else {
                    corners[k]
                },
                n: if normals { m.normals[v] } else { Vec3::ZERO },
                color: if colors {
                    m.colors[v].truncate()
                } else {
                    Vec3::ONE
                },
                tangent: if tangents {
                    m.tangents[v]
                } else {
                    glam::Vec4::ZERO
                },
                uv1: if t.flags & TRIANGLE_HAS_UV1 != 0 {
                    m.uvs1[v]
                } else {
                    Vec2::ZERO
                },
                alpha: if t.flags & TRIANGLE_HAS_COLORS != 0 {
                    m.colors[v].w
                } else {
                    1.0
                },
            }
        });
        add(t.material, (normals, colors, tangents, alpha), tri);
    }
    Ok(meshes)
}

impl<'s> MitsubaScene<'s> {
    fn new(scene: &'s Scene) -> Result<Self> {
        // Mitsuba's disks, cylinders, textured spheres and grids: the
        // export's materials are placed for the reference's own shapes'
        // texture coordinates, not these (refused, not dropped).
        let (quadrics, grids) = (scene.quadrics().len(), scene.sdf_grids().len());
        if quadrics + grids > 0 {
            bail!(
                "the scene has {quadrics} disk, cylinder or Mitsuba-textured sphere shapes and {grids} signed distance grids, which export-mitsuba does not write (not exported)"
            );
        }
        // Instances: the export writes the scene's own triangles, which
        // a group's are not (refused, not dropped).
        if !scene.instances().is_empty() {
            bail!(
                "the scene has {} instances of shape groups, which export-mitsuba does not write (not exported)",
                scene.instances().len()
            );
        }
        let surfaces = (0..scene.materials().len())
            .map(|i| materials::surface(scene, i))
            .collect::<Result<Vec<_>>>()?;
        let wrappings = (0..scene.materials().len())
            .map(|i| materials::wrapping(scene, i, &surfaces[i]))
            .collect::<Result<Vec<_>>>()?;
        // Refused here, before `write` creates any file.
        check_spots(scene)?;
        let coverages = (0..scene.materials().len())
            .map(|i| materials::coverage(scene, i))
            .collect::<Result<Vec<_>>>()?;
        let meshes = meshes(scene, &surfaces, &coverages)?;
        if let Some(s) = scene
            .spheres()
            .iter()
            .find(|s| surfaces[s.material as usize].uses_uv1())
        {
            bail!(
                "material {} reads the second texture coordinates on a sphere (not exported)",
                s.material
            );
        }
        let spheres = scene
            .spheres()
            .iter()
            .map(|s| (s.center, s.radius, s.material))
            .collect();
        // Mitsuba's `mask` stops shadow rays in `path`, as twintrace's, but
        // `volpath` (which media and coverage need) lets them through.
        let volpath = surfaces.iter().any(Surface::has_medium) || meshes.iter().any(|m| m.alpha);
        if let Some(i) = wrappings
            .iter()
            .position(|w| w.opacity.is_some())
            .filter(|_| volpath)
        {
            bail!("material {i} has a mask, which the scene's medium or alpha coverage (traced by volpath, which lets shadow rays through masks) would render otherwise (not exported)");
        }
        if let Some(m) = meshes
            .iter()
            .find(|m| m.normals && wrappings[m.material as usize].one_sided)
        {
            bail!(
                "material {} is one-sided on triangles with shading normals, where twintrace shades it in the frame the geometric normal's side picks and Mitsuba in the shading frame: they differ at silhouettes (not exported)",
                m.material
            );
        }
        // Mitsuba's spot and projector: their textures, read at Mitsuba's
        // (u, v) as the reference reads them at (u, 1 − v).
        let light_textures = scene
            .punctual_lights()
            .iter()
            .enumerate()
            .map(|(i, l)| {
                (l.texture != reference::light::NO_TEXTURE)
                    .then(|| materials::texture(scene, l.texture, &format!("light {i}")))
                    .transpose()
            })
            .collect::<Result<Vec<_>>>()?;
        let mut images = Vec::new();
        for t in light_textures.iter().flatten() {
            t.images(&mut images);
        }
        for s in &surfaces {
            s.images(&mut images);
        }
        for w in &wrappings {
            w.images(&mut images);
        }
        for c in coverages.iter().flatten() {
            c.images(&mut images);
        }
        Ok(Self {
            scene,
            light_textures,
            surfaces,
            wrappings,
            coverages,
            meshes,
            spheres,
            images,
        })
    }

    /// The names of the files [`MitsubaScene::write`] and the XML take in
    /// the output folder.
    fn files(&self) -> Vec<String> {
        let mut files = vec![XML_FILE.to_string()];
        files.extend((0..self.meshes.len()).map(mesh_file));
        files.extend(self.images.iter().map(|&i| materials::texture_file(i)));
        if matches!(
            self.scene.background(),
            Background::Sky { .. } | Background::Envmap { .. }
        ) {
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
        if self.surfaces.iter().any(Surface::uses_plugins) {
            x += "<!-- Needs twintrace's Mitsuba plugins (xtask/mitsuba/plugins, registered by render.py). -->\n";
        }
        x += "<scene version=\"3.0.0\">\n";
        // Russian roulette from the same vertex: twintrace rolls at the
        // k-th surface hit when k ≥ roulette_depth, Mitsuba's `path` when
        // k > rr_depth (its depth counts hits); both survive with the
        // throughput's largest component capped at 0.95.
        let rr_depth = self.scene.render_settings().roulette_depth.max(1) - 1;
        // An absorbing dielectric's interior is a medium, which only
        // `volpath` traces (the same estimator as `path` elsewhere).
        // So does coverage: `volpath` passes shadow rays through a
        // `mask`'s uncovered share, as the reference's traversal does,
        // and does not count the pass as a bounce.
        let integrator = if self.surfaces.iter().any(Surface::has_medium)
            || self.meshes.iter().any(|m| m.alpha)
        {
            "volpath"
        } else {
            "path"
        };
        writeln!(
            x,
            r#"  <integrator type="{integrator}"><integer name="max_depth" value="{max_depth}"/><integer name="rr_depth" value="{rr_depth}"/></integrator>"#
        )?;
        self.sensor_xml(&mut x, (width, height), spp)?;
        self.shapes_xml(&mut x, dir)?;
        self.lights_xml(&mut x)?;
        self.background_xml(&mut x, dir)?;
        x += "</scene>\n";
        Ok(x)
    }

    /// The sensor: the camera, its sampler and its film.
    fn sensor_xml(&self, x: &mut String, (width, height): (u32, u32), spp: u32) -> Result<()> {
        let cam = &self.scene.render_camera_settings();
        let lens = if cam.aperture > 0.0 {
            format!(
                r#"<float name="aperture_radius" value="{:?}"/><float name="focus_distance" value="{:?}"/>"#,
                0.5 * cam.aperture,
                cam.focus_distance
            )
        } else {
            String::new()
        };
        // Mitsuba's orthographic window is 2 wide and 2 / aspect tall in
        // the sensor's space: a uniform scale of height · aspect / 2 makes
        // it `height` tall.
        let (sensor, scale) = match cam.projection {
            Projection::Orthographic { height: h } => (
                "<sensor type=\"orthographic\">".to_string(),
                format!(
                    r#"<scale x="{:?}" y="{:?}"/>"#,
                    h * width as f32 / height as f32 / 2.0,
                    h * width as f32 / height as f32 / 2.0
                ),
            ),
            Projection::Perspective => (
                format!(
                    r#"<sensor type="{}">{lens}<float name="fov" value="{:?}"/><string name="fov_axis" value="y"/>"#,
                    if cam.aperture > 0.0 {
                        "thinlens"
                    } else {
                        "perspective"
                    },
                    cam.vfov
                ),
                String::new(),
            ),
        };
        writeln!(x, r#"  {sensor}<float name="near_clip" value="1e-4"/>"#)?;
        writeln!(
            x,
            r#"    <transform name="to_world">{scale}<lookat origin="{}" target="{}" up="{}"/></transform>"#,
            triple(cam.look_from),
            triple(cam.look_at),
            triple(cam.up)
        )?;
        writeln!(
            x,
            r#"    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>"#
        )?;
        let rfilter = match self.scene.filter() {
            PixelFilter::Box => r#"<rfilter type="box"/>"#.to_string(),
            PixelFilter::Gaussian { stddev } => format!(
                r#"<rfilter type="gaussian"><float name="stddev" value="{stddev:?}"/></rfilter>"#
            ),
        };
        writeln!(
            x,
            r#"    <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/><string name="pixel_format" value="rgb"/>{rfilter}</film>"#
        )?;
        *x += "  </sensor>\n";
        Ok(())
    }

    /// The shapes, each with its material; writes their meshes and
    /// textures into `dir`.
    fn shapes_xml(&self, x: &mut String, dir: &Path) -> Result<()> {
        for &id in &self.images {
            materials::write_texture(self.scene, id, dir)?;
        }
        for (i, mesh) in self.meshes.iter().enumerate() {
            let file = mesh_file(i);
            write_ply(&dir.join(&file), mesh)?;
            let at = materials::Placement {
                uv: materials::MESH_UV,
                shading_normals: mesh.normals,
                vertex_colors: mesh.colors,
                tangents: mesh.tangents,
                one_sided: self.wrappings[mesh.material as usize].one_sided,
            };
            let wrapping = &self.wrappings[mesh.material as usize];
            let mut bsdf = wrapping.wrap(&self.surfaces[mesh.material as usize].xml(at), at.uv);
            if let (true, Some(c)) = (mesh.alpha, &self.coverages[mesh.material as usize]) {
                bsdf = c.wrap(&bsdf, at.uv, true);
            }
            writeln!(
                x,
                r#"  <shape type="ply"><string name="filename" value="{file}"/><boolean name="face_normals" value="{}"/>{bsdf}</shape>"#,
                !mesh.normals,
            )?;
        }
        for (center, radius, material) in &self.spheres {
            let surface = &self.surfaces[*material as usize];
            let wrapping = &self.wrappings[*material as usize];
            let at = materials::Placement {
                uv: materials::SPHERE_UV,
                shading_normals: false,
                vertex_colors: false,
                tangents: false,
                one_sided: wrapping.one_sided,
            };
            // A textured sphere is placed by a matrix that gives its uv the
            // reference's orientation; the others as before.
            let placed = if surface.uses_uv() || wrapping.uses_uv() {
                materials::sphere_to_world(*center, radius.abs())
            } else {
                format!(
                    r#"<point name="center" value="{}"/><float name="radius" value="{:?}"/>"#,
                    triple(*center),
                    radius.abs()
                )
            };
            writeln!(
                x,
                r#"  <shape type="sphere">{placed}<boolean name="flip_normals" value="{}"/>{}</shape>"#,
                *radius < 0.0,
                wrapping.wrap(&surface.xml(at), at.uv)
            )?;
        }
        Ok(())
    }

    /// The punctual lights.
    fn lights_xml(&self, x: &mut String) -> Result<()> {
        for (i, l) in self.scene.punctual_lights().iter().enumerate() {
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
                punctual_tag::DIRECTIONAL => writeln!(
                    x,
                    r#"  <emitter type="directional"><vector name="direction" value="{}"/>{}</emitter>"#,
                    triple(l.direction),
                    rgb("irradiance", l.intensity)
                )?,
                tag => {
                    // Mitsuba's own spot and projector: the frame as the
                    // to_world's columns, the texture at Mitsuba's (u, v).
                    let (x_axis, y_axis, z_axis, p) = (l.axis_x, l.axis_y, l.direction, l.position);
                    let matrix: Vec<String> = [
                        [x_axis.x, y_axis.x, z_axis.x, p.x],
                        [x_axis.y, y_axis.y, z_axis.y, p.y],
                        [x_axis.z, y_axis.z, z_axis.z, p.z],
                        [0.0, 0.0, 0.0, 1.0],
                    ]
                    .iter()
                    .flatten()
                    .map(|v| format!("{v:?}"))
                    .collect();
                    let to_world = format!(
                        r#"<transform name="to_world"><matrix value="{}"/></transform>"#,
                        matrix.join(" ")
                    );
                    const FLIP: materials::UvMap = [1.0, 0.0, 0.0, 0.0, -1.0, 1.0];
                    let texture = |name: &str| {
                        self.light_textures[i]
                            .as_ref()
                            .map_or(String::new(), |t| t.xml(name, FLIP))
                    };
                    let degrees = |cos: f32| (cos as f64).acos().to_degrees();
                    if tag == punctual_tag::SPOT_LINEAR {
                        writeln!(
                            x,
                            r#"  <emitter type="spot">{to_world}{}<float name="cutoff_angle" value="{:?}"/><float name="beam_width" value="{:?}"/>{}</emitter>"#,
                            rgb("intensity", l.intensity),
                            (l.profile[0] as f64).to_degrees(),
                            degrees(l.cos_inner),
                            texture("texture")
                        )?
                    } else {
                        // intensity = π · scale · irradiance; the field of
                        // view along y, whose half has tangent 1 / (2 sv).
                        let fov_y = 2.0 * (0.5 / l.profile[1] as f64).atan().to_degrees();
                        let pi = std::f32::consts::PI;
                        let light = match &self.light_textures[i] {
                            Some(_) => format!(
                                r#"<float name="scale" value="{:?}"/>{}"#,
                                l.intensity.x / pi,
                                texture("irradiance")
                            ),
                            None => rgb("irradiance", l.intensity / pi),
                        };
                        writeln!(
                            x,
                            r#"  <emitter type="projector">{to_world}<float name="fov" value="{fov_y:?}"/><string name="fov_axis" value="y"/>{light}</emitter>"#
                        )?
                    }
                }
            }
        }
        Ok(())
    }

    /// The background as an emitter (none where it is black); writes its
    /// map into `dir`.
    fn background_xml(&self, x: &mut String, dir: &Path) -> Result<()> {
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
            Background::Envmap {
                image,
                intensity,
                to_map,
                rows,
            } => {
                let data = &self.scene.images()[image as usize];
                match rows {
                    EnvRows::Bands => write_envmap(&dir.join(SKY_FILE), data)?,
                    EnvRows::Poles => write_map(
                        &dir.join(SKY_FILE),
                        data.width,
                        data.height,
                        data.texels.clone(),
                    )?,
                }
                // Mitsuba reads the map at to_world⁻¹ · d with u = 0 along
                // −z where the reference's u is 0.5 (half a turn H about
                // +y): to_map = H · to_world⁻¹, so to_world = to_mapᵀ · H.
                let m = (to_map.transpose() * Mat3::from_diagonal(Vec3::new(-1.0, 1.0, -1.0)))
                    .as_dmat3()
                    .transpose()
                    .to_cols_array();
                writeln!(
                    x,
                    r#"  <emitter type="envmap"><string name="filename" value="{SKY_FILE}"/><float name="scale" value="{intensity:?}"/><transform name="to_world"><matrix value="{:?} {:?} {:?} 0 {:?} {:?} {:?} 0 {:?} {:?} {:?} 0 0 0 0 1"/></transform></emitter>"#,
                    m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]
                )?;
            }
        }
        Ok(())
    }
}

/// Binary little-endian PLY: float vertices (position, uv, and the
/// normal and colour where the mesh has them), three per face, in order.
fn write_ply(path: &Path, mesh: &Mesh) -> Result<()> {
    let positions = &mesh.vertices;
    let faces = positions.len() / 3;
    image_io::write_atomic(path, |f| {
        use std::io::Write as _;
        let mut w = std::io::BufWriter::new(f);
        let mut properties = String::from(
            "property float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\n",
        );
        if mesh.normals {
            properties += "property float nx\nproperty float ny\nproperty float nz\n";
        }
        if mesh.colors {
            properties += "property float r\nproperty float g\nproperty float b\n";
        }
        if mesh.tangents {
            // Mitsuba keeps three-channel attributes: the tangent's w in
            // each channel of `tsign`.
            properties += "property float tangent_x\nproperty float tangent_y\nproperty float tangent_z\nproperty float tsign_x\nproperty float tsign_y\nproperty float tsign_z\n";
        }
        if mesh.uv1 {
            properties += "property float uv1_x\nproperty float uv1_y\nproperty float uv1_z\n";
        }
        if mesh.alpha {
            properties +=
                "property float alpha_x\nproperty float alpha_y\nproperty float alpha_z\n";
        }
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\nelement vertex {}\n{properties}element face {faces}\nproperty list uchar int vertex_indices\nend_header\n",
            positions.len()
        )?;
        for v in positions {
            let mut values = v.p.to_array().to_vec();
            values.extend(v.uv.to_array());
            if mesh.normals {
                values.extend(v.n.to_array());
            }
            if mesh.colors {
                values.extend(v.color.to_array());
            }
            if mesh.tangents {
                values.extend(v.tangent.truncate().to_array());
                values.extend([v.tangent.w; 3]);
            }
            if mesh.uv1 {
                values.extend([v.uv1.x, v.uv1.y, 0.0]);
            }
            if mesh.alpha {
                values.extend([v.alpha; 3]);
            }
            for c in values {
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
/// direction at polar angle `θ = π j / (rows − 1)` from +y (Mitsuba's
/// `envmap` puts its first and last rows at the poles; measured with its
/// `eval` against the lookup formulas in `write_envmap`'s note).
fn write_sky(path: &Path, horizon: Vec3, zenith: Vec3) -> Result<()> {
    const COLUMNS: usize = 8;
    let mut mean = Vec::with_capacity(SKY_ROWS * COLUMNS);
    for j in 0..SKY_ROWS {
        let theta = std::f64::consts::PI * j as f64 / (SKY_ROWS - 1) as f64;
        let t = (0.5 * (theta.cos() + 1.0)) as f32;
        mean.extend(std::iter::repeat_n(horizon.lerp(zenith, t), COLUMNS));
    }
    write_map(path, COLUMNS as u32, SKY_ROWS as u32, mean)
}

/// The reference's environment map (`evaluate_background`) as a map
/// Mitsuba's `envmap` looks up to the same values. Mitsuba interpolates
/// bilinearly at `x = u·w − ½` (columns wrapping; `u = atan2(x, −z) / 2π`)
/// and `y = (θ/π)·(h − 1)` (rows clamped: the first and last rows at the
/// poles); the reference at `x = u'·w − ½` (`u' = u + ½`: the half turn
/// the XML gives) and `y = (θ/π)·h − ½` with *repeat* wrapping, so within
/// half a row of a pole it blends the top row with the bottom one. Both
/// are piecewise linear in θ; the reference's knots are the row centres
/// and the poles, at multiples of π/2h. So the map gets 2h + 1 rows: row
/// 2k + 1 is the reference's row k, row 2k (0 < k < h) the mean of rows
/// k − 1 and k, and the two pole rows the mean of the first and last
/// rows; Mitsuba's interpolation of it is the reference's (within f32
/// rounding: 3·10^-6 of the values in a check of 1,000 directions, up to
/// 6·10^-5 within a degree of a pole when turned, where the azimuth is
/// ill-conditioned).
fn write_envmap(path: &Path, data: &reference::texture::ImageData) -> Result<()> {
    let (w, h) = (data.width as usize, data.height as usize);
    let row = |k: usize| &data.texels[k * w..(k + 1) * w];
    let mut mean = Vec::with_capacity((2 * h + 1) * w);
    for j in 0..=2 * h {
        if j % 2 == 1 {
            mean.extend_from_slice(row(j / 2));
        } else {
            let (a, b) = if j == 0 || j == 2 * h {
                (row(h - 1), row(0))
            } else {
                (row(j / 2 - 1), row(j / 2))
            };
            mean.extend(a.iter().zip(b).map(|(a, b)| 0.5 * (*a + *b)));
        }
    }
    write_map(path, w as u32, (2 * h + 1) as u32, mean)
}
