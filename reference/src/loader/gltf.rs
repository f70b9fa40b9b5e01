//! glTF 2.0 import (`.gltf` with external or `data:` buffers, and `.glb`).
//!
//! Three entry points:
//! - [`load_gltf_mesh`]: every triangle of the document's scene, placed by
//!   the node hierarchy and merged into one [`MeshInput`] (the scene file's
//!   `mesh` object, whose material overrides the file's);
//! - [`add_gltf_scene`]: the scene with its own materials, one
//!   `SceneBuilder::add_mesh` per primitive instance (the `gltf` object);
//! - [`load_gltf_document`]: a whole document as a [`Scene`].
//!
//! The last two have `_with` forms ([`add_gltf_scene_with`],
//! [`load_gltf_document_with`]) that take [`GltfOptions`]: how the lights'
//! intensities are read ([`GltfLightUnits`]).
//!
//! Extensions: the importer implements those of [`SUPPORTED_EXTENSIONS`],
//! and checks `extensionsRequired` itself (`check_required`): a
//! document that requires one of them loads, one that requires another
//! is refused, naming it (`extensionsRequired[1] = "KHR_draco_mesh_compression":
//! not supported by twintrace`). (The `gltf` crate would refuse every
//! required extension outside its own feature list, `KHR_lights_punctual`
//! among them, so its validation runs without the list.) Other extensions
//! in `extensionsUsed` are ignored with one warning line
//! ([`Scene::warnings`], printed by the CLI).
//!
//! Which nodes: the default scene, else the first scene; a document without
//! scenes contributes every mesh once, untransformed. Nodes are walked
//! depth first in document order; a node reached twice (the hierarchy is
//! not a forest) is an error, so cycles cannot hang the loader. A node's
//! `rotation` must be a unit quaternion: one within glTF-Validator's
//! bound of unit length is normalized (a warning line where it is off by
//! more than a rounded unit quaternion is, `bounds::ROTATION_QUIET`),
//! one further off is an error (`bounds::node_transform`).
//!
//! Geometry: `Triangles`, `TriangleStrip` and `TriangleFan` primitives are
//! imported (strips and fans are converted to triangles as the glTF spec
//! defines them); points and lines are skipped. Attributes read: POSITION,
//! NORMAL, TEXCOORD_0 and TEXCOORD_1, COLOR_0 (RGB or RGBA) and TANGENT
//! (kept only where the material has a normal map, and ignored without
//! NORMAL, as the spec says), stored as float or (normalized) integers,
//! dense or sparse. glTF's texture origin is the top-left corner and the
//! reference's the bottom-left, so `v` becomes `1 - v`. Normals go through
//! the inverse transpose of the node's matrix, tangents through the matrix
//! (their `w` changing sign under a mirror), and a node whose matrix
//! mirrors (negative determinant) has its triangles' winding reversed so
//! that front faces stay front faces, as the glTF spec requires. A
//! primitive whose material has a normal map but no TANGENT gets MikkTSpace
//! tangents ([`with_generated_tangents`]). The `mesh` object
//! ([`load_gltf_mesh`]) keeps positions, normals and TEXCOORD_0 only: its
//! material is the scene file's.
//!
//! Materials (metallic-roughness): `baseColorFactor` and
//! `baseColorTexture` (their RGB) become the base colour of a
//! [`Material::Ggx`] with `metallicFactor` and `roughnessFactor`. A
//! material's emission (`emissiveFactor` × `KHR_materials_emissive_strength`,
//! times `emissiveTexture` where it has one), where it is non-zero, is
//! added to its BSDF ([`SceneBuilder::set_emission`]), as glTF defines it:
//! the surface keeps its base colour, metal-roughness and normal map, and
//! emits from its front face (glTF's `doubleSided` is not read). A
//! material that transmits (`KHR_materials_transmission`, with
//! `KHR_materials_ior` and `KHR_materials_volume`) becomes a
//! [`Material::Dielectric`] (`Importer::dielectric` says how, and what is
//! lost is one warning line). The `metallicRoughnessTexture` scales the
//! factors per point (blue: metallic, green: roughness;
//! `material::ggx_parameters`); vertex colours scale the base colour; the
//! `normalTexture` bends the GGX material's shading normal
//! ([`crate::material::normal_mapped`]); `KHR_materials_clearcoat` lays
//! a [`crate::material::ClearCoat`] over it (`Importer::clearcoat`; its
//! `clearcoatNormalTexture` is a warning: the coat follows the base's
//! shading normal). A texture reads the coordinate
//! set its `texCoord` (or its transform's) names, 0 or 1 (a set above 1 is
//! a warning, and TEXCOORD_0 is read). Not supported (ignored): the
//! occlusion texture (occlusion is baked ambient light, which a path
//! tracer computes itself), `doubleSided` (other
//! materials shade both sides anyway; emitters emit from the front face
//! only), skins, morph targets, animations and orthographic cameras.
//! `alphaMode` MASK (with `alphaCutoff`, 0.5 by default) and BLEND give
//! the material a coverage ([`crate::material::Alpha`]): the alpha of the
//! base colour texture (its own decoding, [`Decoding::Alpha`]) times the
//! factor's and the vertex colour's, tested where the traversal accepts a
//! hit; BLEND is stochastic transparency ([`AlphaMode::Blend`]).
//! A primitive without a material gets the spec's default material: base
//! colour 1, metallic 1, roughness 1. Each glTF material, texture/factor
//! pair and image is added to the builder once.
//!
//! Lights (`KHR_lights_punctual`): each node holding a light adds it
//! ([`SceneBuilder::add_light`]) at the node's world position, pointing
//! along the node's −Z. The extension's `intensity` is photometric:
//! candela (lm/sr) for point and spot lights, lux (lm/m²) for directional
//! ones. The renderer's lights are radiometric, per channel: radiant
//! intensity (W/sr) and irradiance (W/m²). By default
//! ([`GltfLightUnits::Photometric`]) `color` × `intensity` /
//! [`LUMENS_PER_WATT`] (683 lm/W, as Blender's glTF importer converts) is
//! what the renderer gets; [`GltfLightUnits::Radiometric`] takes
//! `color` × `intensity` as watts already (for files whose writer put
//! them there). A
//! spot's `innerConeAngle` and `outerConeAngle` (defaults 0 and π/4)
//! shape its falloff as the extension's reference formula does
//! ([`crate::light::PunctualLight::falloff`]). `range` is not honoured:
//! a light that states one falls off by the inverse square law alone, and
//! the importer says so in one warning line per light.
//!
//! Textures keep their sampler (wrap modes per axis: repeat, clamp to
//! edge, mirrored repeat; a NEAREST magnification filter) and their
//! `KHR_texture_transform` (offset, rotation, scale), rewritten for the
//! renderer's uv convention (`sampler`); the renderer builds no mipmaps,
//! so minification filters are read as the magnification one.
//!
//! Images are decoded by the `gltf` crate (PNG, JPEG), only when a material
//! uses them. 8- and 16-bit channels of base colour and emissive textures
//! are sRGB-encoded colour and are decoded to linear, those of the
//! metallic-roughness texture linear data (an image used both ways is
//! decoded once each way); float images are taken as linear. Grey images
//! become grey RGB; the alpha channel is decoded (linear) into an image of
//! its own where a material's alpha mode reads it. Row 0 of the decoded image is the top row, as in [`ImageData`].
//!
//! Every problem in the file (unreadable, not glTF, a buffer that is
//! missing or too short, an accessor that reaches past its buffer, an
//! index out of range, a value of the wrong type, a number outside the
//! bounds the specification gives it or an attribute of an accessor type
//! it does not allow ([`bounds`]), ...) is an error that names the file,
//! the element (by name and index) and the field; the `gltf` crate's code
//! paths that would panic on such input are checked for beforehand or not
//! used.

mod bounds;
mod uv_transform;

use uv_transform::{uv_matrix, UvTransform, TEXTURE_TRANSFORM};

use crate::background::Background;
use crate::camera::CameraSettings;
use crate::error::SceneError;
use crate::material::{Alpha, AlphaMode, ClearCoat, Material, NormalMap};
use crate::scene::{
    LightInput, MeshInput, RenderOrigin, Scene, SceneBuilder, Transform, MAX_IMAGE_SIDE,
};
use crate::texture::{decode_8bit, srgb_to_linear, ImageData, Texture};
use glam::{DAffine3, DMat3, DMat4, DQuat, DVec3, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Data as BufferData;
use gltf::mesh::{Mode, Semantic};
use gltf::Document;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The field of view of the camera that [`load_gltf_document`] places when
/// the file has none, degrees.
pub const DEFAULT_VFOV: f32 = 40.0;

/// Largest accessor stored without a buffer view (all zeros, then sparse
/// substitutions), in bytes: beyond it the count is a mistake.
const MAX_VIEWLESS_ACCESSOR_BYTES: usize = 1 << 30;

/// Lumens per watt: how a `KHR_lights_punctual` intensity (candela, lm/sr,
/// for point and spot lights; lux, lm/m², for directional ones) becomes
/// the renderer's radiant intensity (W/sr) and irradiance (W/m²):
/// divided by this luminous efficacy. 683 lm/W is the efficacy of light
/// at 555 nm (the SI definition of the candela); provenance: Blender's
/// glTF importer, glTF-Blender-IO's `PBR_WATTS_TO_LUMENS = 683`
/// (addons/io_scene_gltf2/blender/com/conversion.py), which its
/// `BlenderLight.calc_energy_directional` divides lux by (sun strength,
/// W/m²) and `calc_energy_pointlike` divides candela by (× 4π: Blender's
/// point and spot power in W) in its default lighting mode, "Standard".
/// Its "Raw" mode, which keeps the numbers, is [`GltfLightUnits::Radiometric`].
pub const LUMENS_PER_WATT: f32 = 683.0;

/// How the importer reads a `KHR_lights_punctual` light's `intensity`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GltfLightUnits {
    /// The extension's meaning: candela (point, spot) and lux
    /// (directional), converted to W/sr and W/m² at [`LUMENS_PER_WATT`].
    #[default]
    Photometric,
    /// Watts already: W/sr and W/m², taken as they are (for files whose
    /// writer put radiometric numbers in the field).
    Radiometric,
}

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

/// The punctual lights extension.
const LIGHTS: &str = "KHR_lights_punctual";

/// A `KHR_lights_punctual` light as the document defines it, in the
/// light's own frame (at the origin, pointing down −Z).
#[derive(Clone, Debug)]
struct GltfLight {
    /// How errors name it ([`bounds::named`]).
    at: String,
    kind: LightKind,
    /// `color` × `intensity`.
    value: Vec3,
    inner: f32,
    outer: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum LightKind {
    Point,
    Spot,
    Directional,
}

impl GltfLight {
    /// The light placed by its node's world matrix.
    fn placed(&self, world: &DAffine3) -> LightInput {
        let position = world.transform_point3(DVec3::ZERO);
        let direction = world.transform_vector3(DVec3::NEG_Z).as_vec3();
        match self.kind {
            LightKind::Point => LightInput::Point {
                position,
                intensity: self.value,
            },
            LightKind::Spot => LightInput::Spot {
                position,
                direction,
                intensity: self.value,
                inner_cone_angle: self.inner,
                outer_cone_angle: self.outer,
            },
            LightKind::Directional => LightInput::Directional {
                direction,
                irradiance: self.value,
            },
        }
    }

    /// A builder error with the document's names for its fields (the
    /// values the document gives are checked by [`read_lights`]; what the
    /// builder can still refuse is where its node puts it).
    fn rename(&self, e: SceneError, node: usize) -> SceneError {
        match e {
            SceneError::Invalid { field, message } => {
                let field = match field.as_str() {
                    "intensity" | "irradiance" => "color × intensity".to_string(),
                    "inner_cone_angle" => "spot.innerConeAngle".to_string(),
                    "outer_cone_angle" => "spot.outerConeAngle".to_string(),
                    "direction" => format!("direction (nodes[{node}]'s −Z)"),
                    "position" => format!("position (nodes[{node}]'s)"),
                    other => other.to_string(),
                };
                SceneError::invalid(&format!("{}: {field}", self.at), message)
            }
            other => other,
        }
    }
}

/// The document's `KHR_lights_punctual` lights (none without the
/// extension); a `range` is one warning line each. Every number is
/// checked against the extension's bounds (its README and schema,
/// light.schema.json and light.spot.schema.json): each `color` component
/// in [0, 1], `intensity` at least 0, `range` above 0, a spot's
/// `innerConeAngle` at least 0 and below `outerConeAngle`, which is at most
/// π/2; all of them finite as f32. With the colour at most 1, `color` ×
/// `intensity` is at most the intensity: finite. The intensity is read in
/// `units` ([`GltfLightUnits`]): photometric, it is divided by
/// [`LUMENS_PER_WATT`] (in f32, before the colour multiplies it).
fn read_lights(
    file: &GltfFile,
    builder: &mut SceneBuilder,
    units: GltfLightUnits,
) -> Result<Vec<GltfLight>, SceneError> {
    let Some(ext) = file.document.extension_value(LIGHTS) else {
        return Ok(Vec::new());
    };
    let lights_path = format!("extensions.{LIGHTS}.lights");
    let Some(list) = ext.get("lights").and_then(|l| l.as_array()) else {
        return Err(file.error(format!("{lights_path} is missing or not an array")));
    };
    let mut out = Vec::with_capacity(list.len());
    for (i, light) in list.iter().enumerate() {
        let name = light.get("name").and_then(|n| n.as_str());
        let at = bounds::named("light", &format!("{lights_path}[{i}]"), name);
        let error = |m: String| file.error(format!("{at}: {m}"));
        let object = light
            .as_object()
            .ok_or_else(|| file.error(format!("{lights_path}[{i}] is not an object")))?;
        // Member `field` of `o` (the last name of its path: `spot` holds
        // `spot.innerConeAngle`'s `innerConeAngle`), a number (read as
        // f32, as the `gltf` crate reads numbers) in `range`; `default`
        // where absent.
        let number = |o: &serde_json::Map<String, serde_json::Value>,
                      field: &str,
                      default: f32,
                      range: bounds::Range| match o
            .get(field.rsplit('.').next().unwrap_or(field))
        {
            None => Ok(default),
            Some(v) => {
                let x = v
                    .as_f64()
                    .ok_or_else(|| error(format!("{field} {v} is not a number")))?
                    as f32;
                bounds::number(field, x, range).map_err(&error)?;
                Ok(x)
            }
        };
        let kind = match object.get("type").and_then(|t| t.as_str()) {
            Some("point") => LightKind::Point,
            Some("spot") => LightKind::Spot,
            Some("directional") => LightKind::Directional,
            other => {
                return Err(error(format!(
                    "type {} is not point, spot or directional",
                    other.map_or("(missing)".to_string(), |t| format!("\"{t}\""))
                )))
            }
        };
        let color = match object.get("color") {
            None => Vec3::ONE,
            Some(v) => {
                let c: Option<Vec<f64>> = v
                    .as_array()
                    .filter(|a| a.len() == 3)
                    .and_then(|a| a.iter().map(|x| x.as_f64()).collect());
                let Some(c) = c else {
                    return Err(error(format!("color {v} is not [r, g, b]")));
                };
                let c = Vec3::from_array([c[0], c[1], c[2]].map(|x| x as f32));
                for (k, x) in c.to_array().into_iter().enumerate() {
                    bounds::number(&format!("color[{k}]"), x, bounds::Range::Unit)
                        .map_err(&error)?;
                }
                c
            }
        };
        let intensity = number(object, "intensity", 1.0, bounds::Range::NonNegative)?;
        let (mut inner, mut outer) = (0.0, std::f32::consts::FRAC_PI_4);
        if kind == LightKind::Spot {
            if let Some(spot) = object.get("spot") {
                let spot = spot
                    .as_object()
                    .ok_or_else(|| error("spot is not an object".into()))?;
                inner = number(
                    spot,
                    "spot.innerConeAngle",
                    inner,
                    bounds::Range::NonNegative,
                )?;
                outer = number(spot, "spot.outerConeAngle", outer, bounds::Range::Positive)?;
            }
            if outer > std::f32::consts::FRAC_PI_2 {
                return Err(error(format!(
                    "spot.outerConeAngle {} is above π/2",
                    bounds::show(outer)
                )));
            }
            if inner >= outer {
                return Err(error(format!(
                    "spot.innerConeAngle {} must be below spot.outerConeAngle {}",
                    bounds::show(inner),
                    bounds::show(outer)
                )));
            }
        }
        if object.contains_key("range") {
            let range = number(object, "range", 0.0, bounds::Range::Positive)?;
            builder.warnings.push(format!(
                "{}: {at}: range {} ignored: the light falls off by the inverse square law alone",
                file.path.display(),
                bounds::show(range)
            ));
        }
        let radiometric = match units {
            GltfLightUnits::Photometric => intensity / LUMENS_PER_WATT,
            GltfLightUnits::Radiometric => intensity,
        };
        out.push(GltfLight {
            at,
            kind,
            value: color * radiometric,
            inner,
            outer,
        });
    }
    Ok(out)
}

/// The glTF extensions the importer implements: a document may require
/// them (`extensionsRequired`). Not among them, though the `gltf` crate
/// parses them: `KHR_materials_unlit` and
/// `KHR_materials_pbrSpecularGlossiness` (ignored with a warning where a
/// document only uses them), `KHR_mesh_quantization` (its integer
/// positions and normals are refused, `bounds::attribute`).
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    CLEARCOAT,
    LIGHTS,
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// Every name of a document's `extensionsRequired` must be one of
/// [`SUPPORTED_EXTENSIONS`]: a file that requires another cannot be shown
/// as its author meant without it (glTF 2.0, "Specifying Extensions").
/// The error names each such entry by its place in the list, in one line:
/// `extensionsRequired[1] = "KHR_draco_mesh_compression": not supported by
/// twintrace (supported: ...)`.
fn check_required(required: &[String]) -> Result<(), String> {
    let refused: Vec<String> = required
        .iter()
        .enumerate()
        .filter(|(_, name)| !SUPPORTED_EXTENSIONS.contains(&name.as_str()))
        .map(|(i, name)| format!("extensionsRequired[{i}] = {name:?}"))
        .collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(format!(
        "{}: not supported by twintrace (supported: {})",
        refused.join(", "),
        SUPPORTED_EXTENSIONS.join(", ")
    ))
}

/// A parsed document with its buffers loaded.
struct GltfFile {
    path: PathBuf,
    /// The document and the files of its external buffers, as read.
    files: Vec<PathBuf>,
    base: PathBuf,
    document: Document,
    buffers: Vec<BufferData>,
    /// Extensions the document uses (without requiring them) that the
    /// importer ignores.
    ignored_extensions: Vec<String>,
}

impl GltfFile {
    fn open(path: &Path) -> Result<Self, SceneError> {
        Self::open_from(path, None)
    }

