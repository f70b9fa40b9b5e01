//! Building a scene: every parameter checked, then the BVH built.

use super::leaf::{batched, primitive_bounds, Accel, Group, Objects};
use super::primitive::{primitive_tag, Primitive};
use super::render_space::{RenderOrigin, RenderSpace};
use super::settings::RenderSettings;
use super::transform::Transform;
use super::world::{EmitterWeights, Scene};
use crate::background::Background;
use crate::bvh::{Bvh, BvhBuildStats};
use crate::camera::CameraSettings;
use crate::error::SceneError;
use crate::filter::PixelFilter;
use crate::geometry::Aabb;
use crate::light::punctual::{punctual_tag, PunctualLight};
use crate::material::{Alpha, AlphaMode, Material, Wrappers};
use crate::mutants::{self, Mutant};
use crate::sdf::{SdfGrid, SdfVoxel, MAX_SDF_SAMPLES};
use crate::shapes::{
    Instance, MeshData, Quad, Quadric, Sphere, Triangle, QUADRIC_SDF, QUADRIC_SPHERE,
    TRIANGLE_HAS_ALPHA, TRIANGLE_HAS_COLORS, TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS,
    TRIANGLE_HAS_UV1, TRIANGLE_HAS_UVS,
};
use crate::texture::{ImageData, Sampler, Texture};
use glam::{DVec3, Vec2, Vec3, Vec4};
use std::path::PathBuf;

/// An indexed triangle mesh before placement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshInput {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// Linear RGBA vertex colours (they scale the GGX base colour).
    pub colors: Option<Vec<Vec4>>,
    /// Tangents in the mesh's space (`MeshData::tangents`), for normal maps.
    pub tangents: Option<Vec<Vec4>>,
    /// A second set of texture coordinates (v up, as `uvs`).
    pub uvs1: Option<Vec<Vec2>>,
}

/// A punctual light as a loader reads it, in world coordinates (f64
/// positions); [`SceneBuilder::add_light`] checks it. Field names in its
/// errors are the scene format's (`position`, `direction`, `intensity`,
/// `irradiance`, `inner_cone_angle`, `outer_cone_angle`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightInput {
    /// Radiant intensity (W/sr) per channel, the same in every direction.
    Point { position: DVec3, intensity: Vec3 },
    /// Radiant intensity along `direction` (the way the light points),
    /// full inside the inner cone, falling off to none at the outer
    /// (angles in radians from the axis: `0 ≤ inner < outer ≤ π/2`).
    Spot {
        position: DVec3,
        direction: Vec3,
        intensity: Vec3,
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
    /// Irradiance (W/m²) on a surface facing it, arriving along
    /// `direction` (the way the light travels).
    Directional { direction: Vec3, irradiance: Vec3 },
    /// Mitsuba's `spot`: radiant intensity along its frame's z, full
    /// inside `beam_width`, falling linearly in the angle to none at
    /// `cutoff_angle` (radians from the axis, `0 ≤ beam ≤ cutoff`, the
    /// cutoff above 0 and at most π, at most π/2 with a texture), times
    /// `texture` (a texture id: a constant, an image or a uv checker) projected
    /// through the cone ([`crate::light::punctual::PunctualLight`]).
    SpotLinear {
        position: DVec3,
        /// The light's x, y and z axes (orthonormal, right-handed).
        frame: [Vec3; 3],
        intensity: Vec3,
        cutoff_angle: f32,
        beam_width: f32,
        texture: Option<u32>,
    },
    /// Mitsuba's `projector`: `π · scale · irradiance` as `intensity`,
    /// times `texture` if any, projected through a pinhole along its
    /// frame's z whose half fields of view have the tangents `tan_half`
    /// (x, y) ([`crate::light::punctual::PunctualLight`]).
    Projector {
        position: DVec3,
        /// The light's x, y and z axes (orthonormal, right-handed).
        frame: [Vec3; 3],
        intensity: Vec3,
        tan_half: Vec2,
        texture: Option<u32>,
    },
}

/// The most punctual lights a scene may hold (their ids share the emitter
/// list's 31 bits with nothing else, `light::PUNCTUAL_PRIM`; this is a
/// sanity bound far above any real scene's count).
pub const MAX_PUNCTUAL_LIGHTS: usize = 1 << 16;

/// Collects a scene, checks it, and builds its BVH. Positions are kept in
/// world coordinates, in f64, until [`SceneBuilder::build`] translates them
/// into render space ([`SceneBuilder::render_origin`]) and rounds them to
/// f32.
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    /// The camera in world coordinates (see also
    /// [`SceneBuilder::set_camera_exact`]).
    pub camera: CameraSettings,
    /// Where render space's origin lies: the world's (the default, for
    /// scenes built in code whose tests aim rays in world coordinates) or
    /// the camera's (every loader).
    pub render_origin: RenderOrigin,
    /// The camera's `look_from` and `look_at` as the file gave them, in
    /// f64, while they round to `camera`'s.
    camera_exact: Option<(DVec3, DVec3)>,
    /// World-space f64 twins of the spheres' centres, the quads' corners
    /// and the mesh positions, which `build` translates and rounds.
    sphere_centers: Vec<DVec3>,
    quad_corners: Vec<DVec3>,
    /// The quadrics' f64 object-to-world maps.
    quadric_maps: Vec<glam::DAffine3>,
    positions: Vec<DVec3>,
    pub render: RenderSettings,
    /// How each pixel's camera samples are spread (the box by default).
    pub filter: PixelFilter,
    /// The emitters' selection weights a file gives (Mitsuba's
    /// `sampling_weight`s); `None`: by power ([`crate::light`]).
    pub emitter_weights: Option<EmitterWeights>,
    pub background: Option<Background>,
    /// What the loaders ignored and the user should hear of (one line
    /// each), kept with the scene ([`Scene::warnings`]).
    pub warnings: Vec<String>,
    /// The files the loaders read to make the scene (the scene file, its
    /// meshes, glTF documents and buffers, images), as the loaders
    /// named them; kept with the scene ([`Scene::sources`]).
    pub sources: Vec<PathBuf>,
    spheres: Vec<Sphere>,
    quads: Vec<Quad>,
    quadrics: Vec<Quadric>,
    sdf_grids: Vec<SdfGrid>,
    sdf_voxels: Vec<SdfVoxel>,
    triangles: Vec<Triangle>,
    mesh: MeshData,
    materials: Vec<Material>,
    /// By material: its coverage ([`SceneBuilder::set_alpha`]); shorter
    /// than `materials` until the build.
    alphas: Vec<Option<Alpha>>,
    /// By material: the emission added to its BSDF
    /// ([`SceneBuilder::set_emission`]); shorter than `materials` until
    /// the build.
    emissions: Vec<Option<u32>>,
    /// By material: Mitsuba's wrappers on it ([`SceneBuilder::set_wrappers`]);
    /// shorter than `materials` until the build.
    wraps: Vec<Wrappers>,
    textures: Vec<Texture>,
    images: Vec<ImageData>,
    primitives: Vec<Primitive>,
    /// Punctual lights, and their positions in world coordinates (f64),
    /// which `build` translates and rounds.
    punctual_lights: Vec<PunctualLight>,
    light_positions: Vec<DVec3>,
    /// Instanced groups: each one's triangles and vertices (object space,
    /// never moved into render space).
    groups: Vec<GroupInput>,
    /// The group being filled ([`SceneBuilder::begin_group`]): where its
    /// triangles and vertices start.
    open_group: Option<(u32, u32)>,
    /// The instances' groups and f64 object-to-world maps.
    instances: Vec<(u32, glam::DAffine3)>,
}

/// Most triangles an instanced group may hold: 2^23, so that its tree's
/// node and entry indices (fewer than 2^24) are exact f32 integers, as
/// the GPU twin's records hold them (`gpu::scene_buffers`).
pub const MAX_GROUP_TRIANGLES: usize = 1 << 23;

/// A group's triangles and vertices (ranges of the builder's).
#[derive(Clone, Debug)]
struct GroupInput {
    triangles: std::ops::Range<u32>,
    vertices: std::ops::Range<u32>,
}

fn check_finite_vec(field: &str, v: Vec3) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::invalid(field, format!("{v} is not finite")))
    }
}

/// A dielectric's ratio of indices.
fn check_eta(eta: f32) -> Result<(), SceneError> {
    if !(eta.is_finite() && eta > 0.0) {
        return Err(SceneError::invalid(
            "eta",
            format!("{eta} must be a positive finite number"),
        ));
    }
    Ok(())
}

/// A microfacet distribution's tag.
fn check_distribution(distribution: u32) -> Result<(), SceneError> {
    if distribution > crate::microfacet::distribution::BECKMANN {
        return Err(SceneError::invalid(
            "distribution",
            format!("{distribution} is neither GGX (0) nor Beckmann (1)"),
        ));
    }
    Ok(())
}

