//! The public entry points and the import itself: a document's scene as
//! one mesh or added to a scene builder, its camera, or a framing one.

use super::bounds;
use super::document::GltfFile;
use super::extensions::LIGHTS;
use super::lights::{read_lights, GltfLightUnits};
use super::materials::texture_sets;
use super::meshes::{flip_winding, merge, mesh_named, place, MeshCache};
use super::nodes::instances;
use super::textures::Importer;
use crate::background::Background;
use crate::camera::CameraSettings;
use crate::error::SceneError;
use crate::scene::{MeshInput, RenderOrigin, Scene, SceneBuilder, Transform, MAX_IMAGE_SIDE};
use glam::{DAffine3, DVec3, Vec3};
use gltf::Document;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The field of view of the camera that [`load_gltf_document`] places when
/// the file has none, degrees.
pub const DEFAULT_VFOV: f32 = 40.0;

/// How the importer reads a document (the default: as the glTF
/// specification and its extensions define it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GltfOptions {
    /// The units of the lights' `intensity`.
    pub light_units: GltfLightUnits,
}

/// Loads every triangle of the document's scene, with the node transforms
/// applied, as one mesh (see the module documentation for what is read).
///
/// Normals: when no primitive has normals the mesh has none (the renderer
/// then shades with the geometric normal, which is the flat shading the
/// glTF spec asks for). When only some have them, the others are unwelded
/// into three vertices per triangle carrying the face normal, which keeps
/// their flat look while the merged mesh keeps per-vertex normals.
/// Texture coordinates: kept when any primitive has TEXCOORD_0; primitives
/// without them get `(0, 0)`.
pub fn load_gltf_mesh(path: &Path) -> Result<MeshInput, SceneError> {
    load_gltf_mesh_reading(path, &mut Vec::new(), &mut Vec::new())
}

/// [`load_gltf_mesh`], adding the files it reads (the document and its
/// external buffers) to `sources` ([`SceneBuilder::sources`]), and to
/// `warnings` ([`SceneBuilder::warnings`]) one line when the scene has
/// light that a mesh does not carry: `KHR_lights_punctual` lights on its
/// nodes, or materials with emission on the triangles read (the mesh
/// takes the caller's material).
pub fn load_gltf_mesh_reading(
    path: &Path,
    sources: &mut Vec<PathBuf>,
    warnings: &mut Vec<String>,
) -> Result<MeshInput, SceneError> {
    let file = GltfFile::open(path)?;
    sources.extend(file.files.iter().cloned());
    let mut parts: Vec<MeshInput> = Vec::new();
    let mut cache = MeshCache::default();
    let mut lights = 0;
    let mut emissive = std::collections::BTreeSet::new();
    let mut node_warnings = Vec::new();
    let instances = instances(&file.document, &mut node_warnings).map_err(|m| file.error(m))?;
    warnings.extend(
        node_warnings
            .into_iter()
            .map(|w| format!("{}: {w}", path.display())),
    );
    for instance in instances {
        lights += instance.light.is_some() as usize;
        let Some(mesh) = &instance.mesh else { continue };
        for primitive in mesh.primitives() {
            let material = primitive.material();
            if material.emissive_factor() != [0.0; 3] {
                emissive.insert(material.index());
            }
            let Some(local) = cache.get(&file, mesh.index(), &primitive)? else {
                continue;
            };
            parts.push(place(local, &instance.world));
        }
    }
    if parts.is_empty() {
        return Err(file.error("the document's scene contains no triangles".into()));
    }
    let mut dropped = Vec::new();
    if lights > 0 {
        dropped.push(format!("{lights} punctual light(s) (KHR_lights_punctual)"));
    }
    if !emissive.is_empty() {
        dropped.push(format!("the emission of {} material(s)", emissive.len()));
    }
    if !dropped.is_empty() {
        warnings.push(format!(
            "{}: a mesh takes only the file's triangles, so its {} add no light (a `gltf` object adds the file's lights and materials)",
            path.display(),
            dropped.join(" and ")
        ));
    }
    merge(parts).map_err(|m| file.error(m))
}

/// Adds the document's scene with its own materials to `builder`: one
/// `add_mesh` per primitive instance, placed by `transform · node world
/// matrix`. With `take_camera`, the first node (depth first) holding a
/// perspective camera sets `builder.camera` (pinhole, looking down the
/// node's -Z with +Y up) and, when the camera states an aspect ratio,
/// `builder.render.width` (the height is kept).
pub fn add_gltf_scene(
    builder: &mut SceneBuilder,
    path: &Path,
    transform: &Transform,
    take_camera: bool,
) -> Result<(), SceneError> {
    add_gltf_scene_with(
        builder,
        path,
        transform,
        take_camera,
        &GltfOptions::default(),
    )
}