    /// The document `path`, or `bytes` if given (named `path`).
    fn open_from(path: &Path, bytes: Option<&[u8]>) -> Result<Self, SceneError> {
        let fail = |message: String| SceneError::Io {
            path: path.to_path_buf(),
            message,
        };
        let read;
        let bytes = match bytes {
            Some(bytes) => bytes,
            None => {
                read =
                    std::fs::read(path).map_err(|e| fail(format!("cannot read glTF file: {e}")))?;
                &read
            }
        };
        if bytes.starts_with(b"glTF") {
            check_glb_header(bytes).map_err(|m| fail(format!("not a valid GLB file: {m}")))?;
        }
        let (document, mut blob) =
            parse(bytes).map_err(|m| fail(format!("cannot read glTF: {m}")))?;
        let mut json = document.into_json();
        // The required list is checked here, against what this importer
        // implements; the `gltf` crate's validation would refuse every
        // name outside its own enabled features (`KHR_lights_punctual`,
        // `KHR_materials_volume` and `KHR_materials_clearcoat` among
        // them), so it runs without the list, which is then put back.
        // Nothing else in that validation reads the list.
        let required = std::mem::take(&mut json.extensions_required);
        check_required(&required).map_err(&fail)?;
        let document = Document::from_json_without_validation(json);
        check_position_accessors(&document).map_err(&fail)?;
        let mut json = Document::from_json(document.into_json())
            .map_err(|e| fail(format!("cannot read glTF: {e}")))?
            .into_json();
        json.extensions_required = required;
        let document = Document::from_json_without_validation(json);
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let ignored_extensions = document
            .extensions_used()
            .filter(|n| !SUPPORTED_EXTENSIONS.contains(n))
            .map(str::to_string)
            .collect();
        check_uris(&document).map_err(&fail)?;
        check_views(&document).map_err(&fail)?;
        let mut buffers = Vec::new();
        let mut files = vec![path.to_path_buf()];
        for buffer in document.buffers() {
            if let gltf::buffer::Source::Uri(uri) = buffer.source() {
                files.extend(uri_file(&base, uri));
            }
            let source = match buffer.source() {
                gltf::buffer::Source::Bin => "the GLB binary chunk".to_string(),
                gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                    "its data: URI".to_string()
                }
                gltf::buffer::Source::Uri(uri) => format!("`{}`", base.join(uri).display()),
            };
            let data = BufferData::from_source_and_blob(buffer.source(), Some(&base), &mut blob)
                .map_err(|e| {
                    fail(format!(
                        "cannot load buffer {} from {source}: {e}",
                        buffer.index()
                    ))
                })?;
            if data.len() < buffer.length() {
                return Err(fail(format!(
                    "buffer {} from {source} holds {} bytes, the document says {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                )));
            }
            buffers.push(data);
        }
        Ok(Self {
            path: path.to_path_buf(),
            files,
            base,
            document,
            buffers,
            ignored_extensions,
        })
    }

    fn error(&self, message: String) -> SceneError {
        SceneError::Io {
            path: self.path.clone(),
            message,
        }
    }
}

/// The document's JSON (a `.gltf`, or a `.glb`'s JSON chunk) as the
/// `gltf` crate's types, unvalidated, and the `.glb`'s binary chunk. It is
/// deserialized as the crate does, through `serde_path_to_error`, so that
/// a value of the wrong type is named by its path in the file.
fn parse(bytes: &[u8]) -> Result<(Document, Option<Vec<u8>>), String> {
    let glb;
    let (json, blob) = if bytes.starts_with(b"glTF") {
        glb = gltf::Glb::from_slice(bytes).map_err(|e| e.to_string())?;
        (&*glb.json, glb.bin.as_deref().map(<[u8]>::to_vec))
    } else {
        (bytes, None)
    };
    let de = &mut serde_json::Deserializer::from_slice(json);
    let root: gltf::json::Root =
        serde_path_to_error::deserialize(&mut *de).map_err(|e| match e.path().iter().next() {
            // Not in a value (a syntax error before the first member).
            None => e.inner().to_string(),
            Some(_) => format!("{}: {}", path_named(e.path(), json), e.inner()),
        })?;
    de.end().map_err(|e| e.to_string())?;
    Ok((Document::from_json_without_validation(root), blob))
}

/// A path in the document (`materials[0].pbrMetallicRoughness...`), the
/// element of the top-level array it starts in [`bounds::named`] as the
/// importer's other errors name it (`material "Brass", materials[0]:
/// pbrMetallicRoughness...`) where the element has a name.
fn path_named(path: &serde_path_to_error::Path, json: &[u8]) -> String {
    use serde_path_to_error::Segment;
    let segments: Vec<&Segment> = path.iter().collect();
    let [Segment::Map { key }, Segment::Seq { index }, rest @ ..] = segments.as_slice() else {
        return path.to_string();
    };
    let what = match key.as_str() {
        "accessors" => "accessor",
        "bufferViews" => "bufferView",
        "buffers" => "buffer",
        "cameras" => "camera",
        "images" => "image",
        "materials" => "material",
        "meshes" => "mesh",
        "nodes" => "node",
        "samplers" => "sampler",
        "scenes" => "scene",
        "textures" => "texture",
        _ => return path.to_string(),
    };
    let name = element_name(json, key, *index);
    let mut inside = String::new();
    for segment in rest {
        match segment {
            Segment::Seq { index } => inside += &format!("[{index}]"),
            Segment::Map { key } if inside.is_empty() => inside += key,
            Segment::Map { key } => inside += &format!(".{key}"),
            Segment::Enum { variant } if inside.is_empty() => inside += variant,
            Segment::Enum { variant } => inside += &format!(".{variant}"),
            Segment::Unknown => inside += "?",
        }
    }
    let element = bounds::named(what, &format!("{key}[{index}]"), name.as_deref());
    if inside.is_empty() {
        element
    } else {
        format!("{element}: {inside}")
    }
}

/// The `name` of element `index` of the document's top-level array `key`,
/// read from a document that did not deserialize: everything but the
/// names is skipped unparsed (serde_json skips a number without reading
/// its value, so one beyond f64's range does not stop it).
fn element_name(json: &[u8], key: &str, index: usize) -> Option<String> {
    #[derive(serde::Deserialize)]
    struct Element {
        name: Option<String>,
    }
    #[derive(Default, serde::Deserialize)]
    #[serde(default, rename_all = "camelCase")]
    struct Arrays {
        accessors: Vec<Element>,
        buffer_views: Vec<Element>,
        buffers: Vec<Element>,
        cameras: Vec<Element>,
        images: Vec<Element>,
        materials: Vec<Element>,
        meshes: Vec<Element>,
        nodes: Vec<Element>,
        samplers: Vec<Element>,
        scenes: Vec<Element>,
        textures: Vec<Element>,
    }
    let arrays: Arrays = serde_json::from_slice(json).ok()?;
    let elements = match key {
        "accessors" => arrays.accessors,
        "bufferViews" => arrays.buffer_views,
        "buffers" => arrays.buffers,
        "cameras" => arrays.cameras,
        "images" => arrays.images,
        "materials" => arrays.materials,
        "meshes" => arrays.meshes,
        "nodes" => arrays.nodes,
        "samplers" => arrays.samplers,
        "scenes" => arrays.scenes,
        "textures" => arrays.textures,
        _ => return None,
    };
    elements.into_iter().nth(index)?.name
}

/// Checks what the `gltf` crate's GLB parser takes on trust.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    let word = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err("the 12-byte header is truncated".into());
    };
    if version != 2 {
        return Err(format!("container version {version} (only 2 is supported)"));
    }
    if (length as usize) < 20 || length as usize > bytes.len() {
        return Err(format!(
            "the header states {length} bytes but the file has {} (at least 20 are needed)",
            bytes.len()
        ));
    }
    Ok(())
}

/// The `gltf` crate's validation indexes the accessor a primitive's
/// `POSITION` names before it checks the index (it panicked on a file
/// whose `accessors` were misspelled; found by the fuzz target `glb`).
fn check_position_accessors(document: &Document) -> Result<(), String> {
    let json = document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= json.accessors.len() {
                    return Err(format!(
                        "mesh {m} primitive {p}: POSITION names accessor {}, the file has {}",
                        index.value(),
                        json.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The `gltf` crate unwraps the UTF-8 decoding of percent-escaped relative
/// URIs; reject those that would not decode.
fn check_uris(document: &Document) -> Result<(), String> {
    let json = document.as_json();
    let buffer_uris = json
        .buffers
        .iter()
        .enumerate()
        .filter_map(|(i, b)| b.uri.as_deref().map(|u| (format!("buffer {i}"), u)));
    let image_uris = json
        .images
        .iter()
        .enumerate()
        .filter_map(|(i, im)| im.uri.as_deref().map(|u| (format!("image {i}"), u)));
    for (what, uri) in buffer_uris.chain(image_uris) {
        if !uri.contains(':') && !percent_decodes_to_utf8(uri) {
            return Err(format!(
                "{what}: URI `{uri}` is not valid UTF-8 once percent-decoded"
            ));
        }
    }
    Ok(())
}

fn percent_decodes_to_utf8(uri: &str) -> bool {
    percent_decode(uri).is_some()
}

/// `uri` with its `%XX` escapes decoded, if that is UTF-8 (as the `gltf`
/// crate decodes a relative URI before reading it).
fn percent_decode(uri: &str) -> Option<String> {
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            if let (Some(h), Some(l)) = (
                bytes.get(i + 1).and_then(|&c| hex(c)),
                bytes.get(i + 2).and_then(|&c| hex(c)),
            ) {
                out.push(h << 4 | l);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8(out).ok()
}

/// The file a buffer or image URI names, as the `gltf` crate resolves it
/// (a relative URI, percent-decoded, against `base`; `file:` as written);
/// `None` for a `data:` URI or a scheme the crate does not read.
fn uri_file(base: &Path, uri: &str) -> Option<PathBuf> {
    if uri.contains(':') {
        let rest = uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))?;
        return Some(PathBuf::from(rest));
    }
    percent_decode(uri).map(|p| base.join(p))
}

/// Every buffer view must lie inside its buffer (the image decoder slices
/// views without checking).
fn check_views(document: &Document) -> Result<(), String> {
    for view in document.views() {
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|e| e > view.buffer().length()) {
            return Err(format!(
                "bufferView {} (offset {}, length {}) reaches past the end of buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                view.buffer().length()
            ));
        }
    }
    Ok(())
}

/// A node (or, in a document without scenes, a bare mesh) to place.
struct Instance<'a> {
    node: usize,
    mesh: Option<gltf::Mesh<'a>>,
    camera: Option<usize>,
    /// The `KHR_lights_punctual` light the node holds.
    light: Option<usize>,
    world: DAffine3,
}

/// The document's scene flattened, depth first in document order; what
/// the nodes' transforms warn of (`node_matrix`) is added to `warnings`,
/// one line each, without the file's name.
fn instances<'a>(
    document: &'a Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<Instance<'a>>, String> {
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let Some(scene) = scene else {
        return Ok(document
            .meshes()
            .map(|mesh| Instance {
                node: 0,
                mesh: Some(mesh),
                camera: None,
                light: None,
                world: DAffine3::IDENTITY,
            })
            .collect());
    };
    let mut visited = vec![false; document.as_json().nodes.len()];
    let mut out = Vec::new();
    let mut stack: Vec<(gltf::Node, DAffine3)> =
        scene.nodes().map(|n| (n, DAffine3::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let seen = visited
            .get_mut(node.index())
            .ok_or_else(|| format!("node {} does not exist", node.index()))?;
        if std::mem::replace(seen, true) {
            return Err(format!(
                "node {} is reached twice from scene {} (the node hierarchy must be a forest)",
                node.index(),
                scene.index()
            ));
        }
        // Finite: node_matrix checked every number.
        let local = node_matrix(&node, warnings)?;
        let world = parent * DAffine3::from_mat4(local);
        if !world.is_finite() {
            return Err(format!(
                "node {}: the composed world transform is not finite",
                node.index()
            ));
        }
        let light = match node.extension_value(LIGHTS) {
            None => None,
            Some(v) => Some(v.get("light").and_then(|l| l.as_u64()).ok_or_else(|| {
                format!(
                    "nodes[{}].extensions.{LIGHTS}.light {} is not a light index",
                    node.index(),
                    v.get("light").map_or("(missing)".into(), |l| l.to_string())
                )
            })? as usize),
        };
        out.push(Instance {
            node: node.index(),
            mesh: node.mesh(),
            camera: node.camera().map(|c| c.index()),
            light,
            world,
        });
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
    }
    Ok(out)
}

/// A node's local transform in f64: its matrix, or its translation,
/// rotation and scale composed in f64 (the hierarchy is composed in f64
/// too, and rounded to f32 only in render space). What glTF 2.0 requires
/// of them ([`bounds::node_transform`]) is checked first; a rotation
/// within that check's tolerance of unit length is normalized, so that
/// the digits a writer rounded to do not scale the mesh (every accepted
/// rotation is, as before the tolerance was widened: one within 10^-3 of
/// unit length loads exactly as it did). One further from unit length
/// than [`bounds::ROTATION_QUIET`] adds a line to `warnings`.
fn node_matrix(node: &gltf::Node, warnings: &mut Vec<String>) -> Result<DMat4, String> {
    let transform = node.transform();
    let named = || bounds::named("node", &format!("nodes[{}]", node.index()), node.name());
    let warning = bounds::node_transform(&transform).map_err(|m| format!("{}.{m}", named()))?;
    if let Some(w) = warning {
        warnings.push(format!("{}.{w}", named()));
    }
    Ok(match transform {
        gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(|x| x as f64)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => DMat4::from_scale_rotation_translation(
            Vec3::from(scale).as_dvec3(),
            DQuat::from_array(rotation.map(|x| x as f64)).normalize(),
            Vec3::from(translation).as_dvec3(),
        ),
    })
}

/// Primitives read once, in their own space, however many nodes use them.
#[derive(Default)]
struct MeshCache {
    meshes: HashMap<(usize, usize), Option<MeshInput>>,
}

impl MeshCache {
    /// The primitive's triangles (`None`: not triangles, or no triangles).
    fn get(
        &mut self,
        file: &GltfFile,
        mesh: usize,
        primitive: &gltf::Primitive,
    ) -> Result<Option<&MeshInput>, SceneError> {
        let key = (mesh, primitive.index());
        let slot = match self.meshes.entry(key) {
            std::collections::hash_map::Entry::Occupied(slot) => slot.into_mut(),
            std::collections::hash_map::Entry::Vacant(slot) => {
                let read = read_primitive(primitive, &file.buffers).map_err(|m| {
                    let at = file
                        .document
                        .meshes()
                        .nth(mesh)
                        .map_or_else(|| format!("meshes[{mesh}]"), |mesh| mesh_named(&mesh));
                    file.error(format!("{at}: primitives[{}]: {m}", primitive.index()))
                })?;
                slot.insert(read.filter(|m| !m.indices.is_empty()))
            }
        };
        Ok(slot.as_ref())
    }
}

/// How errors and warnings name a mesh ([`bounds::named`]).
fn mesh_named(mesh: &gltf::Mesh) -> String {
    bounds::named("mesh", &format!("meshes[{}]", mesh.index()), mesh.name())
}

/// Reads one primitive as indexed triangles in the mesh's own space.
fn read_primitive(
    primitive: &gltf::Primitive,
    buffers: &[BufferData],
) -> Result<Option<MeshInput>, String> {
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(None);
    }
    for (semantic, accessor) in primitive.attributes() {
        bounds::attribute(&semantic, &accessor)?;
    }
    let positions_accessor = primitive
        .get(&Semantic::Positions)
        .ok_or("no POSITION attribute")?;
    let positions: Vec<Vec3> =
        read_floats(&positions_accessor, buffers, "POSITION", Dimensions::Vec3)?
            .chunks_exact(3)
            .map(Vec3::from_slice)
            .collect();
    let n = positions.len();
    let normals = match primitive.get(&Semantic::Normals) {
        Some(a) => Some(
            read_floats(&a, buffers, "NORMAL", Dimensions::Vec3)?
                .chunks_exact(3)
                .map(Vec3::from_slice)
                .collect::<Vec<_>>(),
        ),
        None => None,
    };
    // A texture coordinate set, v flipped into the renderer's convention.
    let read_uvs = |set: u32| -> Result<Option<Vec<Vec2>>, String> {
        let Some(a) = primitive.get(&Semantic::TexCoords(set)) else {
            return Ok(None);
        };
        let name = format!("TEXCOORD_{set}");
        Ok(Some(
            read_floats(&a, buffers, &name, Dimensions::Vec2)?
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0], 1.0 - c[1]))
                .collect(),
        ))
    };
    let (uvs, uvs1) = (read_uvs(0)?, read_uvs(1)?);
    let colors = match primitive.get(&Semantic::Colors(0)) {
        Some(a) => {
            let shape = match a.dimensions() {
                Dimensions::Vec3 => Dimensions::Vec3,
                _ => Dimensions::Vec4,
            };
            let floats = read_floats(&a, buffers, "COLOR_0", shape)?;
            Some(match shape {
                Dimensions::Vec3 => floats
                    .chunks_exact(3)
                    .map(|c| Vec3::from_slice(c).extend(1.0))
                    .collect::<Vec<_>>(),
                _ => floats.chunks_exact(4).map(Vec4::from_slice).collect(),
            })
        }
        None => None,
    };
    // Tangents without normals are to be ignored (glTF 2.0, "Meshes").
    let tangents = match (primitive.get(&Semantic::Tangents), &normals) {
        (Some(a), Some(_)) => Some(
            read_floats(&a, buffers, "TANGENT", Dimensions::Vec4)?
                .chunks_exact(4)
                .map(Vec4::from_slice)
                .collect::<Vec<_>>(),
        ),
        _ => None,
    };
    for (name, len) in [
        ("NORMAL", normals.as_ref().map(Vec::len)),
        ("TEXCOORD_0", uvs.as_ref().map(Vec::len)),
        ("TEXCOORD_1", uvs1.as_ref().map(Vec::len)),
        ("COLOR_0", colors.as_ref().map(Vec::len)),
        ("TANGENT", tangents.as_ref().map(Vec::len)),
    ] {
        if let Some(len) = len.filter(|&l| l != n) {
            return Err(format!("{name} has {len} elements but POSITION has {n}"));
        }
    }
    let vertices: Vec<u32> = match primitive.indices() {
        Some(a) => read_indices(&a, buffers)?,
        None => {
            let count = u32::try_from(n).map_err(|_| format!("{n} vertices are too many"))?;
            (0..count).collect()
        }
    };
    if let Some((i, &bad)) = vertices.iter().enumerate().find(|(_, &v)| v as usize >= n) {
        return Err(format!("index {i} is {bad}, out of range for {n} vertices"));
    }
    let indices = match mode {
        Mode::Triangles => {
            if !vertices.chunks_exact(3).remainder().is_empty() {
                return Err(format!(
                    "a triangle list with {} indices (not a multiple of 3)",
                    vertices.len()
                ));
            }
            vertices
        }
        // Strip triangle i: (v[i], v[i+1], v[i+2]) for even i, (v[i], v[i+2], v[i+1]) for odd i.
        Mode::TriangleStrip => (0..vertices.len().saturating_sub(2))
            .flat_map(|i| {
                if i % 2 == 0 {
                    [vertices[i], vertices[i + 1], vertices[i + 2]]
                } else {
                    [vertices[i], vertices[i + 2], vertices[i + 1]]
                }
            })
            .collect(),
        // Fan triangle i: (v[i+1], v[i+2], v[0]).
        _ => (0..vertices.len().saturating_sub(2))
            .flat_map(|i| [vertices[i + 1], vertices[i + 2], vertices[0]])
            .collect(),
    };
    let mut mesh = MeshInput {
        positions,
        normals,
        uvs,
        indices,
        colors,
        tangents,
        uvs1,
    };
    match normal_map_set(&primitive.material())? {
        // Tangents serve normal maps only.
        None => mesh.tangents = None,
        Some(set) if mesh.tangents.is_none() => mesh = with_generated_tangents(mesh, set),
        Some(_) => {}
    }
    Ok(Some(mesh))
}