fn check_colour(field: &str, c: Vec3) -> Result<(), SceneError> {
    check_finite_vec(field, c)?;
    if c.min_element() < 0.0 {
        return Err(SceneError::invalid(
            field,
            format!("colour {c} has a negative component"),
        ));
    }
    Ok(())
}

/// Appends a mesh's `n` values of an optional vertex attribute to the
/// scene's array, which stays empty until some mesh has the attribute and
/// from then on has one entry per vertex (`fill` where a mesh had none).
fn push_attribute<T: Copy>(
    scene: &mut Vec<T>,
    base: u32,
    n: usize,
    fill: T,
    values: &Option<Vec<T>>,
    place: impl Fn(T) -> T,
) {
    match values {
        Some(values) => {
            scene.resize(base as usize, fill);
            scene.extend(values.iter().map(|&v| place(v)));
        }
        None if !scene.is_empty() => scene.extend(std::iter::repeat_n(fill, n)),
        None => {}
    }
}

/// A texture's values, and its references: to `images` images, and for a
/// checker to two of the `earlier` textures, neither a checker itself.
fn check_texture(texture: &Texture, earlier: &[Texture], images: usize) -> Result<(), SceneError> {
    match *texture {
        Texture::Constant(c) => check_colour("texture", c)?,
        Texture::Checker { scale, even, odd } => {
            if !scale.is_finite() {
                return Err(SceneError::invalid(
                    "texture.scale",
                    format!("{scale} is not finite"),
                ));
            }
            check_pattern_leaves(even, odd, earlier)?;
        }
        Texture::UvChecker { sampler, even, odd } => {
            check_sampler(&sampler)?;
            check_pattern_leaves(even, odd, earlier)?;
        }
        Texture::VertexColor { factor } => check_colour("texture.factor", factor)?,
        Texture::Image {
            image,
            factor,
            sampler,
        } => {
            check_colour("texture.factor", factor)?;
            check_sampler(&sampler)?;
            if image as usize >= images {
                return Err(SceneError::invalid(
                    "texture.image",
                    format!("image index {image} does not exist"),
                ));
            }
        }
    }
    Ok(())
}

/// A sampler's transform (finite) and coordinate set (0 or 1).
fn check_sampler(sampler: &Sampler) -> Result<(), SceneError> {
    if let Some(t) = sampler.transform {
        if t.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::invalid(
                "texture.transform",
                format!("{t:?} must be finite"),
            ));
        }
    }
    if sampler.tex_coord > 1 {
        return Err(SceneError::invalid(
            "texture.tex_coord",
            format!(
                "coordinate set {} does not exist (0 or 1)",
                sampler.tex_coord
            ),
        ));
    }
    Ok(())
}