/// [`add_gltf_scene`], reading the document as `options` say.
pub fn add_gltf_scene_with(
    builder: &mut SceneBuilder,
    path: &Path,
    transform: &Transform,
    take_camera: bool,
    options: &GltfOptions,
) -> Result<(), SceneError> {
    import_scene(builder, path, transform, take_camera, options).map(|_| ())
}

/// Loads a glTF document as a scene: its meshes, materials, lights and
/// first perspective camera. Without a camera, one looks down -Z at the
/// centre of the scene's bounds from far enough to see its bounding
/// sphere (vertical field of view [`DEFAULT_VFOV`]). The background is the
/// Ray Tracing in One Weekend sky (white horizon, light blue zenith).
/// Read as the specification defines it ([`GltfOptions::default`]).
pub fn load_gltf_document(path: &Path) -> Result<Scene, SceneError> {
    load_gltf_document_with(path, &GltfOptions::default())
}

/// [`load_gltf_document`], reading the document as `options` say.
pub fn load_gltf_document_with(path: &Path, options: &GltfOptions) -> Result<Scene, SceneError> {
    load_gltf_document_from(path, None, options)
}

/// [`load_gltf_document`] of a document already in memory (`bytes`, a
/// `.gltf` or a `.glb`, named `path`): nothing is read from disk but what
/// it refers to, relative to `path`'s folder (the fuzz targets' entry).
pub fn load_gltf_document_bytes(path: &Path, bytes: &[u8]) -> Result<Scene, SceneError> {
    load_gltf_document_from(path, Some(bytes), &GltfOptions::default())
}

fn load_gltf_document_from(
    path: &Path,
    bytes: Option<&[u8]>,
    options: &GltfOptions,
) -> Result<Scene, SceneError> {
    let mut builder = SceneBuilder::new();
    builder.render_origin = RenderOrigin::Camera;
    builder.background = Some(Background::Sky {
        horizon: Vec3::ONE,
        zenith: Vec3::new(0.5, 0.7, 1.0),
    });
    let file = GltfFile::open_from(path, bytes)?;
    let summary = import_file(&mut builder, file, &Transform::default(), true, options)?;
    if !summary.camera_taken {
        let aspect = builder.render.width as f32 / builder.render.height as f32;
        builder.camera = framing_camera(summary.bounds_min, summary.bounds_max, aspect);
    }
    builder.build().map_err(|e| e.in_file(path))
}

/// A camera on +Z of the box's centre that sees the box's bounding sphere
/// at the given aspect ratio.
fn framing_camera(min: Vec3, max: Vec3, aspect: f32) -> CameraSettings {
    let centre = 0.5 * (min + max);
    let mut radius = 0.5 * (max - min).length();
    if !(radius.is_finite() && radius > 0.0) {
        radius = 1.0;
    }
    let half_v = (0.5 * DEFAULT_VFOV).to_radians();
    let half_h = (half_v.tan() * aspect.max(1e-3)).atan();
    // 5 % margin so that the silhouette does not touch the frame.
    let distance = 1.05 * radius / half_v.min(half_h).sin();
    CameraSettings {
        look_from: centre + Vec3::new(0.0, 0.0, distance),
        look_at: centre,
        up: Vec3::Y,
        vfov: DEFAULT_VFOV,
        aperture: 0.0,
        focus_distance: distance,
        projection: crate::camera::Projection::Perspective,
    }
}

/// What [`import_scene`] found besides what it added.
struct ImportSummary {
    camera_taken: bool,
    /// World-space bounds of the added vertices.
    bounds_min: Vec3,
    bounds_max: Vec3,
}

fn import_scene(
    builder: &mut SceneBuilder,
    path: &Path,
    transform: &Transform,
    take_camera: bool,
    options: &GltfOptions,
) -> Result<ImportSummary, SceneError> {
    import_file(
        builder,
        GltfFile::open(path)?,
        transform,
        take_camera,
        options,
    )
}