/// The coordinate sets the material's textures read (a normal texture
/// whose transform does not parse is left out: importing the material
/// reports it).
fn texture_sets(material: &gltf::Material) -> Vec<u32> {
    let pbr = material.pbr_metallic_roughness();
    let infos = [
        pbr.base_color_texture(),
        pbr.metallic_roughness_texture(),
        material.emissive_texture(),
    ];
    let mut sets: Vec<u32> = infos
        .iter()
        .flatten()
        .map(|info| TextureRef::of(info).set())
        .collect();
    sets.extend(normal_map_set(material).ok().flatten());
    sets
}

/// The texture coordinate set the material's normal map reads (`None`:
/// the material has no normal map); an error names the material.
fn normal_map_set(material: &gltf::Material) -> Result<Option<u32>, String> {
    match material.normal_texture() {
        Some(normal) => Ok(Some(
            TextureRef::of_normal(&normal)
                .map_err(|m| format!("{}: normalTexture.{m}", material_named(material)))?
                .set(),
        )),
        None => Ok(None),
    }
}

/// How errors and warnings name a material ([`bounds::named`]).
fn material_named(material: &gltf::Material) -> String {
    match material.index() {
        Some(i) => bounds::named("material", &format!("materials[{i}]"), material.name()),
        None => "default material".to_string(),
    }
}

/// `mesh` with MikkTSpace tangents (the algorithm glTF 2.0 names for files
/// without TANGENT) computed from its positions, its normals (the face
/// normal where it has none) and texture coordinate set `set` in the
/// renderer's convention (v up: the bitangent then points up the image,
/// the convention of glTF's normal maps). The algorithm gives each
/// triangle corner its own tangent; a vertex whose corners got different
/// ones (at a uv seam or mirror) is split, one copy per tangent. A mesh
/// with no coordinates of that set, or with non-finite values (which the
/// scene builder refuses anyway), is returned as it is: no tangents, no
/// normal mapping.
fn with_generated_tangents(mesh: MeshInput, set: u32) -> MeshInput {
    let uvs = match set {
        0 => mesh.uvs.as_ref(),
        1 => mesh.uvs1.as_ref(),
        _ => None,
    };
    let Some(uvs) = uvs else { return mesh };
    let finite = mesh.positions.iter().all(|p| p.is_finite())
        && uvs.iter().all(|uv| uv.is_finite())
        && mesh.normals.iter().flatten().all(|n| n.is_finite());
    if !finite {
        return mesh;
    }
    struct Corners<'m> {
        mesh: &'m MeshInput,
        uvs: &'m [Vec2],
        tangents: Vec<Vec4>,
    }
    impl Corners<'_> {
        fn vertex(&self, face: usize, vert: usize) -> usize {
            self.mesh.indices[3 * face + vert] as usize
        }
    }
    impl mikktspace::Geometry for Corners<'_> {
        fn num_faces(&self) -> usize {
            self.mesh.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.mesh.positions[self.vertex(face, vert)].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            match &self.mesh.normals {
                Some(normals) => normals[self.vertex(face, vert)].to_array(),
                None => {
                    let [a, b, c] = [0, 1, 2].map(|v| self.mesh.positions[self.vertex(face, v)]);
                    (b - a).cross(c - a).normalize_or_zero().to_array()
                }
            }
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uvs[self.vertex(face, vert)].to_array()
        }
        fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
            self.tangents[3 * face + vert] = Vec4::from_array(tangent);
        }
    }
    let mut corners = Corners {
        mesh: &mesh,
        uvs,
        tangents: vec![Vec4::ZERO; mesh.indices.len()],
    };
    if !mikktspace::generate_tangents(&mut corners) {
        return mesh;
    }
    let corner_tangents = corners.tangents;
    // Weld corners back: one vertex per (original vertex, tangent).
    let mut first_copy: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut source: Vec<u32> = Vec::new();
    let mut tangents: Vec<Vec4> = Vec::new();
    let indices: Vec<u32> = mesh
        .indices
        .iter()
        .zip(&corner_tangents)
        .map(|(&v, t)| {
            *first_copy
                .entry((v, t.to_array().map(f32::to_bits)))
                .or_insert_with(|| {
                    source.push(v);
                    tangents.push(*t);
                    source.len() as u32 - 1
                })
        })
        .collect();
    let pick = |values: &Vec<Vec3>| source.iter().map(|&v| values[v as usize]).collect();
    let pick2 = |values: &Vec<Vec2>| source.iter().map(|&v| values[v as usize]).collect();
    MeshInput {
        positions: pick(&mesh.positions),
        normals: mesh.normals.as_ref().map(pick),
        uvs: mesh.uvs.as_ref().map(pick2),
        uvs1: mesh.uvs1.as_ref().map(pick2),
        colors: mesh
            .colors
            .as_ref()
            .map(|c| source.iter().map(|&v| c[v as usize]).collect()),
        tangents: Some(tangents),
        indices,
    }
}

/// The accessor's elements, tightly packed, with sparse substitutions applied.
fn accessor_bytes(accessor: &gltf::Accessor, buffers: &[BufferData]) -> Result<Vec<u8>, String> {
    let index = accessor.index();
    let elem = accessor.size();
    let count = accessor.count();
    let total = count
        .checked_mul(elem)
        .ok_or_else(|| format!("accessor {index}: {count} elements overflow"))?;
    let mut out = match accessor.view() {
        Some(view) => {
            let data = view_bytes(&view, buffers)?;
            let stride = view.stride().unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "accessor {index}: byteStride {stride} is smaller than its {elem}-byte element"
                ));
            }
            let start = accessor.offset();
            if count > 0 {
                let end = (count - 1)
                    .checked_mul(stride)
                    .and_then(|s| s.checked_add(start))
                    .and_then(|s| s.checked_add(elem));
                if end.is_none_or(|e| e > data.len()) {
                    return Err(format!(
                        "accessor {index}: {count} elements of {elem} bytes (stride {stride}, offset {start}) reach past the end of bufferView {} ({} bytes)",
                        view.index(),
                        data.len()
                    ));
                }
            }
            let mut out = Vec::with_capacity(total);
            for i in 0..count {
                let s = start + i * stride;
                out.extend_from_slice(&data[s..s + elem]);
            }
            out
        }
        None => {
            if total > MAX_VIEWLESS_ACCESSOR_BYTES {
                return Err(format!(
                    "accessor {index}: {count} elements without a bufferView is implausibly many"
                ));
            }
            vec![0; total]
        }
    };
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let isize = indices.index_type().size();
        let idata = view_bytes(&indices.view(), buffers)?;
        let ibytes = n
            .checked_mul(isize)
            .and_then(|len| Some(indices.offset()..indices.offset().checked_add(len)?))
            .and_then(|r| idata.get(r));
        let ibytes = ibytes.ok_or_else(|| {
            format!(
                "accessor {index}: {n} sparse indices reach past the end of bufferView {}",
                indices.view().index()
            )
        })?;
        let values = sparse.values();
        let vdata = view_bytes(&values.view(), buffers)?;
        let vbytes = n
            .checked_mul(elem)
            .and_then(|len| Some(values.offset()..values.offset().checked_add(len)?))
            .and_then(|r| vdata.get(r));
        let vbytes = vbytes.ok_or_else(|| {
            format!(
                "accessor {index}: {n} sparse values reach past the end of bufferView {}",
                values.view().index()
            )
        })?;
        for (k, (ib, vb)) in ibytes
            .chunks_exact(isize)
            .zip(vbytes.chunks_exact(elem))
            .enumerate()
        {
            let target = ib
                .iter()
                .rev()
                .fold(0usize, |acc, &b| acc << 8 | b as usize);
            if target >= count {
                return Err(format!("accessor {index}: sparse index {k} is {target}, out of range for {count} elements"));
            }
            out[target * elem..(target + 1) * elem].copy_from_slice(vb);
        }
    }
    Ok(out)
}