/// A pattern's two textures: earlier ones, neither a pattern itself.
fn check_pattern_leaves(even: u32, odd: u32, earlier: &[Texture]) -> Result<(), SceneError> {
    for (name, id) in [("even", even), ("odd", odd)] {
        match earlier.get(id as usize) {
            None => {
                return Err(SceneError::invalid(
                    &format!("texture.{name}"),
                    format!("texture index {id} does not exist"),
                ))
            }
            Some(t) if t.is_pattern() => {
                return Err(SceneError::invalid(
                    &format!("texture.{name}"),
                    "a checker cannot nest another checker".into(),
                ))
            }
            Some(Texture::VertexColor { .. }) => {
                return Err(SceneError::invalid(
                    &format!("texture.{name}"),
                    "a checker cannot nest a vertex colour".into(),
                ))
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// A wrap's opacity texture, and the material it wraps.
pub(super) fn check_wrap(
    material: &Material,
    wrap: &Wrappers,
    textures: &[Texture],
) -> Result<(), SceneError> {
    if *wrap != Wrappers::default() && matches!(material, Material::DiffuseLight { .. }) {
        return Err(SceneError::invalid(
            "wrap",
            "a light (diffuse_light) takes no mask, normal map or one-sidedness".into(),
        ));
    }
    for (what, t) in [
        ("opacity", wrap.opacity),
        ("normal_map", wrap.normal_map),
        ("blend.weight", wrap.blend.map(|b| b.weight)),
    ] {
        match t {
            Some(t) if t as usize >= textures.len() => {
                return Err(SceneError::invalid(
                    what,
                    format!("texture index {t} does not exist"),
                ))
            }
            _ => {}
        }
    }
    if wrap.normal_map_mirrored && wrap.normal_map.is_none() {
        return Err(SceneError::invalid(
            "normal_map_mirrored",
            "is set without a normal map".into(),
        ));
    }
    if wrap.bump_map {
        // The gradient is per unit of the first uv set, whose ∂p/∂u and
        // ∂p/∂v the surface gives (`texture::texture_gradient`).
        match wrap.normal_map.map(|t| &textures[t as usize]) {
            None => {
                return Err(SceneError::invalid(
                    "bump_map",
                    "is set without a texture".into(),
                ))
            }
            Some(Texture::Constant(_)) => {}
            Some(Texture::Image { sampler, .. }) if sampler.tex_coord == 0 => {}
            Some(_) => {
                return Err(SceneError::invalid(
                    "bump_map",
                    "a bump map's height is an image read through the first uv set, or a constant"
                        .into(),
                ))
            }
        }
    }
    Ok(())
}

/// Each blend's second BSDF ([`crate::material::Blend`]): another material
/// of the scene, not a light, whose wrappers say at most its side (a blend
/// inside a blend, or a mask or map inside one, is not a model).
pub(super) fn check_blends(materials: &[Material], wraps: &[Wrappers]) -> Result<(), SceneError> {
    for (i, wrap) in wraps.iter().enumerate() {
        let Some(b) = wrap.blend else { continue };
        let at = format!("materials[{i}].blend.second");
        let second = b.second as usize;
        if second >= materials.len() {
            return Err(SceneError::invalid(
                &at,
                format!("material index {second} does not exist"),
            ));
        }
        if second == i {
            return Err(SceneError::invalid(&at, "is the blend itself".into()));
        }
        if matches!(materials[second], Material::DiffuseLight { .. }) {
            return Err(SceneError::invalid(
                &at,
                "is a light (diffuse_light), which has no BSDF to blend".into(),
            ));
        }
        let inner = wraps.get(second).copied().unwrap_or_default();
        if inner
            != (Wrappers {
                one_sided: inner.one_sided,
                ..Wrappers::default()
            })
        {
            return Err(SceneError::invalid(
                &at,
                format!("material {second} has a mask, a map or a blend of its own; a blend's BSDFs take only their side"),
            ));
        }
    }
    Ok(())
}

/// A coverage's texture reference and cutoff.
pub(super) fn check_alpha(alpha: &Alpha, textures: usize) -> Result<(), SceneError> {
    if alpha.texture as usize >= textures {
        return Err(SceneError::invalid(
            "alpha.texture",
            format!("texture index {} does not exist", alpha.texture),
        ));
    }
    if let AlphaMode::Mask { cutoff } = alpha.mode {
        if !cutoff.is_finite() {
            return Err(SceneError::invalid(
                "alpha.cutoff",
                format!("{cutoff} is not finite"),
            ));
        }
    }
    Ok(())
}

/// Emission `emission` (a texture index) added to `material`'s BSDF.
pub(super) fn check_added_emission(
    material: &Material,
    emission: u32,
    textures: usize,
) -> Result<(), SceneError> {
    if emission as usize >= textures {
        return Err(SceneError::invalid(
            "emission",
            format!("texture index {emission} does not exist"),
        ));
    }
    if let Material::DiffuseLight { .. } = material {
        return Err(SceneError::invalid(
            "emission",
            "a diffuse_light emits its own emission; only other materials take an added one".into(),
        ));
    }
    Ok(())
}

/// A material's parameters, and its references to `textures` textures.
fn check_material(
    material: &Material,
    textures: usize,
    images: &[ImageData],
) -> Result<(), SceneError> {
    let tex_ok = |field: &str, id: u32| {
        if (id as usize) < textures {
            Ok(())
        } else {
            Err(SceneError::invalid(
                field,
                format!("texture index {id} does not exist"),
            ))
        }
    };
    match *material {
        Material::Lambertian { albedo } => tex_ok("albedo", albedo)?,
        Material::SmoothDielectric {
            eta,
            reflectance,
            transmittance,
        }
        | Material::ThinDielectric {
            eta,
            reflectance,
            transmittance,
        } => {
            tex_ok("reflectance", reflectance)?;
            tex_ok("transmittance", transmittance)?;
            check_eta(eta)?;
        }
        Material::Conductor { specular, eta, k } => {
            tex_ok("specular", specular)?;
            check_colour("eta", eta)?;
            check_colour("k", k)?;
        }
        Material::RoughConductor {
            distribution,
            alpha,
            alpha_v,
            specular,
            eta,
            k,
        } => {
            tex_ok("alpha", alpha)?;
            if let Some(v) = alpha_v {
                tex_ok("alpha_v", v)?;
            }
            tex_ok("specular", specular)?;
            check_colour("eta", eta)?;
            check_colour("k", k)?;
            check_distribution(distribution)?;
        }
        Material::RoughDielectric {
            distribution,
            alpha,
            alpha_v,
            eta,
            reflectance,
            transmittance,
        } => {
            tex_ok("alpha", alpha)?;
            if let Some(v) = alpha_v {
                tex_ok("alpha_v", v)?;
            }
            tex_ok("reflectance", reflectance)?;
            tex_ok("transmittance", transmittance)?;
            check_eta(eta)?;
            check_distribution(distribution)?;
        }
        Material::Plastic {
            diffuse,
            specular,
            eta,
            specular_weight,
            ..
        } => {
            tex_ok("diffuse", diffuse)?;
            tex_ok("specular", specular)?;
            check_eta(eta)?;
            // Egan and Hilgeman's fit of the coat's inner reflectance
            // passes 1 near eta 3.9 (Mitsuba's plugin gives negative
            // light there): a coat that dense has no plastic's model.
            let internal = crate::material::plastic_internal_reflectance(eta);
            if internal >= 1.0 {
                return Err(SceneError::invalid(
                    "eta",
                    format!(
                        "{eta}: a plastic's coat reflects {internal} of its diffuse light back in \
                         by the fit of its model (at most about 3.9 keeps it below 1)"
                    ),
                ));
            }
            if !(0.0..=1.0).contains(&specular_weight) {
                return Err(SceneError::invalid(
                    "specular_weight",
                    format!("{specular_weight} is outside [0, 1]"),
                ));
            }
        }
        Material::RoughPlastic {
            distribution,
            alpha,
            diffuse,
            specular,
            eta,
            specular_weight,
            transmittance,
            internal,
            ..
        } => {
            tex_ok("diffuse", diffuse)?;
            tex_ok("specular", specular)?;
            check_eta(eta)?;
            if eta == 1.0 {
                // Mitsuba's refuses it too: a coat that is no interface.
                return Err(SceneError::invalid(
                    "eta",
                    "1: a rough plastic's coat must differ from its surroundings".into(),
                ));
            }
            check_distribution(distribution)?;
            if !(alpha.is_finite() && alpha > 0.0) {
                return Err(SceneError::invalid(
                    "alpha",
                    format!("{alpha} must be a positive finite number"),
                ));
            }
            if !(0.0..=1.0).contains(&specular_weight) {
                return Err(SceneError::invalid(
                    "specular_weight",
                    format!("{specular_weight} is outside [0, 1]"),
                ));
            }
            if !(0.0..1.0).contains(&internal) {
                return Err(SceneError::invalid(
                    "internal",
                    format!("{internal} is outside [0, 1)"),
                ));
            }
            let size = crate::material::ROUGH_PLASTIC_TABLE_SIZE;
            match images.get(transmittance as usize) {
                Some(t) if t.width == size && t.height == 1 => {}
                _ => {
                    return Err(SceneError::invalid(
                        "transmittance",
                        format!("image {transmittance} is not a table of {size} x 1"),
                    ))
                }
            }
        }
        Material::Principled {
            base_color,
            roughness,
            lobes,
            eta,
            thin,
        } => {
            tex_ok("base_color", base_color)?;
            tex_ok("roughness", roughness)?;
            for (what, t) in crate::material::PrincipledLobes::NAMES
                .into_iter()
                .zip(lobes.textures())
            {
                if let Some(t) = t {
                    tex_ok(what, t)?;
                }
            }
            check_eta(eta)?;
            let (thin_only, full_only) = (
                [("diff_trans", lobes.diff_trans)],
                [
                    ("metallic", lobes.metallic),
                    ("clearcoat", lobes.clearcoat),
                    ("clearcoat_gloss", lobes.clearcoat_gloss),
                ],
            );
            let (model, other) = if thin {
                ("thin principled", &full_only[..])
            } else {
                ("principled", &thin_only[..])
            };
            if let Some((what, _)) = other.iter().find(|(_, t)| t.is_some()) {
                return Err(SceneError::invalid(
                    what,
                    format!("a {model} BSDF has no {what}"),
                ));
            }
            if !thin && lobes.spec_trans.is_some() && eta == 1.0 {
                // Mitsuba moves it to 1.001: a transmission through no
                // interface has no half vector.
                return Err(SceneError::invalid(
                    "eta",
                    "1: a principled BSDF that transmits must differ from its surroundings".into(),
                ));
            }
        }
        Material::Metal { albedo, fuzz } => {
            tex_ok("albedo", albedo)?;
            if !(0.0..=1.0).contains(&fuzz) {
                return Err(SceneError::invalid(
                    "fuzz",
                    format!("{fuzz} is outside [0, 1]"),
                ));
            }
        }
        Material::Dielectric { ior, absorption } => {
            if !(ior.is_finite() && ior > 0.0) {
                return Err(SceneError::invalid(
                    "ior",
                    format!("{ior} must be a positive finite number"),
                ));
            }
            check_colour("absorption", absorption)?;
        }
        Material::DiffuseLight { emission } => tex_ok("emission", emission)?,
        Material::Ggx {
            base_color,
            metallic,
            roughness,
            metallic_roughness,
            normal_map,
            clearcoat,
        } => {
            tex_ok("base_color", base_color)?;
            if let Some(coat) = clearcoat {
                for (name, t) in [
                    ("clearcoat.texture", coat.texture),
                    ("clearcoat.roughness_texture", coat.roughness_texture),
                ] {
                    if let Some(t) = t {
                        tex_ok(name, t)?;
                    }
                }
                for (name, v) in [
                    ("clearcoat", coat.factor),
                    ("clearcoat_roughness", coat.roughness),
                ] {
                    if !(0.0..=1.0).contains(&v) {
                        return Err(SceneError::invalid(name, format!("{v} is outside [0, 1]")));
                    }
                }
            }
            if let Some(t) = metallic_roughness {
                tex_ok("metallic_roughness", t)?;
            }
            if let Some(map) = normal_map {
                tex_ok("normal_map", map.texture)?;
                if !map.scale.is_finite() {
                    return Err(SceneError::invalid(
                        "normal_map.scale",
                        format!("{} is not finite", map.scale),
                    ));
                }
            }
            if !(0.0..=1.0).contains(&metallic) {
                return Err(SceneError::invalid(
                    "metallic",
                    format!("{metallic} is outside [0, 1]"),
                ));
            }
            if !(0.0..=1.0).contains(&roughness) {
                return Err(SceneError::invalid(
                    "roughness",
                    format!("{roughness} is outside [0, 1]"),
                ));
            }
        }
    }
    Ok(())
}

/// The camera, the render settings and the background (which may name one
/// of `images` images).
fn check_view(
    camera: &CameraSettings,
    render: &RenderSettings,
    background: &Background,
    images: usize,
) -> Result<(), SceneError> {
    render.validate()?;
    camera.validate()?;
    match *background {
        Background::Solid(col) => check_colour("background.color", col)?,
        Background::Sky { horizon, zenith } => {
            check_colour("background.horizon", horizon)?;
            check_colour("background.zenith", zenith)?;
        }
        Background::Envmap {
            image,
            intensity,
            to_map,
            ..
        } => {
            if image as usize >= images {
                return Err(SceneError::invalid(
                    "background.path",
                    "envmap image missing".into(),
                ));
            }
            if !(intensity.is_finite() && intensity >= 0.0) {
                return Err(SceneError::invalid(
                    "background.intensity",
                    format!("intensity {intensity} must be finite and non-negative"),
                ));
            }
            if !crate::background::is_rotation(to_map) {
                return Err(SceneError::invalid(
                    "background.rotate_y",
                    format!("the map's turn {to_map} is not finite or not a rotation"),
                ));
            }
        }
    }
    Ok(())
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn add_image(&mut self, image: ImageData) -> u32 {
        self.images.push(image);
        self.images.len() as u32 - 1
    }

    /// Adds a texture after checking its references and values.
    pub fn add_texture(&mut self, texture: Texture) -> Result<u32, SceneError> {
        check_texture(&texture, &self.textures, self.images.len())?;
        self.textures.push(texture);
        Ok(self.textures.len() as u32 - 1)
    }

    /// Shorthand for a constant texture.
    pub fn constant(&mut self, c: Vec3) -> Result<u32, SceneError> {
        self.add_texture(Texture::Constant(c))
    }

    /// Mitsuba's `null` BSDF, a surface that light passes straight
    /// through, as its material and wrappers: a mask of opacity 0 (its
    /// pass-through is Mitsuba's null lobe, a delta draw that counts as a
    /// segment of the path) around a black diffuse that no path reaches.
    pub fn null_material(&mut self) -> Result<(Material, Wrappers), SceneError> {
        let black = self.constant(Vec3::ZERO)?;
        let opacity = if mutants::is(Mutant::NullOpaque) {
            self.constant(Vec3::ONE)?
        } else {
            black
        };
        Ok((
            Material::Lambertian { albedo: black },
            Wrappers {
                opacity: Some(opacity),
                ..Wrappers::default()
            },
        ))
    }

    /// Texture `id`'s mean ([`crate::texture::texture_mean`]).
    pub fn texture_mean(&self, id: u32) -> Result<f32, SceneError> {
        match self.textures.get(id as usize) {
            None => {
                return Err(SceneError::invalid(
                    "texture",
                    format!("texture index {id} does not exist"),
                ))
            }
            // As Mitsuba's `mesh_attribute`, which has no mean.
            Some(Texture::VertexColor { .. }) => {
                return Err(SceneError::invalid(
                    "texture",
                    "a vertex colour has no mean (a plastic cannot weigh its lobes by it)".into(),
                ))
            }
            Some(_) => {}
        }
        Ok(crate::texture::texture_mean(
            &self.textures,
            &self.images,
            id,
        ))
    }

    /// A smooth plastic ([`Material::Plastic`]) of textures `diffuse` and
    /// `specular`, its sampling weight from their means as Mitsuba's
    /// ([`crate::material::plastic_specular_weight`]); checked when added.
    pub fn plastic(
        &self,
        diffuse: u32,
        specular: u32,
        eta: f32,
        nonlinear: bool,
    ) -> Result<Material, SceneError> {
        let weight = crate::material::plastic_specular_weight(
            self.texture_mean(diffuse)?,
            self.texture_mean(specular)?,
        );
        Ok(Material::Plastic {
            diffuse,
            specular,
            eta,
            nonlinear,
            specular_weight: weight,
        })
    }

    /// A rough plastic ([`Material::RoughPlastic`]) of roughness `alpha`,
    /// textures `diffuse` and `specular`: its coat's tables computed
    /// ([`crate::material::rough_plastic_tables`]; once for each
    /// distribution, roughness and index: a rough plastic already added
    /// lends its own) and its sampling weight from the textures' means as
    /// Mitsuba's. Checked when added.
    pub fn rough_plastic(
        &mut self,
        distribution: u32,
        alpha: f32,
        (diffuse, specular): (u32, u32),
        eta: f32,
        nonlinear: bool,
    ) -> Result<Material, SceneError> {
        check_distribution(distribution)?;
        check_eta(eta)?;
        // Refused before its tables are computed (check_material checks
        // the material again).
        if !(alpha.is_finite() && alpha > 0.0) {
            return Err(SceneError::invalid(
                "alpha",
                format!("{alpha} must be a positive finite number"),
            ));
        }
        let weight = crate::material::plastic_specular_weight(
            self.texture_mean(diffuse)?,
            self.texture_mean(specular)?,
        );
        let same_coat = self.materials.iter().find_map(|m| match *m {
            Material::RoughPlastic {
                distribution: d,
                alpha: a,
                eta: e,
                transmittance,
                internal,
                ..
            } if (d, a.to_bits(), e.to_bits())
                == (distribution, alpha.to_bits(), eta.to_bits()) =>
            {
                Some((transmittance, internal))
            }
            _ => None,
        });
        let (transmittance, internal) = match same_coat {
            Some(coat) => coat,
            None => {
                let (table, internal) =
                    crate::material::rough_plastic_tables(distribution, alpha, eta);
                let image = self.add_image(ImageData {
                    width: table.len() as u32,
                    height: 1,
                    texels: table.into_iter().map(Vec3::splat).collect(),
                });
                (image, internal)
            }
        };
        Ok(Material::RoughPlastic {
            distribution,
            alpha,
            diffuse,
            specular,
            eta,
            nonlinear,
            specular_weight: weight,
            transmittance,
            internal,
        })
    }

    /// Adds a material after checking its parameters.
    pub fn add_material(&mut self, material: Material) -> Result<u32, SceneError> {
        check_material(&material, self.textures.len(), &self.images)?;
        self.materials.push(material);
        Ok(self.materials.len() as u32 - 1)
    }

    /// Gives material `material` a coverage: the triangles that use it are
    /// hit only where it covers the point ([`Scene::alpha_covers`]). Only
    /// triangles can have one (the build refuses a sphere or quad whose
    /// material has).
    pub fn set_alpha(&mut self, material: u32, alpha: Alpha) -> Result<(), SceneError> {
        self.check_material(material)?;
        check_alpha(&alpha, self.textures.len())?;
        let m = material as usize;
        if self.alphas.len() <= m {
            self.alphas.resize(m + 1, None);
        }
        self.alphas[m] = Some(alpha);
        Ok(())
    }

    /// Adds emission to material `material`'s BSDF: it reflects as it
    /// did and emits texture `emission` (radiance, linear RGB) from its
    /// front face, as a `DiffuseLight` does ([`Scene::emission`]). A
    /// `DiffuseLight` already emits: it cannot have more.
    pub fn set_emission(&mut self, material: u32, emission: u32) -> Result<(), SceneError> {
        self.check_material(material)?;
        check_added_emission(
            &self.materials[material as usize],
            emission,
            self.textures.len(),
        )?;
        let m = material as usize;
        if self.emissions.len() <= m {
            self.emissions.resize(m + 1, None);
        }
        self.emissions[m] = Some(emission);
        Ok(())
    }

    /// Puts Mitsuba's wrappers on material `material` ([`Wrappers`]): one
    /// side, a mask. A light (`DiffuseLight`) takes none: it already
    /// emits from its front alone and scatters nothing.
    pub fn set_wrappers(&mut self, material: u32, wrap: Wrappers) -> Result<(), SceneError> {
        self.check_material(material)?;
        check_wrap(&self.materials[material as usize], &wrap, &self.textures)?;
        let m = material as usize;
        if self.wraps.len() <= m {
            self.wraps.resize(m + 1, Wrappers::default());
        }
        self.wraps[m] = wrap;
        Ok(())
    }

    fn check_material(&self, material: u32) -> Result<(), SceneError> {
        if (material as usize) < self.materials.len() {
            Ok(())
        } else {
            Err(SceneError::invalid(
                "material",
                format!("material index {material} does not exist"),
            ))
        }
    }

    fn push_primitive(&mut self, tag: u32, index: usize) {
        self.primitives.push(Primitive {
            tag,
            index: index as u32,
        });
    }

    /// Refuses `what` while a group is open: a group holds meshes only.
    fn outside_group(&self, what: &str) -> Result<(), SceneError> {
        match self.open_group {
            None => Ok(()),
            Some(_) => Err(SceneError::invalid(
                "group",
                format!("{what} cannot be instanced: a group holds triangle meshes only"),
            )),
        }
    }

    /// Opens an instanced group: the meshes added until
    /// [`SceneBuilder::end_group`] are kept once, in their own object
    /// space (placed by their own transforms within it), and drawn only by
    /// the group's instances ([`SceneBuilder::add_instance`]). Only meshes
    /// can be added meanwhile.
    pub fn begin_group(&mut self) -> Result<(), SceneError> {
        self.outside_group("a group")?;
        self.open_group = Some((
            self.triangles.len() as u32,
            self.mesh.positions.len() as u32,
        ));
        Ok(())
    }

    /// Closes the open group; returns its id for
    /// [`SceneBuilder::add_instance`]. An empty group is refused.
    pub fn end_group(&mut self) -> Result<u32, SceneError> {
        let Some((tri, vertex)) = self.open_group.take() else {
            return Err(SceneError::invalid("group", "no group is open".into()));
        };
        if tri as usize == self.triangles.len() {
            return Err(SceneError::invalid(
                "group",
                "the group has no triangles".into(),
            ));
        }
        let count = self.triangles.len() - tri as usize;
        if count > MAX_GROUP_TRIANGLES {
            self.open_group = Some((tri, vertex));
            return Err(SceneError::invalid(
                "group",
                format!("the group has {count} triangles, more than the {MAX_GROUP_TRIANGLES} an instanced group may hold"),
            ));
        }
        self.groups.push(GroupInput {
            triangles: tri..self.triangles.len() as u32,
            vertices: vertex..self.mesh.positions.len() as u32,
        });
        Ok(self.groups.len() as u32 - 1)
    }

    /// An instance of group `group` ([`SceneBuilder::end_group`]) placed
    /// by `transform`: a primitive that shows the group's triangles
    /// through the map, their one copy shared by every instance.
    pub fn add_instance(&mut self, group: u32, transform: &Transform) -> Result<(), SceneError> {
        self.outside_group("an instance")?;
        if group as usize >= self.groups.len() {
            return Err(SceneError::invalid(
                "group",
                format!("group {group} does not exist"),
            ));
        }
        let m = transform.matrix;
        let det = m.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && m.translation.is_finite()) {
            return Err(SceneError::invalid(
                "transform",
                "an instance's transform is singular or not finite".into(),
            ));
        }
        self.instances.push((group, m));
        self.push_primitive(primitive_tag::INSTANCE, self.instances.len() - 1);
        Ok(())
    }

    /// A punctual light (see [`LightInput`]), every value checked.
    pub fn add_light(&mut self, light: LightInput) -> Result<(), SceneError> {
        self.outside_group("a light")?;
        if self.punctual_lights.len() >= MAX_PUNCTUAL_LIGHTS {
            return Err(SceneError::invalid(
                "lights",
                format!("more than {MAX_PUNCTUAL_LIGHTS} lights"),
            ));
        }
        let position_of = |p: DVec3| {
            if p.is_finite() && p.as_vec3().is_finite() {
                Ok(p)
            } else {
                Err(SceneError::invalid(
                    "position",
                    format!("{p} is not finite in f32"),
                ))
            }
        };
        let direction_of = |d: Vec3| {
            check_finite_vec("direction", d)?;
            d.try_normalize().ok_or_else(|| {
                SceneError::invalid("direction", format!("{d} has no direction (zero length)"))
            })
        };
        // A light's frame: finite, orthonormal and right-handed to 1e-4
        // (f32 axes of an f64 rotation are within a few 1e-7), made unit.
        let frame_of = |f: [Vec3; 3]| {
            let unit = |v: Vec3| (v.length() - 1.0).abs() < 1e-4;
            let ok = f.iter().all(|v| v.is_finite() && unit(*v))
                && f[0].dot(f[1]).abs() < 1e-4
                && f[1].dot(f[2]).abs() < 1e-4
                && f[0].dot(f[2]).abs() < 1e-4
                && f[0].cross(f[1]).dot(f[2]) > 0.0;
            if ok {
                Ok(f.map(Vec3::normalize))
            } else {
                Err(SceneError::invalid(
                    "frame",
                    format!(
                        "axes {}, {}, {} are not a rotation (orthonormal and right-handed)",
                        f[0], f[1], f[2]
                    ),
                ))
            }
        };
        let (light, position) = match light {
            LightInput::Point {
                position,
                intensity,
            } => {
                check_colour("intensity", intensity)?;
                let light = PunctualLight {
                    tag: punctual_tag::POINT,
                    intensity,
                    ..PunctualLight::default()
                };
                (light, position_of(position)?)
            }
            LightInput::Spot {
                position,
                direction,
                intensity,
                inner_cone_angle: inner,
                outer_cone_angle: outer,
            } => {
                check_colour("intensity", intensity)?;
                let show = |a: f32| format!("{a} rad ({:.3}°)", a.to_degrees());
                if !(outer.is_finite() && outer > 0.0 && outer <= std::f32::consts::FRAC_PI_2) {
                    return Err(SceneError::invalid(
                        "outer_cone_angle",
                        format!("{} must be above 0 and at most π/2 (90°)", show(outer)),
                    ));
                }
                if !(inner.is_finite() && inner >= 0.0 && inner < outer) {
                    return Err(SceneError::invalid(
                        "inner_cone_angle",
                        format!(
                            "{} must be at least 0 and below the outer cone angle {}",
                            show(inner),
                            show(outer)
                        ),
                    ));
                }
                let light = PunctualLight {
                    tag: punctual_tag::SPOT,
                    direction: direction_of(direction)?,
                    intensity,
                    cos_inner: inner.cos(),
                    cos_outer: outer.cos(),
                    ..PunctualLight::default()
                };
                (light, position_of(position)?)
            }
            LightInput::Directional {
                direction,
                irradiance,
            } => {
                check_colour("irradiance", irradiance)?;
                let light = PunctualLight {
                    tag: punctual_tag::DIRECTIONAL,
                    direction: direction_of(direction)?,
                    intensity: irradiance,
                    ..PunctualLight::default()
                };
                (light, DVec3::ZERO)
            }
            LightInput::SpotLinear {
                position,
                frame,
                intensity,
                cutoff_angle: cutoff,
                beam_width: beam,
                texture,
            } => {
                check_colour("intensity", intensity)?;
                let show = |a: f32| format!("{a} rad ({:.3}°)", a.to_degrees());
                let most = if texture.is_some() {
                    std::f32::consts::FRAC_PI_2
                } else {
                    std::f32::consts::PI
                };
                if !(cutoff.is_finite() && cutoff > 0.0 && cutoff <= most) {
                    return Err(SceneError::invalid(
                        "cutoff_angle",
                        format!(
                            "{} must be above 0 and at most {}{}",
                            show(cutoff),
                            show(most),
                            if texture.is_some() {
                                " with a texture"
                            } else {
                                ""
                            }
                        ),
                    ));
                }
                if !(beam.is_finite() && beam >= 0.0 && beam <= cutoff) {
                    return Err(SceneError::invalid(
                        "beam_width",
                        format!(
                            "{} must be at least 0 and at most the cutoff angle {}",
                            show(beam),
                            show(cutoff)
                        ),
                    ));
                }
                let [x, y, z] = frame_of(frame)?;
                let light = PunctualLight {
                    tag: punctual_tag::SPOT_LINEAR,
                    direction: z,
                    intensity,
                    cos_inner: beam.cos(),
                    cos_outer: cutoff.cos(),
                    axis_x: x,
                    axis_y: y,
                    texture: self.light_texture(texture)?,
                    profile: [cutoff, 1.0 / (cutoff - beam), 1.0 / cutoff.tan()],
                    ..PunctualLight::default()
                };
                (light, position_of(position)?)
            }
            LightInput::Projector {
                position,
                frame,
                intensity,
                tan_half,
                texture,
            } => {
                check_colour("intensity", intensity)?;
                if !(tan_half.is_finite() && tan_half.min_element() > 0.0) {
                    return Err(SceneError::invalid(
                        "fov",
                        format!("half fields of view of tangents {tan_half} must be above 0 and below 90°"),
                    ));
                }
                let [x, y, z] = frame_of(frame)?;
                let light = PunctualLight {
                    tag: punctual_tag::PROJECTOR,
                    direction: z,
                    intensity,
                    axis_x: x,
                    axis_y: y,
                    texture: self.light_texture(texture)?,
                    profile: [0.5 / tan_half.x, 0.5 / tan_half.y, 0.0],
                    ..PunctualLight::default()
                };
                (light, position_of(position)?)
            }
        };
        self.punctual_lights.push(PunctualLight {
            position: position.as_vec3(),
            ..light
        });
        self.light_positions.push(position);
        Ok(())
    }

    /// A light's texture: none, or a constant, an image or a uv checker
    /// (read at coordinates, not at a surface: no 3-D checker or vertex
    /// colour).
    fn light_texture(&self, texture: Option<u32>) -> Result<u32, SceneError> {
        let Some(id) = texture else {
            return Ok(crate::light::punctual::NO_TEXTURE);
        };
        match self.textures.get(id as usize) {
            None => Err(SceneError::invalid(
                "texture",
                format!("texture index {id} does not exist"),
            )),
            Some(Texture::Constant(_) | Texture::Image { .. } | Texture::UvChecker { .. }) => Ok(id),
            Some(_) => Err(SceneError::invalid(
                "texture",
                "a light's texture must be an image or a uv checker (a light has no surface point or vertex colour)".into(),
            )),
        }
    }

    /// The punctual lights added so far (positions in world coordinates,
    /// rounded to f32).
    pub fn punctual_lights(&self) -> &[PunctualLight] {
        &self.punctual_lights
    }

    /// A sphere, placed by `transform` (which must be a similarity: a
    /// sphere under non-uniform scale is an ellipsoid, not a sphere).
    pub fn add_sphere(
        &mut self,
        center: impl Into<DVec3>,
        radius: f32,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.outside_group("a sphere")?;
        let center = center.into();
        self.check_material(material)?;
        if !center.is_finite() {
            return Err(SceneError::invalid(
                "center",
                format!("{center} is not finite"),
            ));
        }
        if !(radius.is_finite() && radius != 0.0) {
            return Err(SceneError::invalid(
                "radius",
                format!("{radius} must be a finite non-zero number"),
            ));
        }
        let scale = transform.uniform_scale().ok_or_else(|| {
            SceneError::invalid("transform", "a sphere accepts only uniform scale".into())
        })?;
        let placed = transform.point_f64(center);
        let s = Sphere {
            center: placed.as_vec3(),
            radius: (radius as f64 * scale) as f32,
            material,
        };
        check_finite_vec("transform", s.center)?;
        if !(s.radius.is_finite() && s.radius != 0.0) {
            return Err(SceneError::invalid(
                "transform",
                format!("the placed radius {} is degenerate", s.radius),
            ));
        }
        self.spheres.push(s);
        self.sphere_centers.push(placed);
        self.push_primitive(primitive_tag::SPHERE, self.spheres.len() - 1);
        Ok(())
    }

    /// A parallelogram `corner + s·u + t·v`, placed by `transform`.
    pub fn add_quad(
        &mut self,
        corner: impl Into<DVec3>,
        u: Vec3,
        v: Vec3,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.outside_group("a quad")?;
        let corner = corner.into();
        self.check_material(material)?;
        if !corner.is_finite() {
            return Err(SceneError::invalid(
                "corner",
                format!("{corner} is not finite"),
            ));
        }
        for (f, x) in [("u", u), ("v", v)] {
            check_finite_vec(f, x)?;
        }
        let placed = transform.point_f64(corner);
        let q = Quad {
            corner: placed.as_vec3(),
            u: transform.vector(u),
            v: transform.vector(v),
            material,
        };
        let n = q.u.cross(q.v);
        if !(n.is_finite() && n.length_squared() > 0.0 && q.corner.is_finite()) {
            return Err(SceneError::invalid(
                "u/v",
                "the quad is degenerate (u and v are parallel or zero)".into(),
            ));
        }
        self.quads.push(q);
        self.quad_corners.push(placed);
        self.push_primitive(primitive_tag::QUAD, self.quads.len() - 1);
        Ok(())
    }

    /// A [`Quadric`] of kind `kind` (`QUADRIC_DISK`, `QUADRIC_CYLINDER`,
    /// `QUADRIC_SPHERE`: the unit shape of its object space) placed by
    /// `transform`, its normal inward where `flip`.
    pub fn add_quadric(
        &mut self,
        kind: u32,
        flip: bool,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.outside_group("a quadric")?;
        self.check_material(material)?;
        if kind > QUADRIC_SPHERE {
            return Err(SceneError::invalid(
                "kind",
                format!("no quadric kind {kind}"),
            ));
        }
        let q = Quadric::placed(kind, transform.matrix, flip, material).ok_or_else(|| {
            SceneError::invalid(
                "transform",
                "the shape's transform is singular or not finite in f32".into(),
            )
        })?;
        self.quadrics.push(q);
        self.quadric_maps.push(transform.matrix);
        self.push_primitive(primitive_tag::QUADRIC, self.quadrics.len() - 1);
        Ok(())
    }

    /// A signed distance grid ([`crate::sdf`]): `dims` samples per axis
    /// (x fastest in `values`) over [0, 1]³ of its object space, placed by
    /// `transform`; `smooth` for Mitsuba's smooth shading normals. Each
    /// cell the surface may cross becomes a primitive.
    pub fn add_sdf_grid(
        &mut self,
        dims: [u32; 3],
        values: Vec<f32>,
        smooth: bool,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.outside_group("a signed distance grid")?;
        self.check_material(material)?;
        if dims.iter().any(|&n| !(2..=MAX_SDF_SAMPLES).contains(&n)) {
            return Err(SceneError::invalid(
                "grid",
                format!("{dims:?} samples: each axis needs 2 to {MAX_SDF_SAMPLES}"),
            ));
        }
        let count = dims.iter().map(|&n| n as usize).product::<usize>();
        if values.len() != count {
            return Err(SceneError::invalid(
                "grid",
                format!("{} values for {dims:?} samples", values.len()),
            ));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(SceneError::invalid(
                "grid",
                format!("sample {i} is {}", values[i]),
            ));
        }
        let map =
            Quadric::placed(QUADRIC_SDF, transform.matrix, false, material).ok_or_else(|| {
                SceneError::invalid(
                    "transform",
                    "the grid's transform is singular or not finite in f32".into(),
                )
            })?;
        let grid = SdfGrid {
            map,
            map_f64: transform.matrix,
            dims,
            values,
            smooth,
        };
        let cells = grid.occupied();
        if cells.is_empty() {
            return Err(SceneError::invalid(
                "grid",
                "no cell has a surface (every sample has one strict sign)".into(),
            ));
        }
        let index = self.sdf_grids.len() as u32;
        for cell in cells {
            self.sdf_voxels.push(SdfVoxel { grid: index, cell });
            self.push_primitive(primitive_tag::SDF_VOXEL, self.sdf_voxels.len() - 1);
        }
        self.sdf_grids.push(grid);
        Ok(())
    }

    /// An axis-aligned box in its own frame (six quads, outward normals).
    pub fn add_box(
        &mut self,
        min: impl Into<DVec3>,
        max: impl Into<DVec3>,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        let (min, max) = (min.into(), max.into());
        for (field, p) in [("min", min), ("max", max)] {
            if !p.is_finite() {
                return Err(SceneError::invalid(field, format!("{p} is not finite")));
            }
        }
        if !min.cmplt(max).all() {
            return Err(SceneError::invalid(
                "min/max",
                format!("min {min} must be below max {max} on every axis"),
            ));
        }
        let d = (max - min).as_vec3();
        let (dx, dy, dz) = (
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, d.y, 0.0),
            Vec3::new(0.0, 0.0, d.z),
        );
        // Each face: corner, u, v with u × v pointing out of the box.
        let faces = [
            (DVec3::new(min.x, min.y, max.z), dx, dy),  // front (+z)
            (DVec3::new(max.x, min.y, max.z), -dz, dy), // right (+x)
            (DVec3::new(max.x, min.y, min.z), -dx, dy), // back (-z)
            (DVec3::new(min.x, min.y, min.z), dz, dy),  // left (-x)
            (DVec3::new(min.x, max.y, max.z), dx, -dz), // top (+y)
            (DVec3::new(min.x, min.y, min.z), dx, dz),  // bottom (-y)
        ];
        let mirror = transform.mirrors();
        for (corner, u, v) in faces {
            // A mirroring transform flips u × v; swap to keep normals outward.
            let (u, v) = if mirror { (v, u) } else { (u, v) };
            self.add_quad(corner, u, v, material, transform)?;
        }
        Ok(())
    }

    /// An indexed triangle mesh placed by `transform`. Degenerate
    /// triangles are kept (they never report a hit); out-of-range indices
    /// and non-finite data are errors.
    pub fn add_mesh(
        &mut self,
        mesh: &MeshInput,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        let n = mesh.positions.len();
        if mesh.indices.len() % 3 != 0 {
            return Err(SceneError::invalid(
                "indices",
                format!("{} indices is not a multiple of 3", mesh.indices.len()),
            ));
        }
        if let Some(bad) = mesh.indices.iter().find(|&&i| i as usize >= n) {
            return Err(SceneError::invalid(
                "indices",
                format!("index {bad} is out of range for {n} vertices"),
            ));
        }
        for (name, len) in [
            ("normals", mesh.normals.as_ref().map(Vec::len)),
            ("uvs", mesh.uvs.as_ref().map(Vec::len)),
            ("colors", mesh.colors.as_ref().map(Vec::len)),
            ("tangents", mesh.tangents.as_ref().map(Vec::len)),
            ("uvs1", mesh.uvs1.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&l| l != n) {
                return Err(SceneError::invalid(
                    name,
                    format!("{len} entries for {n} vertices"),
                ));
            }
        }
        if mesh.indices.is_empty() {
            return Err(SceneError::invalid(
                "indices",
                "the mesh has no triangles".into(),
            ));
        }
        let base = self.mesh.positions.len() as u32;
        if (base as usize + n) > u32::MAX as usize / 2 {
            return Err(SceneError::invalid("positions", "too many vertices".into()));
        }
        // Everything is checked before the scene's arrays change, so a mesh
        // refused leaves the builder as it was.
        if let Some(colors) = &mesh.colors {
            if let Some((i, c)) = colors
                .iter()
                .enumerate()
                .find(|(_, c)| !c.is_finite() || c.min_element() < 0.0)
            {
                return Err(SceneError::invalid(
                    "colors",
                    format!("vertex {i}'s colour {c} is negative or not finite"),
                ));
            }
        }
        let placed: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|&p| transform.point_f64(p.as_dvec3()))
            .collect();
        if let Some(i) = placed.iter().position(|p| !p.as_vec3().is_finite()) {
            return Err(SceneError::invalid(
                "positions",
                format!(
                    "vertex {i} ({}) is not finite once placed",
                    mesh.positions[i]
                ),
            ));
        }
        let nm = transform.normal_matrix();
        for (i, wp) in placed.into_iter().enumerate() {
            self.mesh.positions.push(wp.as_vec3());
            self.positions.push(wp);
            let wn = mesh
                .normals
                .as_ref()
                .map_or(Vec3::ZERO, |ns| (nm * ns[i]).normalize_or_zero());
            self.mesh
                .normals
                .push(if wn.is_finite() { wn } else { Vec3::ZERO });
            let uv = mesh.uvs.as_ref().map_or(Vec2::ZERO, |uvs| uvs[i]);
            self.mesh
                .uvs
                .push(if uv.is_finite() { uv } else { Vec2::ZERO });
        }
        // A mirroring placement turns the tangent frame's handedness.
        let mirrors = transform.mirrors();
        let placed_tangent = |t: Vec4| {
            let xyz = transform.vector(t.truncate()).normalize_or_zero();
            let w = if (t.w < 0.0) != mirrors { -1.0 } else { 1.0 };
            if xyz.is_finite() && t.w.is_finite() {
                xyz.extend(w)
            } else {
                Vec4::ZERO
            }
        };
        push_attribute(
            &mut self.mesh.colors,
            base,
            n,
            Vec4::ONE,
            &mesh.colors,
            |c| c,
        );
        push_attribute(
            &mut self.mesh.tangents,
            base,
            n,
            Vec4::ZERO,
            &mesh.tangents,
            placed_tangent,
        );
        push_attribute(&mut self.mesh.uvs1, base, n, Vec2::ZERO, &mesh.uvs1, |uv| {
            if uv.is_finite() {
                uv
            } else {
                Vec2::ZERO
            }
        });
        let flags = [
            (mesh.normals.is_some(), TRIANGLE_HAS_NORMALS),
            (mesh.uvs.is_some(), TRIANGLE_HAS_UVS),
            (mesh.colors.is_some(), TRIANGLE_HAS_COLORS),
            (mesh.tangents.is_some(), TRIANGLE_HAS_TANGENTS),
            (mesh.uvs1.is_some(), TRIANGLE_HAS_UV1),
        ]
        .iter()
        .filter(|(has, _)| *has)
        .fold(0, |flags, (_, bit)| flags | bit);
        for tri in mesh.indices.chunks_exact(3) {
            self.triangles.push(Triangle {
                vertices: [base + tri[0], base + tri[1], base + tri[2]],
                material,
                flags,
            });
            // A group's triangles are drawn by its instances alone.
            if self.open_group.is_none() {
                self.push_primitive(primitive_tag::TRIANGLE, self.triangles.len() - 1);
            }
        }
        Ok(())
    }

    /// Sets the camera from positions given in f64 (a scene file's
    /// numbers): render space is then placed by them, not by their f32
    /// rounding, which `camera` holds. `settings` gives the rest of the
    /// camera.
    pub fn set_camera_exact(&mut self, look_from: DVec3, look_at: DVec3, settings: CameraSettings) {
        self.camera = CameraSettings {
            look_from: look_from.as_vec3(),
            look_at: look_at.as_vec3(),
            ..settings
        };
        self.camera_exact = Some((look_from, look_at));
    }

    /// The camera's position and target in f64: as
    /// [`SceneBuilder::set_camera_exact`] gave them while `camera` still
    /// holds their rounding, else `camera`'s own.
    fn camera_positions(&self) -> (DVec3, DVec3) {
        match self.camera_exact {
            Some((from, at))
                if from.as_vec3() == self.camera.look_from
                    && at.as_vec3() == self.camera.look_at =>
            {
                (from, at)
            }
            _ => (
                self.camera.look_from.as_dvec3(),
                self.camera.look_at.as_dvec3(),
            ),
        }
    }

    /// Material `id` with its wrappers and the emission added to it
    /// (`None`: no such material).
    pub fn material_parts(&self, id: u32) -> Option<(Material, Wrappers, Option<u32>)> {
        let i = id as usize;
        let material = *self.materials.get(i)?;
        let wrappers = self.wraps.get(i).copied().unwrap_or_default();
        Some((material, wrappers, self.emissions.get(i).copied().flatten()))
    }

    /// The primitives added so far (the next one's id).
    pub fn primitive_count(&self) -> usize {
        self.primitives.len()
    }

    pub fn material_count(&self) -> usize {
        self.materials.len()
    }

    pub fn texture_count(&self) -> usize {
        self.textures.len()
    }

    pub fn texture(&self, id: u32) -> Option<&Texture> {
        self.textures.get(id as usize)
    }

    pub fn image(&self, id: u32) -> Option<&ImageData> {
        self.images.get(id as usize)
    }

    /// Checks the camera and settings and builds the BVH.
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.open_group.is_some() {
            return Err(SceneError::invalid(
                "group",
                "a group was begun and never ended".into(),
            ));
        }
        if self.primitives.is_empty() {
            return Err(SceneError::invalid(
                "objects",
                "the scene has no objects".into(),
            ));
        }
        let (from, at) = self.camera_positions();
        let background = self.background.unwrap_or(Background::Solid(Vec3::ZERO));
        check_view(&self.camera, &self.render, &background, self.images.len())?;
        let mut alphas = self.alphas;
        alphas.resize(self.materials.len(), None);
        let mut emissions = self.emissions;
        emissions.resize(self.materials.len(), None);
        let mut wraps = self.wraps;
        wraps.resize(self.materials.len(), Wrappers::default());
        check_blends(&self.materials, &wraps)?;
        let has_alpha = |m: u32| alphas[m as usize].is_some();
        if let Some(m) = (self.spheres.iter().map(|s| s.material))
            .chain(self.quads.iter().map(|q| q.material))
            .chain(self.quadrics.iter().map(|q| q.material))
            .chain(self.sdf_grids.iter().map(|g| g.map.material))
            .find(|&m| has_alpha(m))
        {
            return Err(SceneError::invalid(
                "alpha",
                format!("material {m} has an alpha (coverage), which only triangles can have, but a sphere, quad or quadric uses it"),
            ));
        }
        check_groups(
            self.groups.iter().map(|g| g.triangles.clone()),
            &self.triangles,
            &self.materials,
            &alphas,
            &emissions,
        )?;
        let mut triangles = self.triangles;
        for tri in triangles.iter_mut().filter(|t| has_alpha(t.material)) {
            tri.flags |= TRIANGLE_HAS_ALPHA;
        }
        // Render space: every position translated in f64, then rounded.
        let space = match self.render_origin {
            _ if mutants::is(Mutant::NoRenderSpace) => RenderSpace::WORLD,
            RenderOrigin::World => RenderSpace::WORLD,
            RenderOrigin::Camera => RenderSpace::near(from, &self.textures),
            RenderOrigin::At(p) => RenderSpace::near(p, &self.textures),
        };
        let origin = space.origin();
        let textures = render_textures(&space, &self.textures)?;
        let mut spheres = self.spheres;
        let mut quads = self.quads;
        let mut quadrics = self.quadrics;
        let mut sdf_grids = self.sdf_grids;
        let mut mesh = self.mesh;
        let mut punctual_lights = self.punctual_lights;
        if origin != DVec3::ZERO {
            let to_render = |field: &str, p: DVec3| {
                let r = (p - origin).as_vec3();
                if r.is_finite() {
                    Ok(r)
                } else {
                    Err(SceneError::invalid(
                        field,
                        format!("{p} is not finite in f32 in render space (origin {origin})"),
                    ))
                }
            };
            for (s, &c) in spheres.iter_mut().zip(&self.sphere_centers) {
                s.center = to_render("objects.center", c)?;
            }
            for (q, &c) in quads.iter_mut().zip(&self.quad_corners) {
                q.corner = to_render("objects.corner", c)?;
            }
            for g in &mut sdf_grids {
                g.map_f64.translation -= origin;
                g.map = Quadric::placed(QUADRIC_SDF, g.map_f64, false, g.map.material).ok_or_else(
                    || {
                        SceneError::invalid(
                            "objects.transform",
                            format!(
                                "a grid is not finite in f32 in render space (origin {origin})"
                            ),
                        )
                    },
                )?;
            }
            for (q, m) in quadrics.iter_mut().zip(&self.quadric_maps) {
                let mut m = *m;
                m.translation -= origin;
                *q = Quadric::placed(q.kind, m, q.flip, q.material).ok_or_else(|| {
                    SceneError::invalid(
                        "objects.transform",
                        format!("a quadric is not finite in f32 in render space (origin {origin})"),
                    )
                })?;
            }
            // A group's vertices stay in its object space.
            let mut grouped = vec![false; self.positions.len()];
            for g in &self.groups {
                grouped[g.vertices.start as usize..g.vertices.end as usize].fill(true);
            }
            for ((m, &p), grouped) in mesh.positions.iter_mut().zip(&self.positions).zip(grouped) {
                if !grouped {
                    *m = to_render("objects.positions", p)?;
                }
            }
            for (i, (l, &p)) in punctual_lights
                .iter_mut()
                .zip(&self.light_positions)
                .enumerate()
            {
                if l.tag != punctual_tag::DIRECTIONAL {
                    l.position = to_render(&format!("lights[{i}].position"), p)?;
                }
            }
        }
        let render_camera = CameraSettings {
            look_from: (from - origin).as_vec3(),
            look_at: (at - origin).as_vec3(),
            ..self.camera
        };
        if origin != DVec3::ZERO {
            render_camera.validate()?;
        }
        // The groups' trees (over their triangles, in object space), then
        // each instance's box: its group's root box under its map.
        let group_trees: Vec<(Bvh, BvhBuildStats)> = self
            .groups
            .iter()
            .map(|g| {
                let bounds: Vec<Aabb> = triangles
                    [g.triangles.start as usize..g.triangles.end as usize]
                    .iter()
                    .map(|t| t.bounds(&mesh))
                    .collect();
                Bvh::build_batched(&bounds, &vec![true; bounds.len()])
            })
            .collect();
        let instances = self
            .instances
            .iter()
            .map(|&(group, mut m)| {
                m.translation -= origin;
                let root = group_trees[group as usize].0.nodes()[0].bounds();
                Instance::placed(m, group, root).ok_or_else(|| {
                    SceneError::invalid(
                        "objects.transform",
                        format!(
                            "an instance is not finite in f32 in render space (origin {origin})"
                        ),
                    )
                })
            })
            .collect::<Result<Vec<Instance>, SceneError>>()?;
        let bounds: Vec<Aabb> = self
            .primitives
            .iter()
            .map(|&p| {
                let objects = Objects {
                    quadrics: &quadrics,
                    grids: &sdf_grids,
                    voxels: &self.sdf_voxels,
                    instances: &instances,
                };
                primitive_bounds(p, &spheres, &quads, objects, &triangles, &mesh)
            })
            .collect();
        let batched: Vec<bool> = self.primitives.iter().map(|p| batched(p.tag)).collect();
        let (bvh, bvh_stats) = Bvh::build_batched(&bounds, &batched);
        self.filter.validate()?;
        let mut scene = Scene {
            camera_settings: self.camera,
            render_camera,
            render_space: space,
            render: self.render,
            filter: self.filter,
            filter_table: self.filter.table().map(std::sync::Arc::new),
            emitter_weights: match self.emitter_weights {
                None => None,
                Some(w) => Some(w.checked(self.primitives.len(), punctual_lights.len())?),
            },
            background,
            spheres,
            quads,
            quadrics,
            sdf_grids,
            sdf_voxels: self.sdf_voxels,
            triangles,
            mesh,
            materials: self.materials,
            alphas,
            emissions,
            wraps,
            textures,
            images: self.images,
            punctual_lights,
            primitives: self.primitives,
            groups: Vec::new(),
            instances,
            accel: Accel::default(),
            bvh_stats,
            warnings: self.warnings,
            sources: {
                let mut seen = std::collections::HashSet::new();
                self.sources
                    .into_iter()
                    .filter(|p| seen.insert(p.clone()))
                    .collect()
            },
        };
        scene.groups = self
            .groups
            .iter()
            .zip(group_trees)
            .map(|(g, (tree, _))| {
                let first = g.triangles.start;
                Group {
                    triangles: g.triangles.clone(),
                    accel: Accel::new(tree, |i| scene.group_leaf_prim(first + i)),
                }
            })
            .collect();
        scene.put_bvh(bvh);
        Ok(scene)
    }
}