fn import_file(
    builder: &mut SceneBuilder,
    file: GltfFile,
    transform: &Transform,
    take_camera: bool,
    options: &GltfOptions,
) -> Result<ImportSummary, SceneError> {
    let path = file.path.as_path();
    builder.sources.extend(file.files.iter().cloned());
    if !file.ignored_extensions.is_empty() {
        builder.warnings.push(format!(
            "{}: glTF extensions not supported, ignored: {}",
            path.display(),
            file.ignored_extensions.join(", ")
        ));
    }
    let mut importer = Importer {
        file: &file,
        images: HashMap::new(),
        textures: HashMap::new(),
        materials: HashMap::new(),
    };
    let mut cache = MeshCache::default();
    let mut summary = ImportSummary {
        camera_taken: false,
        bounds_min: Vec3::INFINITY,
        bounds_max: Vec3::NEG_INFINITY,
    };
    let lights = read_lights(&file, builder, options.light_units)?;
    let mut triangles = 0usize;
    let mut node_warnings = Vec::new();
    let instances = instances(&file.document, &mut node_warnings).map_err(|m| file.error(m))?;
    builder.warnings.extend(
        node_warnings
            .into_iter()
            .map(|w| format!("{}: {w}", path.display())),
    );
    for instance in instances {
        let world = Transform {
            matrix: transform.matrix * instance.world,
        };
        if let Some(index) = instance.light {
            let light = lights.get(index).ok_or_else(|| {
                file.error(format!(
                    "nodes[{}].extensions.{LIGHTS}.light: light {index} does not exist ({} defined)",
                    instance.node,
                    lights.len()
                ))
            })?;
            builder
                .add_light(light.placed(&world.matrix))
                .map_err(|e| light.rename(e, instance.node).in_file(path))?;
        }
        if take_camera && !summary.camera_taken {
            if let Some(camera) = instance.camera {
                summary.camera_taken = apply_camera(builder, &file.document, camera, &world.matrix)
                    .map_err(|m| file.error(m))?;
            }
        }
        let Some(mesh) = &instance.mesh else { continue };
        for primitive in mesh.primitives() {
            let Some(local) = cache.get(&file, mesh.index(), &primitive)? else {
                continue;
            };
            let material = importer.material(builder, primitive.material())?;
            let context = format!("{}: primitives[{}]", mesh_named(mesh), primitive.index());
            if local.uvs1.is_none() && texture_sets(&primitive.material()).contains(&1) {
                builder.warnings.push(format!(
                    "{}: {context}: its material reads TEXCOORD_1, which the primitive lacks: (0, 0) is read",
                    path.display(),
                ));
            }
            let mut input = local.clone();
            if world.mirrors() {
                flip_winding(&mut input.indices);
            }
            builder
                .add_mesh(&input, material, &world)
                .map_err(|e| e.within(&context).in_file(path))?;
            for &p in &input.positions {
                let q = world.point(p);
                summary.bounds_min = summary.bounds_min.min(q);
                summary.bounds_max = summary.bounds_max.max(q);
            }
            triangles += input.indices.len() / 3;
        }
    }
    if triangles == 0 {
        return Err(file.error("the document's scene contains no triangles".into()));
    }
    Ok(summary)
}

/// Sets the builder's camera from glTF camera `index` placed by `world`;
/// false when it is not a usable perspective camera (orthographic, or
/// placed by a matrix that leaves it no direction); an error where its
/// numbers are out of the specification's bounds ([`bounds::perspective`]).
fn apply_camera(
    builder: &mut SceneBuilder,
    document: &Document,
    index: usize,
    world: &DAffine3,
) -> Result<bool, String> {
    use gltf::json::camera::Type;
    use gltf::json::validation::Checked;
    // Read the JSON directly: `Camera::projection` unwraps the projection
    // object that the `type` names, which validation does not guarantee.
    let Some(camera) = document.as_json().cameras.get(index) else {
        return Ok(false);
    };
    let (Checked::Valid(Type::Perspective), Some(perspective)) =
        (&camera.type_, &camera.perspective)
    else {
        return Ok(false);
    };
    bounds::perspective(perspective).map_err(|m| {
        let at = format!("cameras[{index}]");
        format!(
            "{}: {m}",
            bounds::named("camera", &at, camera.name.as_deref())
        )
    })?;
    let from = world.transform_point3(DVec3::ZERO);
    let dir = world.transform_vector3(DVec3::NEG_Z).normalize_or_zero();
    let up = world.transform_vector3(DVec3::Y).normalize_or_zero();
    if !from.as_vec3().is_finite() || dir == DVec3::ZERO || up.as_vec3() == Vec3::ZERO {
        return Ok(false);
    }
    // The look-at point and focus plane sit at a distance that f32 can
    // still resolve next to `from` in world coordinates, as the camera is
    // shown (aperture 0: the distance changes nothing else).
    let reach = from.abs().max_element().max(1.0);
    builder.set_camera_exact(
        from,
        from + reach * dir,
        CameraSettings {
            up: up.as_vec3(),
            vfov: perspective.yfov.to_degrees(),
            aperture: 0.0,
            focus_distance: reach as f32,
            ..CameraSettings::default()
        },
    );
    if let Some(aspect) = perspective.aspect_ratio {
        let width = (builder.render.height as f32 * aspect).round();
        builder.render.width = width.clamp(1.0, MAX_IMAGE_SIDE as f32) as u32;
    }
    Ok(true)
}