fn view_bytes<'b>(
    view: &gltf::buffer::View,
    buffers: &'b [BufferData],
) -> Result<&'b [u8], String> {
    let buffer = buffers.get(view.buffer().index()).ok_or_else(|| {
        format!(
            "bufferView {}: buffer {} is not loaded",
            view.index(),
            view.buffer().index()
        )
    })?;
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "bufferView {} reaches past the end of buffer {}",
                view.index(),
                view.buffer().index()
            )
        })
}

/// Reads an accessor of the given shape as floats (normalized integers as
/// the glTF spec maps them to [0, 1] or [-1, 1]).
fn read_floats(
    accessor: &gltf::Accessor,
    buffers: &[BufferData],
    what: &str,
    shape: Dimensions,
) -> Result<Vec<f32>, String> {
    if accessor.dimensions() != shape {
        return Err(format!(
            "{what} accessor {} is {:?}, expected {shape:?}",
            accessor.index(),
            accessor.dimensions()
        ));
    }
    let bytes = accessor_bytes(accessor, buffers).map_err(|m| format!("{what}: {m}"))?;
    let normalized = accessor.normalized();
    let size = accessor.data_type().size();
    let component = |c: &[u8]| -> f32 {
        match accessor.data_type() {
            DataType::F32 => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
            DataType::U8 if normalized => c[0] as f32 / 255.0,
            DataType::U8 => c[0] as f32,
            DataType::I8 if normalized => (c[0] as i8 as f32 / 127.0).max(-1.0),
            DataType::I8 => c[0] as i8 as f32,
            DataType::U16 if normalized => u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0,
            DataType::U16 => u16::from_le_bytes([c[0], c[1]]) as f32,
            DataType::I16 if normalized => {
                (i16::from_le_bytes([c[0], c[1]]) as f32 / 32767.0).max(-1.0)
            }
            DataType::I16 => i16::from_le_bytes([c[0], c[1]]) as f32,
            DataType::U32 if normalized => {
                (u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64 / u32::MAX as f64) as f32
            }
            DataType::U32 => u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f32,
        }
    };
    Ok(bytes.chunks_exact(size).map(component).collect())
}

fn read_indices(accessor: &gltf::Accessor, buffers: &[BufferData]) -> Result<Vec<u32>, String> {
    let data_type = accessor.data_type();
    if accessor.dimensions() != Dimensions::Scalar
        || !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "indices accessor {} is {:?} of {data_type:?}, expected scalar unsigned integers",
            accessor.index(),
            accessor.dimensions()
        ));
    }
    let bytes = accessor_bytes(accessor, buffers).map_err(|m| format!("indices: {m}"))?;
    Ok(match data_type {
        DataType::U8 => bytes.iter().map(|&b| b as u32).collect(),
        DataType::U16 => bytes
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
            .collect(),
        _ => bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    })
}

fn flip_winding(indices: &mut [u32]) {
    for tri in indices.chunks_exact_mut(3) {
        tri.swap(1, 2);
    }
}

/// The primitive in world space (winding reversed under a mirroring matrix).
fn place(local: &MeshInput, world: &DAffine3) -> MeshInput {
    let transform = Transform { matrix: *world };
    let normal_matrix = transform.normal_matrix();
    let mut indices = local.indices.clone();
    if transform.mirrors() {
        flip_winding(&mut indices);
    }
    MeshInput {
        positions: local
            .positions
            .iter()
            .map(|&p| transform.point(p))
            .collect(),
        // Under a pure translation the normals are kept bit for bit.
        normals: local.normals.as_ref().map(|ns| {
            if world.matrix3 == DMat3::IDENTITY {
                ns.clone()
            } else {
                ns.iter()
                    .map(|&n| (normal_matrix * n).normalize_or_zero())
                    .collect()
            }
        }),
        uvs: local.uvs.clone(),
        indices,
        ..MeshInput::default()
    }
}

/// Unwelds a mesh into three vertices per triangle carrying its face normal.
fn flat_shaded(mesh: MeshInput) -> MeshInput {
    let mut out = MeshInput {
        positions: Vec::new(),
        normals: Some(Vec::new()),
        uvs: mesh.uvs.as_ref().map(|_| Vec::new()),
        ..MeshInput::default()
    };
    let normals = out.normals.get_or_insert_with(Vec::new);
    for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        for &i in tri {
            out.positions.push(mesh.positions[i as usize]);
            normals.push(n);
            if let (Some(dst), Some(src)) = (out.uvs.as_mut(), mesh.uvs.as_ref()) {
                dst.push(src[i as usize]);
            }
        }
        let base = 3 * t as u32;
        out.indices.extend([base, base + 1, base + 2]);
    }
    out
}

/// Concatenates placed primitives into one mesh (see [`load_gltf_mesh`]).
fn merge(parts: Vec<MeshInput>) -> Result<MeshInput, String> {
    let any_normals = parts.iter().any(|p| p.normals.is_some());
    let any_uvs = parts.iter().any(|p| p.uvs.is_some());
    let mut out = MeshInput {
        positions: Vec::new(),
        normals: any_normals.then(Vec::new),
        uvs: any_uvs.then(Vec::new),
        ..MeshInput::default()
    };
    for part in parts {
        let part = if any_normals && part.normals.is_none() {
            flat_shaded(part)
        } else {
            part
        };
        if out.positions.len() + part.positions.len() > u32::MAX as usize {
            return Err("the merged mesh has more than 2^32 vertices".into());
        }
        let base = out.positions.len() as u32;
        out.indices.extend(part.indices.iter().map(|&i| base + i));
        if let Some(normals) = out.normals.as_mut() {
            normals.extend(part.normals.iter().flatten());
        }
        if let Some(uvs) = out.uvs.as_mut() {
            match &part.uvs {
                Some(src) => uvs.extend(src),
                None => uvs.extend(std::iter::repeat_n(Vec2::ZERO, part.positions.len())),
            }
        }
        out.positions.extend(part.positions);
    }
    Ok(out)
}

/// Materials, textures and images added so far, by glTF index.
struct Importer<'f> {
    file: &'f GltfFile,
    /// (glTF image index, decoding) → builder image.
    images: HashMap<(usize, Decoding), u32>,
    /// (glTF texture index, factor bits, decoding, transform bits,
    /// coordinate set) → builder texture.
    #[allow(clippy::type_complexity)]
    textures: HashMap<(usize, [u32; 3], Decoding, Option<[u32; 6]>, u32), u32>,
    /// glTF material index (`None`: the default material) → builder material.
    materials: HashMap<Option<usize>, u32>,
}