/// A group's triangles have no coverage (an alpha) and emit nothing: the
/// walk within a group tests no coverage, and a light is sampled as a
/// primitive of the scene, which a group's triangle is not.
fn check_groups(
    groups: impl IntoIterator<Item = std::ops::Range<u32>>,
    triangles: &[Triangle],
    materials: &[Material],
    alphas: &[Option<Alpha>],
    emissions: &[Option<u32>],
) -> Result<(), SceneError> {
    for g in groups {
        for t in &triangles[g.start as usize..g.end as usize] {
            let m = t.material as usize;
            if alphas[m].is_some() {
                return Err(SceneError::invalid(
                    "group",
                    format!(
                        "material {m} has an alpha (coverage), which an instanced mesh cannot have"
                    ),
                ));
            }
            if emissions[m].is_some() || matches!(materials[m], Material::DiffuseLight { .. }) {
                return Err(SceneError::invalid(
                    "group",
                    format!("material {m} emits, and an instanced mesh cannot be a light"),
                ));
            }
        }
    }
    Ok(())
}

/// `textures` (world meaning) as render space `space` evaluates them, or
/// the other way (the map is its own inverse); an error names a checker
/// whose pattern render space cannot keep.
fn render_textures(space: &RenderSpace, textures: &[Texture]) -> Result<Vec<Texture>, SceneError> {
    textures
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            space.texture(t).ok_or_else(|| {
                SceneError::invalid(
                    &format!("textures[{i}].scale"),
                    format!(
                        "the checker does not repeat at render space's origin {} (a checker \
                         whose scale is not a whole multiple of the scene's checkers' cannot \
                         be added to a scene placed away from the world's origin)",
                        space.origin()
                    ),
                )
            })
        })
        .collect()
}

/// What [`Scene::edited`] may change in a built scene: all but the geometry
/// (and so the BVH) and the images. The camera is in world coordinates
/// and the textures have their world meaning, as the builder took them.
#[derive(Clone, Debug, PartialEq)]
pub struct Appearance {
    pub camera: CameraSettings,
    pub render: RenderSettings,
    pub background: Background,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
}

impl Scene {
    /// This scene with its camera, render settings, background, materials
    /// or textures changed by `edit`, checked again as [`SceneBuilder`]
    /// checks them: the materials' texture references against the edited
    /// textures, and the primitives' material references against the edited
    /// materials. The geometry and its BVH stay (a different shape is a
    /// different scene, built anew). For tests and tools that derive a
    /// variant of a loaded scene: a dimmed albedo, another camera.
    pub fn edited(mut self, edit: impl FnOnce(&mut Appearance)) -> Result<Scene, SceneError> {
        let world_textures = render_textures(&self.render_space, &self.textures)?;
        let mut look = Appearance {
            camera: self.camera_settings,
            render: self.render,
            background: self.background,
            materials: std::mem::take(&mut self.materials),
            textures: world_textures,
        };
        edit(&mut look);
        let images = self.images.len();
        check_view(&look.camera, &look.render, &look.background, images)?;
        for (i, texture) in look.textures.iter().enumerate() {
            check_texture(texture, &look.textures[..i], images)
                .map_err(|e| e.within(&format!("textures[{i}]")))?;
        }
        let textures = render_textures(&self.render_space, &look.textures)?;
        let render_camera = self.render_camera_of(&look.camera);
        if render_camera != self.render_camera {
            render_camera.validate()?;
        }
        for (i, material) in look.materials.iter().enumerate() {
            check_material(material, look.textures.len(), &self.images)
                .map_err(|e| e.within(&format!("materials[{i}]")))?;
        }
        for alpha in self.alphas.iter().flatten() {
            check_alpha(alpha, look.textures.len()).map_err(|e| e.within("alphas"))?;
        }
        for (i, wrap) in self.wraps.iter().enumerate() {
            if let Some(material) = look.materials.get(i) {
                check_wrap(material, wrap, &look.textures)
                    .map_err(|e| e.within(&format!("materials[{i}]")))?;
            }
        }
        check_blends(&look.materials, &self.wraps)?;
        // An edit may make an emissive material a light, whose own
        // emission is then the one read (`Scene::added_emission`).
        for (i, emission) in self.emissions.iter().enumerate() {
            if let Some(e) = emission.filter(|&e| e as usize >= look.textures.len()) {
                return Err(SceneError::invalid(
                    &format!("materials[{i}].emission"),
                    format!("texture index {e} does not exist"),
                ));
            }
        }
        let used = (self.spheres.iter().map(|s| s.material))
            .chain(self.quads.iter().map(|q| q.material))
            .chain(self.quadrics.iter().map(|q| q.material))
            .chain(self.sdf_grids.iter().map(|g| g.map.material))
            .chain(self.triangles.iter().map(|t| t.material))
            .max();
        if let Some(m) = used.filter(|&m| m as usize >= look.materials.len()) {
            return Err(SceneError::invalid(
                "materials",
                format!(
                    "a primitive uses material {m}, but only {} remain",
                    look.materials.len()
                ),
            ));
        }
        // What the builder refuses of a group's triangles, under the
        // edited materials (an edit may make theirs a light).
        check_groups(
            self.groups.iter().map(|g| g.triangles()),
            &self.triangles,
            &look.materials,
            &self.alphas,
            &self.emissions,
        )?;
        self.camera_settings = look.camera;
        self.render_camera = render_camera;
        self.render = look.render;
        self.background = look.background;
        self.materials = look.materials;
        self.textures = textures;
        Ok(self)
    }

    /// This scene over another BVH, with the traversal's copies of the
    /// geometry remade in its leaf order: for tests that hand-edit a tree
    /// ([`Bvh::from_parts`], which checks its layout), so that the edit
    /// reaches the traversal. Refused if the tree indexes a primitive the
    /// scene lacks.
    pub fn with_bvh(mut self, bvh: Bvh) -> Result<Scene, SceneError> {
        let count = self.primitives.len();
        if let Some(p) = bvh.prim_order().iter().find(|&&p| p as usize >= count) {
            return Err(SceneError::invalid(
                "bvh",
                format!("the tree indexes primitive {p} of a scene of {count}"),
            ));
        }
        self.put_bvh(bvh);
        Ok(self)
    }
}