impl Importer<'_> {
    fn material(
        &mut self,
        builder: &mut SceneBuilder,
        material: gltf::Material,
    ) -> Result<u32, SceneError> {
        let key = material.index();
        if let Some(&id) = self.materials.get(&key) {
            return Ok(id);
        }
        let context = material_named(&material);
        let file = self.file;
        let in_context = |e: SceneError| e.within(&context).in_file(&file.path);
        let fail = |m: String| file.error(format!("{context}: {m}"));
        // Every number the specification bounds, before anything is made
        // of them: an error names the field, not what it became.
        bounds::material(&material).map_err(fail)?;
        let pbr = material.pbr_metallic_roughness();
        let emission =
            Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0);
        let glass = self
            .dielectric(builder, &material, &context)
            .map_err(fail)?;
        // Added to the BSDF below: the surface keeps what it reflects.
        let emission = if emission != Vec3::ZERO {
            Some(self.factored_texture(
                builder,
                material.emissive_texture(),
                (emission, Decoding::Srgb),
                &context,
                ("emissiveTexture", "emissiveFactor"),
            )?)
        } else {
            None
        };
        let converted = if let Some(glass) = glass {
            glass
        } else {
            let [r, g, b, _alpha] = pbr.base_color_factor();
            let factor = Vec3::new(r, g, b);
            let texture = self.factored_texture(
                builder,
                pbr.base_color_texture(),
                (factor, Decoding::Srgb),
                &context,
                ("pbrMetallicRoughness.baseColorTexture", "baseColorFactor"),
            )?;
            let metallic_roughness = match pbr.metallic_roughness_texture() {
                Some(info) => Some(self.data_texture(
                    builder,
                    &TextureRef::of(&info),
                    &context,
                    "pbrMetallicRoughness.metallicRoughnessTexture",
                )?),
                None => None,
            };
            let normal_map = match material.normal_texture() {
                Some(normal) => {
                    let texture = TextureRef::of_normal(&normal)
                        .map_err(|m| file.error(format!("{context}: normalTexture.{m}")))?;
                    Some(NormalMap {
                        texture: self.data_texture(builder, &texture, &context, "normalTexture")?,
                        scale: normal.scale(),
                    })
                }
                None => None,
            };
            Material::Ggx {
                base_color: texture,
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                metallic_roughness,
                normal_map,
                clearcoat: self.clearcoat(builder, &material, &context)?,
            }
        };
        use gltf::material::AlphaMode as Mode;
        let mode = match material.alpha_mode() {
            Mode::Opaque => None,
            // The cutoff is checked with the other numbers above.
            Mode::Mask => Some(AlphaMode::Mask {
                cutoff: material.alpha_cutoff().unwrap_or(0.5),
            }),
            Mode::Blend => Some(AlphaMode::Blend),
        };
        let alpha = match mode {
            Some(mode) => Some(Alpha {
                texture: self.alpha_texture(builder, &material, &context)?,
                mode,
            }),
            None => None,
        };
        if !matches!(converted, Material::Ggx { .. }) {
            let kind = "the dielectric";
            let ignored = [
                ("normalTexture", material.normal_texture().is_some()),
                (CLEARCOAT, material.extension_value(CLEARCOAT).is_some()),
            ];
            let lost: Vec<String> = ignored
                .iter()
                .filter(|(_, present)| *present)
                .map(|(what, _)| format!("{what} ignored on {kind}"))
                .collect();
            self.warn(builder, &context, &lost);
        }
        let id = builder.add_material(converted).map_err(in_context)?;
        if let Some(emission) = emission {
            builder
                .set_emission(id, emission)
                .map_err(|e| in_context(e.within("emissiveFactor")))?;
        }
        if let Some(alpha) = alpha {
            builder
                .set_alpha(id, alpha)
                .map_err(|e| in_context(e.within("alphaMode")))?;
        }
        self.materials.insert(key, id);
        Ok(id)
    }

    /// The texture whose first channel is the material's alpha: the base
    /// colour texture's alpha channel (linear, with the base colour's
    /// sampler, transform and coordinate set) times `baseColorFactor`'s
    /// alpha, or that factor alone. The vertex colour's alpha multiplies
    /// it at each hit ([`Scene::alpha_covers`]).
    fn alpha_texture(
        &mut self,
        builder: &mut SceneBuilder,
        material: &gltf::Material,
        context: &str,
    ) -> Result<u32, SceneError> {
        let pbr = material.pbr_metallic_roughness();
        let factor = Vec3::splat(pbr.base_color_factor()[3]);
        self.factored_texture(
            builder,
            pbr.base_color_texture(),
            (factor, Decoding::Alpha),
            context,
            ("pbrMetallicRoughness.baseColorTexture", "baseColorFactor"),
        )
    }

    /// glTF's "texture times factor": the texture `info` refers to,
    /// decoded by `decoding`, times `factor`, or the constant `factor`
    /// where the material has no texture there. An error names the
    /// material's member (`fields`: the texture's, the factor's).
    fn factored_texture(
        &mut self,
        builder: &mut SceneBuilder,
        info: Option<gltf::texture::Info>,
        (factor, decoding): (Vec3, Decoding),
        context: &str,
        (texture_field, factor_field): (&str, &str),
    ) -> Result<u32, SceneError> {
        match info {
            Some(info) => self.texture(
                builder,
                &TextureRef::of(&info),
                factor,
                decoding,
                context,
                texture_field,
            ),
            None => builder.constant(factor).map_err(|e| {
                e.within(factor_field)
                    .within(context)
                    .in_file(&self.file.path)
            }),
        }
    }

    /// `KHR_materials_clearcoat` as the GGX material's [`ClearCoat`]
    /// (`None` where the extension is absent or its factor is 0). The
    /// `gltf` crate has no typed accessor, so the object is read as JSON:
    /// the factors must be numbers in [0, 1] and the textures' references
    /// valid, like any texture's. `clearcoatNormalTexture` is one warning
    /// line: the coat shares the base's shading normal.
    fn clearcoat(
        &mut self,
        builder: &mut SceneBuilder,
        material: &gltf::Material,
        context: &str,
    ) -> Result<Option<ClearCoat>, SceneError> {
        let Some(value) = material.extension_value(CLEARCOAT) else {
            return Ok(None);
        };
        let file = self.file;
        let error = |m: String| file.error(format!("{context}: extensions.{CLEARCOAT}{m}"));
        let object = value
            .as_object()
            .ok_or_else(|| error(" is not an object".into()))?;
        // Both factors in [0, 1] (the extension's schema).
        let factor = |name: &str| match object.get(name) {
            None => Ok(0.0),
            Some(v) => {
                let x = v
                    .as_f64()
                    .ok_or_else(|| error(format!(".{name} {v} is not a number")))?
                    as f32;
                bounds::number(name, x, bounds::Range::Unit).map_err(|m| error(format!(".{m}")))?;
                Ok(x)
            }
        };
        let weight = factor("clearcoatFactor")?;
        let roughness = factor("clearcoatRoughnessFactor")?;
        let texture =
            self.extension_texture(builder, object, CLEARCOAT, "clearcoatTexture", context)?;
        let roughness_texture = self.extension_texture(
            builder,
            object,
            CLEARCOAT,
            "clearcoatRoughnessTexture",
            context,
        )?;
        if object.contains_key("clearcoatNormalTexture") {
            self.warn(
                builder,
                context,
                &[format!(
                    "{CLEARCOAT}.clearcoatNormalTexture ignored (the coat follows the base's shading normal)"
                )],
            );
        }
        if weight == 0.0 {
            return Ok(None);
        }
        Ok(Some(ClearCoat {
            factor: weight,
            texture,
            roughness,
            roughness_texture,
        }))
    }

    /// A data texture extension `extension` names by a glTF `textureInfo`
    /// object (`index`, `texCoord`, its own `KHR_texture_transform`) in
    /// member `name` of its `object`, read as JSON; `None` where the member
    /// is absent.
    fn extension_texture(
        &mut self,
        builder: &mut SceneBuilder,
        object: &serde_json::Map<String, serde_json::Value>,
        extension: &str,
        name: &str,
        context: &str,
    ) -> Result<Option<u32>, SceneError> {
        let Some(info) = object.get(name) else {
            return Ok(None);
        };
        let file = self.file;
        let slot = format!("extensions.{extension}.{name}");
        let error = |m: String| file.error(format!("{context}: {slot}{m}"));
        let index = |key: &str| -> Result<Option<u32>, SceneError> {
            match info.get(key) {
                None => Ok(None),
                Some(v) => v
                    .as_u64()
                    .and_then(|i| u32::try_from(i).ok())
                    .map(Some)
                    .ok_or_else(|| error(format!(".{key} {v} is not an index"))),
            }
        };
        if !info.is_object() {
            return Err(error(format!(" {info} is not a textureInfo object")));
        }
        let Some(i) = index("index")? else {
            return Err(error(" has no index".into()));
        };
        let texture = file
            .document
            .textures()
            .nth(i as usize)
            .ok_or_else(|| error(format!(".index {i}: texture {i} does not exist")))?;
        let transform = UvTransform::of_extension(
            info.get("extensions")
                .and_then(|e| e.get(TEXTURE_TRANSFORM)),
        )
        .map_err(|m| error(format!(".{m}")))?;
        let reference = TextureRef {
            texture,
            tex_coord: index("texCoord")?.unwrap_or(0),
            transform,
        };
        Ok(Some(
            self.data_texture(builder, &reference, context, &slot)?,
        ))
    }

    /// `KHR_materials_transmission` as the reference's smooth dielectric,
    /// with `KHR_materials_ior`'s index (1.5 without it) and, where
    /// `KHR_materials_volume` gives the material a thickness, its
    /// Beer-Lambert absorption `-ln(attenuationColor) / attenuationDistance`
    /// per unit length; `None` for a material that transmits nothing (no
    /// extension, a zero factor, or fully metallic). What the dielectric
    /// cannot show (partial or textured transmission, roughness, the base
    /// colour's tint, a thin wall) is one warning line per material. An
    /// `ior` on an opaque material is a warning too: the GGX material's
    /// dielectric F0 is 0.04 (ior 1.5).
    fn dielectric(
        &self,
        builder: &mut SceneBuilder,
        material: &gltf::Material,
        context: &str,
    ) -> Result<Option<Material>, String> {
        let pbr = material.pbr_metallic_roughness();
        // In range ([`bounds::material`]): 1 and above, or 0.
        let ior = material.ior();
        let transmission = material
            .transmission()
            .filter(|t| t.transmission_factor() > 0.0 && pbr.metallic_factor() < 1.0);
        let mut lost: Vec<String> = Vec::new();
        let Some(transmission) = transmission else {
            if let Some(ior) = ior.filter(|&i| i != 1.5) {
                lost.push(format!(
                    "KHR_materials_ior {ior} ignored on an opaque material (its specular F0 stays 0.04, ior 1.5)"
                ));
            }
            self.warn(builder, context, &lost);
            return Ok(None);
        };
        if ior == Some(0.0) {
            return Err(
                "extensions.KHR_materials_ior.ior 0 (an infinite index) cannot be a transmissive material's"
                    .into(),
            );
        }
        let mut absorption = Vec3::ZERO;
        match material.volume() {
            Some(v) if v.thickness_factor() > 0.0 => {
                // Above 0, or infinite (no absorption): [`bounds::material`].
                let distance = v.attenuation_distance();
                if distance.is_finite() {
                    // A channel that keeps nothing (colour 0) is given
                    // 1e-6 of its light per attenuationDistance: opaque
                    // in practice, and a finite coefficient.
                    let colour =
                        Vec3::from(v.attenuation_color()).clamp(Vec3::splat(1e-6), Vec3::ONE);
                    absorption = -Vec3::from(colour.to_array().map(f32::ln)) / distance;
                    // Each term is at most ln(1e6) ≈ 13.8 over the
                    // distance: a distance below about 4e-38 (in range,
                    // above 0) overflows it.
                    if !absorption.is_finite() {
                        return Err(format!(
                            "extensions.KHR_materials_volume.attenuationDistance {} is too small: with attenuationColor {} the absorption −ln(colour) / distance is beyond the range of a 32-bit float",
                            bounds::show(distance),
                            bounds::show_all(&v.attenuation_color())
                        ));
                    }
                }
            }
            _ => lost.push(
                "thin-walled (no KHR_materials_volume thickness): rendered as solid glass".into(),
            ),
        }
        let factor = transmission.transmission_factor();
        if factor < 1.0 {
            lost.push(format!(
                "transmissionFactor {factor} rendered as 1 (the dielectric transmits fully)"
            ));
        }
        if transmission.transmission_texture().is_some() {
            lost.push("transmissionTexture ignored".into());
        }
        if pbr.roughness_factor() > 0.0 || pbr.metallic_roughness_texture().is_some() {
            lost.push(format!(
                "roughness {} rendered smooth (the dielectric is smooth)",
                pbr.roughness_factor()
            ));
        }
        if pbr.metallic_factor() > 0.0 {
            lost.push(format!("metallicFactor {} ignored", pbr.metallic_factor()));
        }
        let [r, g, b, _] = pbr.base_color_factor();
        if Vec3::new(r, g, b) != Vec3::ONE || pbr.base_color_texture().is_some() {
            lost.push("the base colour's tint of transmitted light ignored".into());
        }
        self.warn(builder, context, &lost);
        Ok(Some(Material::Dielectric {
            ior: ior.unwrap_or(1.5),
            absorption,
        }))
    }

    /// One warning line for `context` listing what was not imported.
    fn warn(&self, builder: &mut SceneBuilder, context: &str, lost: &[String]) {
        if !lost.is_empty() {
            builder.warnings.push(format!(
                "{}: {context}: {}",
                self.file.path.display(),
                lost.join("; ")
            ));
        }
    }

    /// A data texture (linear texels: metallic-roughness, normals),
    /// factor 1.
    fn data_texture(
        &mut self,
        builder: &mut SceneBuilder,
        texture: &TextureRef,
        context: &str,
        slot: &str,
    ) -> Result<u32, SceneError> {
        self.texture(builder, texture, Vec3::ONE, Decoding::Linear, context, slot)
    }

    /// The texture `texture` names with its sampler, transform and
    /// coordinate set: a set other than 0 and 1 is a warning (TEXCOORD_0
    /// is read). `slot` is the material's member that refers to it
    /// (`normalTexture`), for errors in its transform.
    fn texture(
        &mut self,
        builder: &mut SceneBuilder,
        reference: &TextureRef,
        factor: Vec3,
        decoding: Decoding,
        context: &str,
        slot: &str,
    ) -> Result<u32, SceneError> {
        if let Some(t) = &reference.transform {
            bounds::transform(slot, t).map_err(|m| self.file.error(format!("{context}: {m}")))?;
        }
        let texture = &reference.texture;
        let mut set = reference.set();
        if set > 1 {
            self.warn(
                builder,
                context,
                &[format!(
                    "texture {} reads TEXCOORD_{set}: TEXCOORD_0 is used (sets 0 and 1 are read)",
                    texture.index()
                )],
            );
            set = 0;
        }
        let mut sampler = sampler(texture, reference.transform.as_ref());
        sampler.tex_coord = set;
        let key = (
            texture.index(),
            factor.to_array().map(f32::to_bits),
            decoding,
            sampler.transform.map(|t| t.map(f32::to_bits)),
            set,
        );
        if let Some(&id) = self.textures.get(&key) {
            return Ok(id);
        }
        let image = self.image(builder, &texture.source(), decoding)?;
        let id = builder
            .add_texture(Texture::Image {
                image,
                factor,
                sampler,
            })
            .map_err(|e| {
                e.within(&format!("textures[{}]", texture.index()))
                    .in_file(&self.file.path)
            })?;
        self.textures.insert(key, id);
        Ok(id)
    }

    /// Image `image` decoded to linear RGB as `decoding` says, added once
    /// per decoding.
    fn image(
        &mut self,
        builder: &mut SceneBuilder,
        image: &gltf::Image,
        decoding: Decoding,
    ) -> Result<u32, SceneError> {
        let index = image.index();
        if let Some(&id) = self.images.get(&(index, decoding)) {
            return Ok(id);
        }
        let file = self.file;
        // `Image::source` unwraps fields that validation does not require.
        let json = file
            .document
            .as_json()
            .images
            .get(index)
            .ok_or_else(|| file.error(format!("image {index} does not exist")))?;
        let source = match (&json.buffer_view, &json.mime_type, &json.uri) {
            (Some(_), None, _) => {
                return Err(file.error(format!(
                    "image {index} is stored in a bufferView but has no mimeType"
                )))
            }
            (None, _, None) => {
                return Err(file.error(format!("image {index} has neither a uri nor a bufferView")))
            }
            (Some(view), Some(_), _) => format!("bufferView {}", view.value()),
            (None, _, Some(uri)) if uri.starts_with("data:") => "a data: URI".to_string(),
            (None, _, Some(uri)) => format!("`{}`", file.base.join(uri).display()),
        };
        if let (None, Some(uri)) = (&json.buffer_view, &json.uri) {
            builder.sources.extend(uri_file(&file.base, uri));
        }
        let decoded =
            gltf::image::Data::from_source(image.source(), Some(&file.base), &file.buffers)
                .map_err(|e| {
                    file.error(format!("cannot decode image {index} from {source}: {e}"))
                })?;
        // An image without alpha is opaque: one texel says so.
        let opaque = decoding == Decoding::Alpha && !has_alpha_channel(decoded.format);
        let data = if opaque {
            Ok(ImageData {
                width: 1,
                height: 1,
                texels: vec![Vec3::ONE],
            })
        } else {
            convert_image(&decoded, decoding)
        }
        .map_err(|m| file.error(format!("image {index} from {source}: {m}")))?;
        let id = builder.add_image(data);
        self.images.insert((index, decoding), id);
        Ok(id)
    }
}

/// The renderer's sampler for glTF `texture` (its wrap modes and
/// magnification filter; minification filters name mipmaps, which the
/// renderer does not build: it filters as the magnification filter says)
/// and a `KHR_texture_transform`, rewritten for the renderer's uv
/// convention (v up, `v = 1 - v_glTF`). With `c, s` the rotation's cosine
/// and sine, glTF's map is `u' = c·sx·u + s·sy·v + ox`,
/// `v' = −s·sx·u + c·sy·v + oy` (scale, then rotate, then offset; the
/// rotation's sign is the one that makes the extension's own example,
/// offset (0, 1), rotation π/2, scale ½, read "the lower left quadrant of
/// the image, rotated clockwise 90°"); in the renderer's convention
/// `u' = c·sx·u − s·sy·v + (ox + s·sy)`,
/// `v' = s·sx·u + c·sy·v + (1 − c·sy − oy)` (computed in f64).
fn sampler(texture: &gltf::Texture, transform: Option<&UvTransform>) -> crate::texture::Sampler {
    use crate::texture::{Sampler, Wrap};
    use gltf::texture::{MagFilter, WrappingMode};
    let wrap = |m: WrappingMode| match m {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
    };
    let s = texture.sampler();
    Sampler {
        wrap_u: wrap(s.wrap_s()),
        wrap_v: wrap(s.wrap_t()),
        nearest: s.mag_filter() == Some(MagFilter::Nearest),
        transform: transform.map(uv_matrix),
        tex_coord: 0,
    }
}

/// The name of the clear coat extension.
const CLEARCOAT: &str = "KHR_materials_clearcoat";

/// A material's reference to a texture: which texture, which coordinate
/// set, and its transform.
struct TextureRef<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    transform: Option<UvTransform>,
}

impl<'a> TextureRef<'a> {
    fn of(info: &gltf::texture::Info<'a>) -> Self {
        TextureRef {
            texture: info.texture(),
            tex_coord: info.tex_coord(),
            transform: UvTransform::of_info(info),
        }
    }

    fn of_normal(normal: &gltf::material::NormalTexture<'a>) -> Result<Self, String> {
        Ok(TextureRef {
            texture: normal.texture(),
            tex_coord: normal.tex_coord(),
            transform: UvTransform::of_extension(normal.extension_value(TEXTURE_TRANSFORM))?,
        })
    }

    /// The coordinate set read: the transform's override, else the
    /// reference's own.
    fn set(&self) -> u32 {
        self.transform
            .and_then(|t| t.tex_coord)
            .unwrap_or(self.tex_coord)
    }
}

/// How an image's texels are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Decoding {
    /// Colour (base colour, emission): integer channels are sRGB-encoded.
    Srgb,
    /// Data (metallic-roughness, normals): integer channels are linear.
    Linear,
    /// The alpha channel (linear, as grey; 1 where the image has none).
    Alpha,
}

/// Whether an image of this format has an alpha channel.
fn has_alpha_channel(format: gltf::image::Format) -> bool {
    use gltf::image::Format;
    matches!(
        format,
        Format::R8G8
            | Format::R8G8B8A8
            | Format::R16G16
            | Format::R16G16B16A16
            | Format::R32G32B32A32FLOAT
    )
}

/// Converts a decoded glTF image to linear RGB as `decoding` says. Row 0
/// stays the top row.
fn convert_image(image: &gltf::image::Data, decoding: Decoding) -> Result<ImageData, String> {
    let srgb = decoding == Decoding::Srgb;
    use gltf::image::Format;
    let (channels, bytes_per_channel) = match image.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Err(format!("empty image ({w}x{h})"));
    }
    let texel_bytes = channels * bytes_per_channel;
    let expected = (w as usize)
        .checked_mul(h as usize)
        .and_then(|n| n.checked_mul(texel_bytes));
    if expected != Some(image.pixels.len()) || (w as u64 * h as u64) > u32::MAX as u64 {
        return Err(format!(
            "{w}x{h} {:?} image with {} bytes of pixels",
            image.format,
            image.pixels.len()
        ));
    }
    let lut: Vec<f32> = (0..=255).map(|i| decode_8bit(i, srgb)).collect();
    let channel = |c: &[u8]| -> f32 {
        match bytes_per_channel {
            1 => lut[c[0] as usize],
            2 => {
                let v = u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0;
                if srgb {
                    srgb_to_linear(v)
                } else {
                    v
                }
            }
            _ => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
        }
    };
    let texels = image
        .pixels
        .chunks_exact(texel_bytes)
        .map(|t| {
            let c: Vec<f32> = t.chunks_exact(bytes_per_channel).map(channel).collect();
            if decoding == Decoding::Alpha {
                // Grey with alpha, or RGBA: the last channel.
                return Vec3::splat(if channels % 2 == 0 {
                    c[channels - 1]
                } else {
                    1.0
                });
            }
            // One or two channels: grey (with alpha).
            if channels < 3 {
                Vec3::splat(c[0])
            } else {
                Vec3::new(c[0], c[1], c[2])
            }
        })
        .collect();
    Ok(ImageData {
        width: w,
        height: h,
        texels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Sampler;
    use std::io::Write;

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.join(name);
        std::fs::File::create(&path)
            .unwrap()
            .write_all(bytes)
            .unwrap();
        path
    }

    fn b64(data: &[u8]) -> String {
        const ALPHABET: &[u8; 64] =
            b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for chunk in data.chunks(3) {
            let b = [
                chunk[0],
                chunk.get(1).copied().unwrap_or(0),
                chunk.get(2).copied().unwrap_or(0),
            ];
            let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
            for k in 0..4 {
                if k <= chunk.len() {
                    s.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    s.push('=');
                }
            }
        }
        s
    }

    fn f32_bytes(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// A document with one buffer (as a data: URI) and the given extra JSON.
    fn gltf_with(buffer: &[u8], body: serde_json::Value) -> Vec<u8> {
        let mut doc = body;
        doc["asset"] = serde_json::json!({ "version": "2.0" });
        doc["buffers"] = serde_json::json!([{ "byteLength": buffer.len(), "uri": format!("data:application/octet-stream;base64,{}", b64(buffer)) }]);
        serde_json::to_vec(&doc).unwrap()
    }

    fn unit_triangle() -> Vec<u8> {
        f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0])
    }

    fn triangle_doc(node: serde_json::Value, accessor_extra: serde_json::Value) -> Vec<u8> {
        let mut accessor = serde_json::json!({ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] });
        if let serde_json::Value::Object(extra) = accessor_extra {
            for (k, v) in extra {
                accessor[k] = v;
            }
        }
        gltf_with(
            &unit_triangle(),
            serde_json::json!({
                "scene": 0,
                "scenes": [{ "nodes": [0] }],
                "nodes": [node],
                "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
                "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
                "accessors": [accessor],
            }),
        )
    }

    /// The triangle document with `extensionsUsed` and `extensionsRequired`.
    fn with_extensions(used: &[&str], required: &[&str]) -> Vec<u8> {
        let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
            serde_json::json!({ "mesh": 0 }),
            serde_json::Value::Null,
        ))
        .unwrap();
        doc["extensionsUsed"] = serde_json::json!(used);
        if !required.is_empty() {
            doc["extensionsRequired"] = serde_json::json!(required);
        }
        serde_json::to_vec(&doc).unwrap()
    }

    #[test]
    fn required_extensions_the_importer_lacks_are_an_error_naming_them() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "draco.gltf",
            &with_extensions(
                &[
                    "KHR_draco_mesh_compression",
                    "KHR_materials_emissive_strength",
                ],
                &["KHR_draco_mesh_compression"],
            ),
        );
        let Err(e) = load_gltf_document(&p) else {
            panic!("a required extension the importer lacks was accepted");
        };
        let e = e.to_string();
        assert!(
            e.contains("draco.gltf")
                && e.contains(
                    "extensionsRequired[0] = \"KHR_draco_mesh_compression\": not supported by twintrace"
                )
                && !e.contains('\n'),
            "{e}"
        );
        assert!(load_gltf_mesh(&p).is_err());
        // Each required extension the importer has is fine, all at once
        // too (the `gltf` crate alone refuses KHR_lights_punctual,
        // KHR_materials_volume and KHR_materials_clearcoat when required).
        let mut lists: Vec<Vec<&str>> = SUPPORTED_EXTENSIONS.iter().map(|&e| vec![e]).collect();
        lists.push(SUPPORTED_EXTENSIONS.to_vec());
        for list in lists {
            let p = write(dir.path(), "required.gltf", &with_extensions(&list, &list));
            let scene = load_gltf_document(&p).unwrap_or_else(|e| panic!("{list:?}: {e}"));
            assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
        }
        // Among others, each unsupported entry is named by its place.
        let p = write(
            dir.path(),
            "two.gltf",
            &with_extensions(
                &[
                    "KHR_lights_punctual",
                    "EXT_meshopt_compression",
                    "KHR_materials_unlit",
                ],
                &[
                    "KHR_lights_punctual",
                    "EXT_meshopt_compression",
                    "KHR_materials_unlit",
                ],
            ),
        );
        let e = load_gltf_document(&p).err().unwrap().to_string();
        assert!(
            e.contains("extensionsRequired[1] = \"EXT_meshopt_compression\", extensionsRequired[2] = \"KHR_materials_unlit\": not supported by twintrace")
                && !e.contains("[0]"),
            "{e}"
        );
    }

    #[test]
    fn used_extensions_the_importer_lacks_are_one_warning() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "sheen.gltf",
            &with_extensions(&["KHR_materials_sheen", "KHR_materials_specular"], &[]),
        );
        let scene = load_gltf_document(&p).unwrap();
        assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
        let w = &scene.warnings()[0];
        assert!(
            w.contains("sheen.gltf") && w.contains("KHR_materials_sheen, KHR_materials_specular"),
            "{w}"
        );
    }

    #[test]
    fn node_transforms_apply_and_mirrors_flip_winding() {
        let dir = tempfile::tempdir().unwrap();
        let plain = write(
            dir.path(),
            "plain.gltf",
            &triangle_doc(serde_json::json!({ "mesh": 0 }), serde_json::Value::Null),
        );
        let m = load_gltf_mesh(&plain).unwrap();
        assert_eq!(m.indices, vec![0, 1, 2]);
        assert_eq!(m.normals, None);
        let moved = write(
            dir.path(),
            "moved.gltf",
            &triangle_doc(
                serde_json::json!({ "children": [1], "translation": [0, 0, 5] }),
                serde_json::Value::Null,
            ),
        );
        // Add the child node holding the mesh, mirrored in x and scaled by 2.
        let mut doc: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&moved).unwrap()).unwrap();
        doc["nodes"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!({ "mesh": 0, "scale": [-2, 2, 2] }));
        std::fs::write(&moved, serde_json::to_vec(&doc).unwrap()).unwrap();
        let m = load_gltf_mesh(&moved).unwrap();
        assert_eq!(
            m.positions,
            vec![
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(-2.0, 0.0, 5.0),
                Vec3::new(0.0, 2.0, 5.0)
            ]
        );
        assert_eq!(
            m.indices,
            vec![0, 2, 1],
            "a mirroring node reverses the winding"
        );
        // The placed triangle still faces +z, like the original.
        let [a, b, c] = [0, 2, 1].map(|i| m.positions[i]);
        assert!((b - a).cross(c - a).z > 0.0);
    }

    #[test]
    fn strips_fans_and_non_indexed_primitives() {
        let dir = tempfile::tempdir().unwrap();
        let quad = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0]);
        for (mode, expect) in [
            (5, vec![0, 1, 2, 1, 3, 2]),
            (6, vec![1, 2, 0, 2, 3, 0]),
            (0, vec![]),
            (1, vec![]),
        ] {
            let doc = gltf_with(
                &quad,
                serde_json::json!({
                    "scenes": [{ "nodes": [0] }],
                    "nodes": [{ "mesh": 0 }],
                    "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": mode }] }],
                    "bufferViews": [{ "buffer": 0, "byteLength": 48 }],
                    "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
                }),
            );
            let path = write(dir.path(), &format!("mode{mode}.gltf"), &doc);
            match load_gltf_mesh(&path) {
                Ok(m) => assert_eq!(m.indices, expect, "mode {mode}"),
                Err(e) => {
                    assert!(expect.is_empty(), "mode {mode}: {e}");
                    assert!(e.to_string().contains("no triangles"), "{e}");
                }
            }
        }
    }

    #[test]
    fn malformed_documents_are_errors_not_panics() {
        let dir = tempfile::tempdir().unwrap();
        let cases: Vec<(&str, Vec<u8>, &str)> = vec![
            ("empty.glb", Vec::new(), "cannot read glTF"),
            (
                "short-header.glb",
                b"glTF\x02\x00\x00\x00\x04\x00\x00\x00".to_vec(),
                "not a valid GLB",
            ),
            (
                "long-header.glb",
                b"glTF\x02\x00\x00\x00\xff\xff\xff\xff\x00\x00\x00\x00".to_vec(),
                "not a valid GLB",
            ),
            (
                "version.glb",
                b"glTF\x01\x00\x00\x00\x14\x00\x00\x00\x00\x00\x00\x00JSON".to_vec(),
                "version 1",
            ),
            ("garbage.gltf", b"{ not json".to_vec(), "cannot read glTF"),
            (
                "zero-count.gltf",
                triangle_doc(
                    serde_json::json!({ "mesh": 0 }),
                    serde_json::json!({ "count": 0 }),
                ),
                "no triangles",
            ),
            (
                "overrun.gltf",
                triangle_doc(
                    serde_json::json!({ "mesh": 0 }),
                    serde_json::json!({ "count": 4 }),
                ),
                "reach past the end",
            ),
            (
                "offset.gltf",
                triangle_doc(
                    serde_json::json!({ "mesh": 0 }),
                    serde_json::json!({ "byteOffset": 4 }),
                ),
                "reach past the end",
            ),
            (
                "shape.gltf",
                triangle_doc(
                    serde_json::json!({ "mesh": 0 }),
                    serde_json::json!({ "type": "VEC2" }),
                ),
                "meshes[0]: primitives[0]: attributes.POSITION: accessor 0 is VEC2 of FLOAT; glTF 2.0 allows VEC3 of FLOAT",
            ),
            (
                "nan.gltf",
                triangle_doc(
                    serde_json::json!({ "mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1e39, 0, 0, 1] }),
                    serde_json::Value::Null,
                ),
                "nodes[0].matrix[12] is beyond the range of a 32-bit float",
            ),
        ];
        for (name, bytes, needle) in cases {
            let path = write(dir.path(), name, &bytes);
            let err = load_gltf_mesh(&path).expect_err(name).to_string();
            assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
        }
        // A cycle in the node hierarchy.
        let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
            serde_json::json!({ "mesh": 0, "children": [1] }),
            serde_json::Value::Null,
        ))
        .unwrap();
        doc["nodes"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!({ "children": [0] }));
        let path = write(dir.path(), "cycle.gltf", &serde_json::to_vec(&doc).unwrap());
        let err = load_gltf_mesh(&path).expect_err("cycle").to_string();
        assert!(err.contains("reached twice"), "{err}");
        // A bad percent escape in a relative URI.
        let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
            serde_json::json!({ "mesh": 0 }),
            serde_json::Value::Null,
        ))
        .unwrap();
        doc["buffers"][0]["uri"] = serde_json::json!("bad%FF.bin");
        let path = write(dir.path(), "uri.gltf", &serde_json::to_vec(&doc).unwrap());
        let err = load_gltf_mesh(&path).expect_err("uri").to_string();
        assert!(err.contains("UTF-8"), "{err}");
        // Out-of-range indices.
        let mut bytes = unit_triangle();
        bytes.extend([0u16, 1, 7, 0].iter().flat_map(|i| i.to_le_bytes()));
        let doc = gltf_with(
            &bytes,
            serde_json::json!({
                "scenes": [{ "nodes": [0] }],
                "nodes": [{ "mesh": 0 }],
                "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
                "bufferViews": [{ "buffer": 0, "byteLength": 36 }, { "buffer": 0, "byteOffset": 36, "byteLength": 6 }],
                "accessors": [
                    { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
                    { "bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR" }
                ],
            }),
        );
        let path = write(dir.path(), "index.gltf", &doc);
        let err = load_gltf_mesh(&path).expect_err("index").to_string();
        assert!(err.contains("out of range"), "{err}");
    }

    #[test]
    fn sparse_accessors_and_normalized_texcoords() {
        let dir = tempfile::tempdir().unwrap();
        // Positions: a base triangle with vertex 2 replaced sparsely; uvs as normalized u16.
        let mut bytes = unit_triangle(); // 0..36
        bytes.extend([2u32].iter().flat_map(|i| i.to_le_bytes())); // 36..40 sparse index
        bytes.extend(f32_bytes(&[0.0, 3.0, 0.0])); // 40..52 sparse value
        bytes.extend(
            [0u16, 65535, 65535, 65535, 0, 0]
                .iter()
                .flat_map(|v| v.to_le_bytes()),
        ); // 52..64 uvs
        let doc = gltf_with(
            &bytes,
            serde_json::json!({
                "scenes": [{ "nodes": [0] }],
                "nodes": [{ "mesh": 0 }],
                "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 } }] }],
                "bufferViews": [
                    { "buffer": 0, "byteLength": 36 },
                    { "buffer": 0, "byteOffset": 36, "byteLength": 4 },
                    { "buffer": 0, "byteOffset": 40, "byteLength": 12 },
                    { "buffer": 0, "byteOffset": 52, "byteLength": 12 }
                ],
                "accessors": [
                    { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 3, 0],
                      "sparse": { "count": 1, "indices": { "bufferView": 1, "componentType": 5125 }, "values": { "bufferView": 2 } } },
                    { "bufferView": 3, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC2" }
                ],
            }),
        );
        let path = write(dir.path(), "sparse.gltf", &doc);
        let m = load_gltf_mesh(&path).unwrap();
        assert_eq!(m.positions[2], Vec3::new(0.0, 3.0, 0.0));
        assert_eq!(
            m.uvs.unwrap(),
            vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 1.0)
            ]
        );
    }

    #[test]
    fn mixed_normals_are_unwelded_flat() {
        let a = MeshInput {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some(vec![Vec3::Z; 3]),
            uvs: None,
            indices: vec![0, 1, 2],
            ..MeshInput::default()
        };
        let b = MeshInput {
            positions: vec![Vec3::ZERO, Vec3::Y, Vec3::Z, Vec3::X],
            normals: None,
            uvs: Some(vec![Vec2::ONE; 4]),
            indices: vec![0, 2, 1, 3, 1, 2],
            ..MeshInput::default()
        };
        let m = merge(vec![a, b]).unwrap();
        assert_eq!(m.positions.len(), 3 + 6);
        let normals = m.normals.unwrap();
        assert_eq!(&normals[3..6], &[-Vec3::X; 3]);
        assert_eq!(m.uvs.unwrap()[..3], [Vec2::ZERO; 3]);
        assert_eq!(m.indices, vec![0, 1, 2, 3, 4, 5, 6, 7, 8]);
    }

    #[test]
    fn images_convert_to_linear_rgb() {
        use gltf::image::{Data, Format};
        let grey = Data {
            pixels: vec![0, 255],
            format: Format::R8,
            width: 1,
            height: 2,
        };
        let img = convert_image(&grey, Decoding::Srgb).unwrap();
        assert_eq!(img.texels, vec![Vec3::ZERO, Vec3::ONE]);
        let rgba = Data {
            pixels: vec![255, 0, 0, 7, 0, 0, 255, 9],
            format: Format::R8G8B8A8,
            width: 2,
            height: 1,
        };
        assert_eq!(
            convert_image(&rgba, Decoding::Srgb).unwrap().texels,
            vec![Vec3::X, Vec3::Z]
        );
        let half = Data {
            pixels: vec![128],
            format: Format::R8,
            width: 1,
            height: 1,
        };
        assert!(
            (convert_image(&half, Decoding::Srgb).unwrap().texels[0].x
                - srgb_to_linear(128.0 / 255.0))
            .abs()
                < 1e-7
        );
        let float = Data {
            pixels: f32_bytes(&[2.0, 0.5, 0.25]),
            format: Format::R32G32B32FLOAT,
            width: 1,
            height: 1,
        };
        assert_eq!(
            convert_image(&float, Decoding::Srgb).unwrap().texels,
            vec![Vec3::new(2.0, 0.5, 0.25)]
        );
        let short = Data {
            pixels: vec![0; 5],
            format: Format::R8G8B8,
            width: 2,
            height: 1,
        };
        assert!(convert_image(&short, Decoding::Srgb).is_err());
    }

    /// The unit triangle with material 0, `material`, whose texture 0 is
    /// a `width` x `height` PNG of `rgb` bytes in a bufferView.
    fn textured_triangle(
        width: u32,
        height: u32,
        rgb: Vec<u8>,
        material: serde_json::Value,
    ) -> Vec<u8> {
        let mut png = Vec::new();
        let img = image::RgbImage::from_raw(width, height, rgb).unwrap();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        triangle_with_png(png, material)
    }

    /// The unit triangle with material 0, `material`, whose texture 0 is
    /// the PNG `png` in a bufferView.
    fn triangle_with_png(png: Vec<u8>, material: serde_json::Value) -> Vec<u8> {
        let mut bytes = unit_triangle();
        bytes.extend(&png);
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        gltf_with(
            &bytes,
            serde_json::json!({
                "scenes": [{ "nodes": [0] }],
                "nodes": [{ "mesh": 0 }],
                "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "material": 0 }] }],
                "materials": [material],
                "textures": [{ "source": 0 }],
                "images": [{ "bufferView": 1, "mimeType": "image/png" }],
                "bufferViews": [{ "buffer": 0, "byteLength": 36 }, { "buffer": 0, "byteOffset": 36, "byteLength": png.len() }],
                "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
            }),
        )
    }

    /// The triangle document whose primitive has material 0, `material`.
    fn with_material(material: serde_json::Value, used: &[&str]) -> Vec<u8> {
        let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
            serde_json::json!({ "mesh": 0 }),
            serde_json::Value::Null,
        ))
        .unwrap();
        doc["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
        doc["materials"] = serde_json::json!([material]);
        doc["extensionsUsed"] = serde_json::json!(used);
        serde_json::to_vec(&doc).unwrap()
    }

    const GLASS_EXTENSIONS: &[&str] = &[
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
    ];

    #[test]
    fn transmission_ior_and_volume_become_the_dielectric() {
        let dir = tempfile::tempdir().unwrap();
        let glass = serde_json::json!({
            "pbrMetallicRoughness": { "metallicFactor": 0, "roughnessFactor": 0 },
            "extensions": {
                "KHR_materials_transmission": { "transmissionFactor": 1 },
                "KHR_materials_ior": { "ior": 1.33 },
                "KHR_materials_volume": { "thicknessFactor": 0.5, "attenuationDistance": 2, "attenuationColor": [0.5, 1, 0.25] }
            }
        });
        let p = write(
            dir.path(),
            "glass.gltf",
            &with_material(glass, GLASS_EXTENSIONS),
        );
        let scene = load_gltf_document(&p).unwrap();
        assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
        let ln2 = std::f32::consts::LN_2;
        assert_eq!(
            scene.materials(),
            vec![Material::Dielectric {
                ior: 1.33,
                absorption: Vec3::new(ln2 / 2.0, 0.0, 2.0 * ln2 / 2.0),
            }]
        );
        // No ior: 1.5; no volume: no absorption, and a warning that the
        // thin wall is solid glass; the factor, roughness and tint lost
        // are named in the same line.
        let partial = serde_json::json!({
            "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.8, 0.7, 1], "metallicFactor": 0 },
            "extensions": { "KHR_materials_transmission": { "transmissionFactor": 0.5 } }
        });
        let p = write(
            dir.path(),
            "thin.gltf",
            &with_material(partial, GLASS_EXTENSIONS),
        );
        let scene = load_gltf_document(&p).unwrap();
        assert_eq!(
            scene.materials(),
            vec![Material::Dielectric {
                ior: 1.5,
                absorption: Vec3::ZERO
            }]
        );
        assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
        let w = &scene.warnings()[0];
        for part in [
            "thin.gltf: materials[0]",
            "thin-walled",
            "transmissionFactor 0.5",
            "roughness 1",
            "tint",
        ] {
            assert!(w.contains(part), "`{part}` not in: {w}");
        }
        // A metal transmits nothing; an opaque material's ior is a warning.
        let metal = serde_json::json!({
            "pbrMetallicRoughness": { "metallicFactor": 1 },
            "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 2.0 } }
        });
        let p = write(
            dir.path(),
            "metal.gltf",
            &with_material(metal, GLASS_EXTENSIONS),
        );
        let scene = load_gltf_document(&p).unwrap();
        assert!(matches!(scene.materials()[0], Material::Ggx { .. }));
        assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
        assert!(scene.warnings()[0].contains("KHR_materials_ior 2 ignored"));
    }

    #[test]
    fn alpha_modes_give_the_material_a_coverage() {
        use crate::material::{Alpha, AlphaMode};
        let dir = tempfile::tempdir().unwrap();
        // A 2x1 RGBA image: alpha 128 and 255, read linear (not sRGB).
        let mut rgba = Vec::new();
        image::RgbaImage::from_raw(2, 1, vec![10, 20, 30, 128, 40, 50, 60, 255])
            .unwrap()
            .write_to(
                &mut std::io::Cursor::new(&mut rgba),
                image::ImageFormat::Png,
            )
            .unwrap();
        let load = |name: &str, doc: Vec<u8>| {
            let scene = load_gltf_document(&write(dir.path(), name, &doc)).unwrap();
            assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
            scene
        };
        let scene = load(
            "mask.gltf",
            triangle_with_png(
                rgba.clone(),
                serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "baseColorFactor": [1, 1, 1, 0.5] }, "alphaMode": "MASK", "alphaCutoff": 0.3 }),
            ),
        );
        let Some(Alpha {
            texture,
            mode: AlphaMode::Mask { cutoff },
        }) = scene.alpha(0)
        else {
            panic!("{:?}", scene.alpha(0));
        };
        assert_eq!(cutoff, 0.3);
        let Texture::Image { image, factor, .. } = scene.textures()[texture as usize] else {
            panic!("{:?}", scene.textures()[texture as usize]);
        };
        assert_eq!(factor, Vec3::splat(0.5), "the factor's alpha");
        assert_eq!(
            scene.images()[image as usize].texels,
            vec![Vec3::splat(128.0 / 255.0), Vec3::ONE]
        );
        assert_ne!(
            scene.triangles()[0].flags & crate::shapes::TRIANGLE_HAS_ALPHA,
            0
        );
        // BLEND without a texture: the factor alone; MASK's default cutoff.
        for (mode, expected) in [
            ("BLEND", AlphaMode::Blend),
            ("MASK", AlphaMode::Mask { cutoff: 0.5 }),
        ] {
            let scene = load(
                "factor.gltf",
                with_material(
                    serde_json::json!({ "pbrMetallicRoughness": { "baseColorFactor": [1, 1, 1, 0.25] }, "alphaMode": mode }),
                    &[],
                ),
            );
            let alpha = scene.alpha(0).unwrap();
            assert_eq!(alpha.mode, expected);
            assert_eq!(
                scene.textures()[alpha.texture as usize],
                Texture::Constant(Vec3::splat(0.25))
            );
        }
        // An image without alpha is opaque: one texel of 1.
        let scene = load(
            "rgb.gltf",
            textured_triangle(
                1,
                1,
                vec![1, 2, 3],
                serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } }, "alphaMode": "BLEND" }),
            ),
        );
        let Texture::Image { image, .. } =
            scene.textures()[scene.alpha(0).unwrap().texture as usize]
        else {
            panic!()
        };
        assert_eq!(scene.images()[image as usize].texels, vec![Vec3::ONE]);
        // OPAQUE (the default): no coverage, no flag.
        let scene = load(
            "opaque.gltf",
            with_material(serde_json::json!({ "alphaMode": "OPAQUE" }), &[]),
        );
        assert_eq!(scene.alpha(0), None);
        assert_eq!(
            scene.triangles()[0].flags & crate::shapes::TRIANGLE_HAS_ALPHA,
            0
        );
        // A negative cutoff is malformed.
        let p = write(
            dir.path(),
            "negative.gltf",
            &with_material(
                serde_json::json!({ "alphaMode": "MASK", "alphaCutoff": -0.5 }),
                &[],
            ),
        );
        let e = load_gltf_document(&p).unwrap_err().to_string();
        assert!(
            e.contains("negative.gltf") && e.contains("alphaCutoff"),
            "{e}"
        );
    }

    #[test]
    fn the_metallic_roughness_texture_is_linear_data() {
        // A 1x1 PNG (0, 128, 64): roughness 128/255 and metallic 64/255,
        // not sRGB-decoded; the same image as a base colour is decoded.
        let doc = textured_triangle(
            1,
            1,
            vec![0, 128, 64],
            serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0.5, "roughnessFactor": 0.75, "metallicRoughnessTexture": { "index": 0 } } }),
        );
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), "mr.gltf", &doc);
        let scene = load_gltf_document(&path).unwrap();
        let Material::Ggx {
            base_color,
            metallic,
            roughness,
            metallic_roughness: Some(mr),
            normal_map: None,
            clearcoat: None,
        } = scene.materials()[0]
        else {
            panic!("{:?}", scene.materials());
        };
        assert_eq!((metallic, roughness), (0.5, 0.75));
        let image_of = |t: u32| match scene.textures()[t as usize] {
            Texture::Image { image, factor, .. } => {
                assert_eq!(factor, Vec3::ONE);
                &scene.images()[image as usize]
            }
            other => panic!("{other:?}"),
        };
        assert_eq!(
            image_of(mr).texels,
            vec![Vec3::new(0.0, 128.0 / 255.0, 64.0 / 255.0)]
        );
        assert_eq!(
            image_of(base_color).texels,
            vec![Vec3::new(
                0.0,
                srgb_to_linear(128.0 / 255.0),
                srgb_to_linear(64.0 / 255.0)
            )]
        );
        assert_eq!(scene.images().len(), 2, "one image, decoded two ways");
    }

    #[test]
    fn samplers_and_texture_transforms_come_through() {
        // A 2x2 image: top row red, green; bottom row blue, white.
        let rgb = vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
        let transform = serde_json::json!({ "KHR_texture_transform": { "offset": [0, 1], "rotation": std::f64::consts::FRAC_PI_2, "scale": [0.5, 0.5] } });
        let mut doc: serde_json::Value = serde_json::from_slice(&textured_triangle(
            2,
            2,
            rgb,
            serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "extensions": transform } } }),
        ))
        .unwrap();
        doc["samplers"] =
            serde_json::json!([{ "wrapS": 33071, "wrapT": 33648, "magFilter": 9728 }]);
        doc["textures"][0]["sampler"] = serde_json::json!(0);
        doc["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "sampled.gltf",
            &serde_json::to_vec(&doc).unwrap(),
        );
        let scene = load_gltf_document(&path).unwrap();
        assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
        let Texture::Image { sampler, .. } = scene.textures()[0] else {
            panic!("{:?}", scene.textures());
        };
        use crate::texture::Wrap;
        assert_eq!(
            (sampler.wrap_u, sampler.wrap_v, sampler.nearest),
            (Wrap::ClampToEdge, Wrap::MirroredRepeat, true)
        );
        // The extension's example: the lower left quadrant of the image
        // (the blue texel), rotated clockwise 90°: the surface's whole uv
        // square reads inside it (renderer uv: v up, so the lower left
        // quadrant is u, v in [0, 0.5]).
        for (u, v) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.2), (0.3, 0.95)] {
            let t = sampler.transformed_uv(Vec2::new(u, v));
            assert!(
                (-1e-6..=0.5 + 1e-6).contains(&t.x) && (-1e-6..=0.5 + 1e-6).contains(&t.y),
                "({u}, {v}) -> {t}"
            );
        }
        // Rotated clockwise: the image's up points along the surface's
        // +u (the surface's +u reads the image's +v), its right along the
        // surface's -v.
        let (o, du, dv) = (
            sampler.transformed_uv(Vec2::ZERO),
            sampler.transformed_uv(Vec2::X),
            sampler.transformed_uv(Vec2::Y),
        );
        assert!((du - o - Vec2::new(0.0, 0.5)).length() < 1e-6, "{o} {du}");
        assert!((dv - o - Vec2::new(-0.5, 0.0)).length() < 1e-6, "{o} {dv}");
        // Set 1 on a primitive without TEXCOORD_1, and set 2 (not read):
        // each a warning naming the set.
        for (set, says) in [
            (1, "which the primitive lacks"),
            (2, "sets 0 and 1 are read"),
        ] {
            doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] =
                serde_json::json!(set);
            let path = write(dir.path(), "set.gltf", &serde_json::to_vec(&doc).unwrap());
            let scene = load_gltf_document(&path).unwrap();
            assert!(
                scene
                    .warnings()
                    .iter()
                    .any(|w| w.contains(&format!("TEXCOORD_{set}")) && w.contains(says)),
                "{:?}",
                scene.warnings()
            );
        }
    }

    /// An added vertex attribute: name, accessor type, component type,
    /// normalized, bytes.
    type Attribute<'a> = (&'a str, &'a str, u32, bool, Vec<u8>);

    /// The unit quad (z = 0, facing +z, NORMAL +z, glTF uv with v = 0 along
    /// its top edge y = 1) with `attributes` added (name → accessor type,
    /// component type, normalized, bytes) and material 0, `material`, whose
    /// texture 0 is a 1x1 PNG of `texel`.
    fn attributed_quad(
        attributes: &[Attribute],
        material: serde_json::Value,
        texel: [u8; 3],
    ) -> Vec<u8> {
        let mut png = Vec::new();
        image::RgbImage::from_raw(1, 1, texel.to_vec())
            .unwrap()
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let mut bytes = Vec::new();
        let mut views = Vec::new();
        let mut add = |data: &[u8]| {
            bytes.resize(bytes.len().next_multiple_of(4), 0);
            views.push(serde_json::json!({ "buffer": 0, "byteOffset": bytes.len(), "byteLength": data.len() }));
            bytes.extend_from_slice(data);
            views.len() - 1
        };
        let p = add(&f32_bytes(&[
            0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.,
        ]));
        let n = add(&f32_bytes(&[
            0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.,
        ]));
        let uv = add(&f32_bytes(&[0., 1., 1., 1., 1., 0., 0., 0.]));
        let i = add(&[0u16, 1, 2, 0, 2, 3].map(u16::to_le_bytes).concat());
        let image = add(&png);
        let mut accessors = vec![
            serde_json::json!({ "bufferView": p, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }),
            serde_json::json!({ "bufferView": n, "componentType": 5126, "count": 4, "type": "VEC3" }),
            serde_json::json!({ "bufferView": uv, "componentType": 5126, "count": 4, "type": "VEC2" }),
            serde_json::json!({ "bufferView": i, "componentType": 5123, "count": 6, "type": "SCALAR" }),
        ];
        let mut primitive_attributes =
            serde_json::json!({ "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2 });
        for (name, kind, component, normalized, data) in attributes {
            let count = match *name {
                "COLOR_0" if *kind == "VEC3" && *component == 5126 => data.len() / 12,
                _ => 4,
            };
            let view = add(data);
            accessors.push(serde_json::json!({ "bufferView": view, "componentType": component, "normalized": normalized, "count": count, "type": kind }));
            primitive_attributes[*name] = serde_json::json!(accessors.len() - 1);
        }
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        gltf_with(
            &bytes,
            serde_json::json!({
                "scenes": [{ "nodes": [0] }],
                "nodes": [{ "mesh": 0 }],
                "meshes": [{ "primitives": [{ "attributes": primitive_attributes, "indices": 3, "material": 0 }] }],
                "materials": [material],
                "textures": [{ "source": 0 }],
                "images": [{ "bufferView": image, "mimeType": "image/png" }],
                "bufferViews": views,
                "accessors": accessors,
            }),
        )
    }

    fn load_quad(
        attributes: &[Attribute],
        material: serde_json::Value,
    ) -> Result<Scene, SceneError> {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "quad.gltf",
            &attributed_quad(attributes, material, [128, 128, 255]),
        );
        load_gltf_document(&path)
    }

    #[test]
    fn vertex_colours_the_second_uv_set_and_tangents_come_through() {
        let colours = [
            0.1f32, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 0.5, 0.0,
        ];
        let material = serde_json::json!({
            "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 1 } },
            "normalTexture": { "index": 0, "scale": 0.5 },
        });
        let scene = load_quad(
            &[
                ("COLOR_0", "VEC3", 5126, false, f32_bytes(&colours)),
                (
                    "TEXCOORD_1",
                    "VEC2",
                    5126,
                    false,
                    f32_bytes(&[1., 1., 0., 1., 0., 0., 1., 0.]),
                ),
                (
                    "TANGENT",
                    "VEC4",
                    5126,
                    false,
                    f32_bytes(&[1., 0., 0., 1.].repeat(4)),
                ),
            ],
            material,
        )
        .unwrap();
        assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
        let m = scene.mesh();
        let expect: Vec<Vec4> = colours
            .chunks(3)
            .map(|c| Vec3::from_slice(c).extend(1.0))
            .collect();
        assert_eq!(m.colors, expect);
        // v flipped into the renderer's convention, as TEXCOORD_0.
        assert_eq!(
            m.uvs1,
            [
                Vec2::new(1., 0.),
                Vec2::new(0., 0.),
                Vec2::new(0., 1.),
                Vec2::new(1., 1.)
            ]
        );
        assert_eq!(m.tangents, vec![Vec4::new(1., 0., 0., 1.); 4]);
        use crate::shapes::*;
        let all = TRIANGLE_HAS_NORMALS
            | TRIANGLE_HAS_UVS
            | TRIANGLE_HAS_COLORS
            | TRIANGLE_HAS_TANGENTS
            | TRIANGLE_HAS_UV1;
        assert!(scene.triangles().iter().all(|t| t.flags == all));
        let Material::Ggx {
            base_color,
            normal_map: Some(map),
            ..
        } = scene.materials()[0]
        else {
            panic!("{:?}", scene.materials());
        };
        assert_eq!(map.scale, 0.5);
        let sampler_of = |t: u32| match scene.textures()[t as usize] {
            Texture::Image { sampler, .. } => sampler,
            ref other => panic!("{other:?}"),
        };
        assert_eq!(sampler_of(base_color).tex_coord, 1);
        assert_eq!(sampler_of(map.texture).tex_coord, 0);
        // Normalized bytes, with alpha.
        let bytes: Vec<u8> = [255u8, 0, 51, 255].repeat(4);
        let scene = load_quad(
            &[("COLOR_0", "VEC4", 5121, true, bytes)],
            serde_json::json!({}),
        )
        .unwrap();
        assert_eq!(scene.mesh().colors, vec![Vec4::new(1.0, 0.0, 0.2, 1.0); 4]);
        // Tangents serve normal maps only: without one they are dropped.
        assert!(scene.mesh().tangents.is_empty());
    }

    #[test]
    fn generated_tangents_point_along_u_with_the_bitangent_up_the_image() {
        let material = serde_json::json!({ "normalTexture": { "index": 0 } });
        let tangents = |uvs: &[f32]| {
            let scene = load_quad(
                &[("TEXCOORD_1", "VEC2", 5126, false, f32_bytes(uvs))],
                serde_json::json!({ "normalTexture": { "index": 0, "texCoord": 1 } }),
            )
            .unwrap();
            scene.mesh().tangents.clone()
        };
        // The quad's own uv (u along +x, the image's top at y = 1): the
        // tangent is +x and w = +1, so w · (n × t) = +y, up the image.
        let scene = load_quad(&[], material).unwrap();
        assert_eq!(scene.mesh().tangents.len(), 4);
        for t in &scene.mesh().tangents {
            assert!(
                (t.truncate() - Vec3::X).length() < 1e-5 && t.w == 1.0,
                "{t}"
            );
        }
        // Read from set 1, mirrored in u: the tangent is -x, and w = -1
        // keeps the bitangent up the image.
        for t in tangents(&[1., 1., 0., 1., 0., 0., 1., 0.]) {
            assert!(
                (t.truncate() + Vec3::X).length() < 1e-5 && t.w == -1.0,
                "{t}"
            );
        }
        // Mirrored in v: the bitangent points down the image, w = -1 with
        // the tangent still +x.
        for t in tangents(&[0., 0., 1., 0., 1., 1., 0., 1.]) {
            assert!(
                (t.truncate() - Vec3::X).length() < 1e-5 && t.w == -1.0,
                "{t}"
            );
        }
    }

    #[test]
    fn malformed_vertex_attributes_and_normal_textures_are_errors() {
        let f = |v: &[f32]| f32_bytes(v);
        let cases: Vec<(&str, Vec<Attribute>, serde_json::Value, &str)> = vec![
            (
                "colour as scalars",
                vec![("COLOR_0", "SCALAR", 5126, false, f(&[1.0; 4]))],
                serde_json::json!({}),
                "attributes.COLOR_0: accessor 4 is SCALAR of FLOAT",
            ),
            (
                "tangent as VEC3",
                vec![("TANGENT", "VEC3", 5126, false, f(&[1.0; 12]))],
                serde_json::json!({}),
                "attributes.TANGENT: accessor 4 is VEC3 of FLOAT",
            ),
            (
                "too few colours",
                vec![("COLOR_0", "VEC3", 5126, false, f(&[1.0; 9]))],
                serde_json::json!({}),
                "COLOR_0 has 3 elements but POSITION has 4",
            ),
            (
                "negative colour",
                vec![("COLOR_0", "VEC4", 5126, false, f(&[-1.0; 16]))],
                serde_json::json!({}),
                "negative",
            ),
            (
                "transform scale not numbers",
                vec![],
                serde_json::json!({ "normalTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "scale": ["big", 1] } } } }),
                "materials[0]: normalTexture.extensions.KHR_texture_transform.scale",
            ),
            (
                "transform rotation not finite",
                vec![],
                serde_json::json!({ "normalTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "rotation": "pi" } } } }),
                "KHR_texture_transform.rotation",
            ),
        ];
        for (what, attributes, material, says) in cases {
            let e = load_quad(&attributes, material)
                .expect_err(what)
                .to_string();
            assert!(e.contains("quad.gltf") && e.contains(says), "{what}: {e}");
        }
        // The normal map's transform read from raw JSON, as the typed
        // accessor reads the other textures'.
        let scene = load_quad(
            &[],
            serde_json::json!({ "normalTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "offset": [0.5, 0], "scale": [2, 3], "texCoord": 0 } } } }),
        )
        .unwrap();
        let Material::Ggx {
            normal_map: Some(map),
            ..
        } = scene.materials()[0]
        else {
            panic!("{:?}", scene.materials());
        };
        let Texture::Image { sampler, .. } = scene.textures()[map.texture as usize] else {
            panic!("{:?}", scene.textures());
        };
        let expect = super::sampler(
            &gltf::Gltf::from_slice(&attributed_quad(&[], serde_json::json!({}), [0; 3]))
                .unwrap()
                .textures()
                .next()
                .unwrap(),
            Some(&UvTransform {
                offset: [0.5, 0.0],
                rotation: 0.0,
                scale: [2.0, 3.0],
                tex_coord: Some(0),
            }),
        );
        assert_eq!(sampler.transform, expect.transform);
        assert!(sampler.transform.is_some());
    }

    #[test]
    fn clear_coats_come_through_and_malformed_ones_are_errors() {
        let coat = |c: serde_json::Value| serde_json::json!({ "extensions": { "KHR_materials_clearcoat": c } });
        let scene = load_quad(
            &[],
            coat(serde_json::json!({
                "clearcoatFactor": 0.7,
                "clearcoatTexture": { "index": 0 },
                "clearcoatRoughnessFactor": 0.3,
                "clearcoatRoughnessTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "scale": [2, 2] } } },
                "clearcoatNormalTexture": { "index": 0 },
            })),
        )
        .unwrap();
        let Material::Ggx {
            clearcoat: Some(c), ..
        } = scene.materials()[0]
        else {
            panic!("{:?}", scene.materials());
        };
        assert_eq!((c.factor, c.roughness), (0.7, 0.3));
        // Two textures of one image (linear data), the second transformed.
        let (Some(t), Some(r)) = (c.texture, c.roughness_texture) else {
            panic!("{c:?}");
        };
        let image = |t: u32| match scene.textures()[t as usize] {
            Texture::Image { image, sampler, .. } => (image, sampler.transform.is_some()),
            ref other => panic!("{other:?}"),
        };
        assert_eq!(image(t).0, image(r).0);
        assert!(!image(t).1 && image(r).1);
        assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
        assert!(scene.warnings()[0].contains("clearcoatNormalTexture ignored"));
        // A zero coat is none.
        let bare = load_quad(
            &[],
            coat(serde_json::json!({ "clearcoatRoughnessFactor": 0.5 })),
        )
        .unwrap();
        assert!(matches!(
            bare.materials()[0],
            Material::Ggx {
                clearcoat: None,
                ..
            }
        ));
        for (what, c, says) in [
            (
                "not an object",
                serde_json::json!(true),
                "KHR_materials_clearcoat is not an object",
            ),
            (
                "factor a string",
                serde_json::json!({ "clearcoatFactor": "thick" }),
                "clearcoatFactor",
            ),
            (
                "factor above 1",
                serde_json::json!({ "clearcoatFactor": 1.5 }),
                "clearcoatFactor 1.5",
            ),
            (
                "negative roughness",
                serde_json::json!({ "clearcoatFactor": 1, "clearcoatRoughnessFactor": -0.1 }),
                "clearcoatRoughnessFactor",
            ),
            (
                "texture out of range",
                serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 9 } }),
                "texture 9 does not exist",
            ),
            (
                "texture without index",
                serde_json::json!({ "clearcoatFactor": 1, "clearcoatRoughnessTexture": { "texCoord": 0 } }),
                "clearcoatRoughnessTexture has no index",
            ),
            (
                "texture not an object",
                serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": 0 }),
                "not a textureInfo object",
            ),
            (
                "texCoord negative",
                serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 0, "texCoord": -1 } }),
                "texCoord -1 is not an index",
            ),
            (
                "bad transform",
                serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "offset": 3 } } } }),
                "KHR_texture_transform.offset",
            ),
        ] {
            let e = load_quad(&[], coat(c)).expect_err(what).to_string();
            assert!(e.contains("quad.gltf") && e.contains(says), "{what}: {e}");
        }
    }

    #[test]
    fn malformed_glass_extensions_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        for (name, ext) in [
            (
                "texture index out of range",
                serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1, "transmissionTexture": { "index": 7 } } }),
            ),
            (
                "ior not a number",
                serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": "glass" } }),
            ),
            (
                "ior below 1",
                serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 0.5 } }),
            ),
            (
                "negative ior on an opaque material",
                serde_json::json!({ "KHR_materials_ior": { "ior": -1.0 } }),
            ),
            (
                "ior 0 on glass",
                serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 0.0 } }),
            ),
        ] {
            let m = serde_json::json!({ "pbrMetallicRoughness": { "metallicFactor": 0, "roughnessFactor": 0 }, "extensions": ext });
            let p = write(dir.path(), "bad.gltf", &with_material(m, GLASS_EXTENSIONS));
            let e = load_gltf_document(&p)
                .map(|_| ())
                .expect_err(name)
                .to_string();
            assert!(e.contains("bad.gltf"), "{name}: {e}");
            println!("{name}: {e}");
        }
    }

    #[test]
    fn base_colour_texture_comes_through_with_its_factor() {
        // A 1x2 PNG (top red, bottom blue) embedded in a bufferView.
        let doc = textured_triangle(
            1,
            2,
            vec![255, 0, 0, 0, 0, 255],
            serde_json::json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1], "baseColorTexture": { "index": 0 }, "metallicFactor": 0.25, "roughnessFactor": 0.75 } }),
        );
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), "textured.gltf", &doc);
        let scene = load_gltf_document(&path).unwrap();
        assert_eq!(
            scene.materials(),
            vec![Material::Ggx {
                base_color: 0,
                metallic: 0.25,
                roughness: 0.75,
                metallic_roughness: None,
                normal_map: None,
                clearcoat: None,
            }]
        );
        assert_eq!(
            scene.textures(),
            vec![Texture::Image {
                image: 0,
                factor: Vec3::splat(0.5),
                sampler: Sampler::default(),
            }]
        );
        assert_eq!(
            scene.images()[0].texels,
            vec![Vec3::X, Vec3::Z],
            "row 0 is the top row"
        );
        // The default camera sees the triangle: it looks at its centre from +z.
        let c = scene.camera_settings();
        assert!((c.look_at - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6 && c.look_from.z > 1.0);
    }

    /// A scene's sources are every file its loaders read, each once: the
    /// scene file, the glTF document, its external buffer (the URI
    /// percent-decoded) and image, and a JSON texture; none for data:
    /// URIs.
    #[test]
    fn a_scene_lists_the_files_it_was_read_from() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut png = Vec::new();
        image::RgbImage::from_raw(1, 1, vec![9, 8, 7])
            .unwrap()
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        write(d, "albedo.png", &png);
        write(d, "tri angle.bin", &unit_triangle());
        let mut doc: serde_json::Value = serde_json::from_slice(&triangle_with_png(
            png,
            serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }),
        ))
        .unwrap();
        doc["buffers"] = serde_json::json!([{ "byteLength": 36, "uri": "tri%20angle.bin" }]);
        doc["bufferViews"] = serde_json::json!([{ "buffer": 0, "byteLength": 36 }]);
        doc["images"] = serde_json::json!([{ "uri": "albedo.png" }]);
        let gltf = write(d, "doc.gltf", &serde_json::to_vec(&doc).unwrap());
        let scene = load_gltf_document(&gltf).unwrap();
        assert_eq!(
            scene.sources(),
            [gltf.clone(), d.join("tri angle.bin"), d.join("albedo.png")]
        );
        let mut read = Vec::new();
        load_gltf_mesh_reading(&gltf, &mut read, &mut Vec::new()).unwrap();
        assert_eq!(read, [gltf.clone(), d.join("tri angle.bin")]);
        // A glTF of data: URIs reads only itself.
        let inline = write(
            d,
            "inline.gltf",
            &triangle_doc(serde_json::json!({ "mesh": 0 }), serde_json::Value::Null),
        );
        assert_eq!(
            load_gltf_document(&inline).unwrap().sources(),
            std::slice::from_ref(&inline)
        );
        // A JSON scene: itself, then what it reads in order, each once.
        let json = write(
            d,
            "scene.json",
            br#"{ "camera": { "look_from": [0, 0, 3], "look_at": [0, 0, 0] },
                  "textures": { "t": { "type": "image", "path": "albedo.png" } },
                  "materials": { "m": { "type": "lambertian", "albedo": "t" } },
                  "objects": [ { "type": "mesh", "path": "doc.gltf", "material": "m" },
                               { "type": "gltf", "path": "inline.gltf" },
                               { "type": "mesh", "path": "doc.gltf", "material": "m" } ] }"#,
        );
        let scene = crate::loader::json::load_json_scene(&json).unwrap();
        assert_eq!(
            scene.sources(),
            [
                json,
                d.join("albedo.png"),
                gltf,
                d.join("tri angle.bin"),
                inline
            ]
        );
        assert!(crate::builtin::load("cornell")
            .unwrap()
            .sources()
            .is_empty());
    }
}
