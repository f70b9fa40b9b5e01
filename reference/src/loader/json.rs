//! The JSON scene format (see docs/scene-format.md for every field, its
//! unit and its default). Parsing is strict: unknown fields and unknown
//! `type` values are errors, reported as `file:line:column: field: message`.
//! Semantic errors (a bad radius, an unknown material name) name the file
//! and the field path, e.g. `objects[3].radius`.

use crate::background::{turn_about_y, Background, EnvRows};
use crate::camera::{CameraSettings, Projection};
use crate::error::SceneError;
use crate::filter::PixelFilter;
use crate::loader::gltf::{GltfLightUnits, GltfOptions};
use crate::loader::image::load_image;
use crate::material::{Blend, ClearCoat, Material, PrincipledLobes, Wrappers};
use crate::microfacet;
use crate::scene::{LightInput, RenderOrigin, RenderSettings, Scene, SceneBuilder, Transform};
use crate::texture::{Sampler, Texture};
use glam::{DQuat, DVec3, Vec3};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

/// A colour field: `[r, g, b]` or the name of a texture.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorRef {
    Rgb(Vec3),
    Texture(String),
}

impl<'de> Deserialize<'de> for ColorRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ColorRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a colour [r, g, b] or the name of a texture")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<ColorRef, E> {
                Ok(ColorRef::Texture(v.to_string()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<ColorRef, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, x) in c.iter_mut().enumerate() {
                    *x = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(ColorRef::Rgb(Vec3::from(c)))
            }
        }
        d.deserialize_any(V)
    }
}

/// A number field that may vary over the surface: a number or the name of
/// a texture (whose first channel is read).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged, expecting = "a number or the name of a texture")]
pub enum ScalarRef {
    Value(f32),
    Texture(String),
}

/// A microfacet distribution's name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DistributionJson {
    Ggx,
    /// Mitsuba's default.
    #[default]
    Beckmann,
}

impl DistributionJson {
    /// Its [`microfacet::distribution`] tag.
    pub fn tag(self) -> u32 {
        match self {
            DistributionJson::Ggx => microfacet::distribution::GGX,
            DistributionJson::Beckmann => microfacet::distribution::BECKMANN,
        }
    }
}

/// A uniform or per-axis scale.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged, expecting = "a number or [x, y, z]")]
pub enum ScaleJson {
    Uniform(f64),
    PerAxis([f64; 3]),
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisAngleJson {
    pub axis: [f64; 3],
    /// Degrees.
    pub angle: f64,
}

/// Scale, then rotations (x, y, z, or axis-angle), then translation; read
/// and composed in f64 (rounded to f32 only in render space).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformJson {
    pub scale: Option<ScaleJson>,
    pub rotate_x: Option<f64>,
    pub rotate_y: Option<f64>,
    pub rotate_z: Option<f64>,
    pub rotate: Option<AxisAngleJson>,
    pub translate: Option<[f64; 3]>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraJson {
    /// Read in f64: render space is placed by the file's numbers.
    pub look_from: [f64; 3],
    pub look_at: [f64; 3],
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    #[serde(default = "default_vfov")]
    pub vfov: f32,
    #[serde(default)]
    pub aperture: f32,
    /// Defaults to the distance from `look_from` to `look_at`.
    pub focus_distance: Option<f32>,
    #[serde(default)]
    pub projection: ProjectionJson,
    /// The orthographic window's height (scene units); required with
    /// `"projection": "orthographic"`, refused otherwise.
    pub height: Option<f32>,
}

/// `camera.projection`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProjectionJson {
    #[default]
    Perspective,
    Orthographic,
}

impl CameraJson {
    /// The camera it describes (the focus distance, where not given, the
    /// distance from `look_from` to `look_at`); unchecked:
    /// `CameraSettings::validate` checks it.
    pub fn settings(&self) -> CameraSettings {
        let (from, at) = self.positions();
        let projection = match self.projection {
            ProjectionJson::Perspective => Projection::Perspective,
            // `check` has seen the height.
            ProjectionJson::Orthographic => Projection::Orthographic {
                height: self.height.unwrap_or(0.0),
            },
        };
        CameraSettings {
            look_from: from.as_vec3(),
            look_at: at.as_vec3(),
            up: Vec3::from(self.up),
            vfov: self.vfov,
            aperture: self.aperture,
            focus_distance: self
                .focus_distance
                .unwrap_or((at.as_vec3() - from.as_vec3()).length()),
            projection,
        }
    }

    /// What serde cannot say: an orthographic camera's `height` given, and
    /// only there.
    pub fn check(&self) -> Result<(), SceneError> {
        match (self.projection, self.height) {
            (ProjectionJson::Orthographic, None) => Err(SceneError::invalid(
                "camera.height",
                "an orthographic camera needs its window's height".into(),
            )),
            (ProjectionJson::Perspective, Some(_)) => Err(SceneError::invalid(
                "camera.height",
                "only an orthographic camera has a height (a perspective one has vfov)".into(),
            )),
            _ => Ok(()),
        }
    }

    /// `look_from` and `look_at` as the file gives them, in f64.
    pub fn positions(&self) -> (DVec3, DVec3) {
        (DVec3::from(self.look_from), DVec3::from(self.look_at))
    }
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_vfov() -> f32 {
    40.0
}

#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderJson {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u32>,
    pub roulette_depth: Option<u32>,
    /// `independent` or `sobol` ([`crate::rng::Sampler`]).
    pub sampler: Option<String>,
}

impl RenderJson {
    /// The sampler `render.sampler` names, else `default`.
    pub fn sampler_or(
        &self,
        default: crate::rng::Sampler,
    ) -> Result<crate::rng::Sampler, SceneError> {
        match self.sampler.as_deref() {
            None => Ok(default),
            Some(name) => crate::rng::Sampler::from_name(name).ok_or_else(|| {
                SceneError::invalid(
                    "render.sampler",
                    format!("unknown sampler {name:?} (expected \"independent\" or \"sobol\")"),
                )
            }),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum BackgroundJson {
    Solid(SolidBackgroundJson),
    Sky(SkyBackgroundJson),
    Envmap(EnvmapBackgroundJson),
}

fn default_horizon() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}
fn default_zenith() -> [f32; 3] {
    [0.5, 0.7, 1.0]
}
fn one() -> f32 {
    1.0
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum TextureJson {
    Constant(ConstantTextureJson),
    Checker(CheckerTextureJson),
    Image(ImageTextureJson),
    UvChecker(UvCheckerTextureJson),
}

fn default_checker_scale() -> f32 {
    10.0
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum MaterialJson {
    Lambertian(LambertianMaterialJson),
    Metal(MetalMaterialJson),
    Dielectric(DielectricMaterialJson),
    DiffuseLight(DiffuseLightMaterialJson),
    Ggx(GgxMaterialJson),
    Conductor(ConductorMaterialJson),
    RoughConductor(RoughConductorMaterialJson),
    SmoothDielectric(SmoothDielectricMaterialJson),
    /// The same fields, `eta` the sheet's index over its surroundings'.
    ThinDielectric(SmoothDielectricMaterialJson),
    RoughDielectric(RoughDielectricMaterialJson),
    Plastic(PlasticMaterialJson),
    RoughPlastic(RoughPlasticMaterialJson),
    Mask(MaskMaterialJson),
    OneSided(OneSidedMaterialJson),
    NormalMapped(NormalMappedMaterialJson),
    BumpMapped(BumpMappedMaterialJson),
    Blend(BlendMaterialJson),
    Principled(PrincipledMaterialJson),
    /// Mitsuba 3's `principledthin`: the same fields but `metallic`,
    /// `clearcoat`, `clearcoat_gloss` and `specular`, with `diff_trans`;
    /// `eta` 1.5 by default.
    PrincipledThin(PrincipledMaterialJson),
    /// Mitsuba 3's `null`: a surface light passes straight through.
    Null(NullMaterialJson),
}

/// Mitsuba 3's `null` (no parameters): `reference::scene::SceneBuilder::null_material`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NullMaterialJson {}

/// Mitsuba 3's `principled` (`reference::principled`): its parameters as
/// Mitsuba's, each number a number or the name of a texture (its value, or
/// a colour's luminance); a lobe absent or given as 0 is off.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrincipledMaterialJson {
    #[serde(default = "default_principled_base")]
    pub base_color: ColorRef,
    #[serde(default = "default_opacity")]
    pub roughness: ScalarRef,
    #[serde(default)]
    pub anisotropic: Option<ScalarRef>,
    #[serde(default)]
    pub spec_trans: Option<ScalarRef>,
    #[serde(default)]
    pub metallic: Option<ScalarRef>,
    #[serde(default)]
    pub clearcoat: Option<ScalarRef>,
    #[serde(default)]
    pub clearcoat_gloss: Option<ScalarRef>,
    #[serde(default)]
    pub sheen: Option<ScalarRef>,
    #[serde(default)]
    pub sheen_tint: Option<ScalarRef>,
    #[serde(default)]
    pub flatness: Option<ScalarRef>,
    #[serde(default)]
    pub spec_tint: Option<ScalarRef>,
    /// `principled_thin`'s diffuse transmission, 0 to 2.
    #[serde(default)]
    pub diff_trans: Option<ScalarRef>,
    /// The interior's index over the exterior's; or `specular` (default
    /// 0.5) standing for one, as Mitsuba's: give at most one.
    #[serde(default)]
    pub eta: Option<f32>,
    #[serde(default)]
    pub specular: Option<f32>,
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

fn default_principled_base() -> ColorRef {
    ColorRef::Rgb(Vec3::splat(0.5))
}

/// Mitsuba 3's `blendbsdf` of two other materials (by name):
/// `(1 − weight)·first + weight·second` (`reference::material::Blend`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlendMaterialJson {
    pub materials: [String; 2],
    /// A number or a texture (its value, or for a colour its luminance),
    /// in [0, 1] (Mitsuba's default 0.5): the second's share.
    #[serde(default = "default_opacity")]
    pub weight: ScalarRef,
}

/// Mitsuba 3's `mask` around another material (by name): where a path
/// meets it, it scatters as that material with probability `opacity` and
/// passes straight on otherwise (`reference::material::Wrappers`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaskMaterialJson {
    pub material: String,
    /// A number or a texture (its value, or for a colour its luminance),
    /// in [0, 1] (Mitsuba's default 0.5).
    #[serde(default = "default_opacity")]
    pub opacity: ScalarRef,
}

/// Mitsuba 3's `normalmap` around another material (by name): the
/// texture's value `c` is the normal `2c − 1` in the surface's tangent
/// frame, in which the material then shades
/// (`reference::material::NormalMapped`; read as data, so an image should
/// be linear).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormalMappedMaterialJson {
    pub material: String,
    pub normal_map: ColorRef,
}

/// Mitsuba 3's `bumpmap` around another material (by name): the surface's
/// normal bent by the gradient of a height (`bump_map`, an image read
/// through the first uv set, its one-channel value: the grey or the
/// luminance) times `scale` (at least 0; default 1), per unit of uv
/// (`reference::material::NormalMapped::bumped`; read as data, so an
/// image should be linear).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumpMappedMaterialJson {
    pub material: String,
    pub bump_map: ColorRef,
    #[serde(default = "default_bump_scale")]
    pub scale: f32,
}

fn default_bump_scale() -> f32 {
    1.0
}

fn default_opacity() -> ScalarRef {
    ScalarRef::Value(0.5)
}

/// Another material (by name) made one-sided, as Mitsuba's models are
/// without `twosided`: it absorbs paths that arrive behind it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OneSidedMaterialJson {
    pub material: String,
}

fn default_roughness() -> f32 {
    0.5
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ObjectJson {
    Sphere(SphereJson),
    Quad(QuadJson),
    Box(BoxJson),
    Mesh(MeshJson),
    Gltf(GltfJson),
}

/// A punctual light (docs/scene-format.md, "Lights"): positions in world
/// coordinates, read in f64; directions are the way the light travels.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LightJson {
    Point(PointLightJson),
    Spot(SpotLightJson),
    Directional(DirectionalLightJson),
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightJson {
    pub position: [f64; 3],
    /// Radiant intensity, W/sr per channel.
    pub intensity: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightJson {
    pub position: [f64; 3],
    pub direction: [f32; 3],
    /// Radiant intensity on the axis, W/sr per channel.
    pub intensity: [f32; 3],
    /// Degrees from the axis (glTF's defaults: 0 and 45).
    #[serde(default)]
    pub inner_cone_angle: f32,
    #[serde(default = "default_outer_cone_angle")]
    pub outer_cone_angle: f32,
}

fn default_outer_cone_angle() -> f32 {
    45.0
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightJson {
    pub direction: [f32; 3],
    /// Irradiance on a surface facing the light, W/m² per channel.
    pub irradiance: [f32; 3],
}

impl LightJson {
    /// What the builder checks ([`SceneBuilder::add_light`]): angles in
    /// radians.
    pub fn input(&self) -> LightInput {
        match self {
            LightJson::Point(l) => LightInput::Point {
                position: DVec3::from(l.position),
                intensity: Vec3::from(l.intensity),
            },
            LightJson::Spot(l) => LightInput::Spot {
                position: DVec3::from(l.position),
                direction: Vec3::from(l.direction),
                intensity: Vec3::from(l.intensity),
                inner_cone_angle: l.inner_cone_angle.to_radians(),
                outer_cone_angle: l.outer_cone_angle.to_radians(),
            },
            LightJson::Directional(l) => LightInput::Directional {
                direction: Vec3::from(l.direction),
                irradiance: Vec3::from(l.irradiance),
            },
        }
    }
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolidBackgroundJson {
    pub color: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyBackgroundJson {
    #[serde(default = "default_horizon")]
    pub horizon: [f32; 3],
    #[serde(default = "default_zenith")]
    pub zenith: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvmapBackgroundJson {
    pub path: PathBuf,
    #[serde(default = "one")]
    pub intensity: f32,
    #[serde(default)]
    pub rotate_y: f32,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantTextureJson {
    pub color: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerTextureJson {
    #[serde(default = "default_checker_scale")]
    pub scale: f32,
    pub even: ColorRef,
    pub odd: ColorRef,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UvCheckerTextureJson {
    /// Multiplies u and v before the squares are found (default 1, 1:
    /// four squares on the unit square).
    #[serde(default = "default_uv_checker_scale")]
    pub scale: [f32; 2],
    pub even: ColorRef,
    pub odd: ColorRef,
}

fn default_uv_checker_scale() -> [f32; 2] {
    [1.0, 1.0]
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageTextureJson {
    pub path: PathBuf,
    /// Decode the sRGB curve; default: yes for PNG/JPEG, no for HDR/EXR.
    pub srgb: Option<bool>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LambertianMaterialJson {
    pub albedo: ColorRef,
    /// Radiance emitted from the front face, added to what the material
    /// reflects (`reference::Scene::emission`); absent or black: none.
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetalMaterialJson {
    pub albedo: ColorRef,
    #[serde(default)]
    pub fuzz: f32,
    /// Radiance emitted from the front face, added to what the material
    /// reflects (`reference::Scene::emission`); absent or black: none.
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

/// A smooth conductor (Mitsuba 3's `conductor`): a mirror of Fresnel
/// reflectance `F(cos θ, eta + i·k)` per channel, times `specular`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConductorMaterialJson {
    /// The complex index's real part per channel (0: a perfect mirror with
    /// the default `k`).
    #[serde(default)]
    pub eta: [f32; 3],
    /// Its imaginary part (the extinction coefficient) per channel.
    #[serde(default = "unit_k")]
    pub k: [f32; 3],
    /// A tint on the reflectance (default white).
    #[serde(default)]
    pub specular: Option<ColorRef>,
    /// Radiance emitted from the front face, added to what the material
    /// reflects (`reference::Scene::emission`); absent or black: none.
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

/// A rough conductor (Mitsuba 3's `roughconductor`): microfacets of the
/// `distribution`, each reflecting as the smooth conductor.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughConductorMaterialJson {
    /// `ggx` or `beckmann` (default, as Mitsuba's).
    #[serde(default)]
    pub distribution: DistributionJson,
    /// The microfacets' roughness α (Mitsuba's default 0.1): in every
    /// direction, or along the surface's tangent where `alpha_v` is given.
    #[serde(default = "default_alpha")]
    pub alpha: ScalarRef,
    /// The roughness across the tangent (anisotropic; absent: isotropic).
    #[serde(default)]
    pub alpha_v: Option<ScalarRef>,
    #[serde(default)]
    pub eta: [f32; 3],
    #[serde(default = "unit_k")]
    pub k: [f32; 3],
    #[serde(default)]
    pub specular: Option<ColorRef>,
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

fn default_alpha() -> ScalarRef {
    ScalarRef::Value(0.1)
}

/// A smooth dielectric with the exact Fresnel equations (Mitsuba 3's
/// `dielectric`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SmoothDielectricMaterialJson {
    /// The index inside (behind the geometric normal) over outside.
    pub eta: f32,
    /// Tints on what it reflects and transmits (default white).
    #[serde(default)]
    pub reflectance: Option<ColorRef>,
    #[serde(default)]
    pub transmittance: Option<ColorRef>,
    /// Radiance emitted from the front face, added to what the material
    /// reflects (`reference::Scene::emission`); absent or black: none.
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

/// A rough dielectric (Mitsuba 3's `roughdielectric`): microfacets of
/// the `distribution`, each an interface as the smooth dielectric's.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughDielectricMaterialJson {
    /// `ggx` or `beckmann` (default, as Mitsuba's).
    #[serde(default)]
    pub distribution: DistributionJson,
    /// The microfacets' roughness α (Mitsuba's default 0.1): in every
    /// direction, or along the surface's tangent where `alpha_v` is given.
    #[serde(default = "default_alpha")]
    pub alpha: ScalarRef,
    /// The roughness across the tangent (anisotropic; absent: isotropic).
    #[serde(default)]
    pub alpha_v: Option<ScalarRef>,
    /// The index inside (behind the geometric normal) over outside.
    pub eta: f32,
    /// Tints on what it reflects and transmits (default white).
    #[serde(default)]
    pub reflectance: Option<ColorRef>,
    #[serde(default)]
    pub transmittance: Option<ColorRef>,
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

/// A smooth plastic (Mitsuba 3's `plastic`): a diffuse base under a
/// smooth dielectric coat.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlasticMaterialJson {
    /// The base's diffuse reflectance.
    pub diffuse: ColorRef,
    /// A tint on what the coat reflects (default white).
    #[serde(default)]
    pub specular: Option<ColorRef>,
    /// The coat's index over the outside's.
    pub eta: f32,
    /// The base's colour compounded at each reflection inside the coat
    /// (Mitsuba's `nonlinear`; default false).
    #[serde(default)]
    pub nonlinear: bool,
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

/// A rough plastic (Mitsuba 3's `roughplastic`): the plastic's base
/// under a rough dielectric coat.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughPlasticMaterialJson {
    /// `ggx` or `beckmann` (default, as Mitsuba's).
    #[serde(default)]
    pub distribution: DistributionJson,
    /// The coat's roughness α (a number, isotropic; Mitsuba's default 0.1).
    #[serde(default = "default_plastic_alpha")]
    pub alpha: f32,
    /// The base's diffuse reflectance.
    pub diffuse: ColorRef,
    /// A tint on what the coat reflects (default white).
    #[serde(default)]
    pub specular: Option<ColorRef>,
    /// The coat's index over the outside's.
    pub eta: f32,
    /// The base's colour compounded at each reflection inside the coat
    /// (Mitsuba's `nonlinear`; default false).
    #[serde(default)]
    pub nonlinear: bool,
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

fn default_plastic_alpha() -> f32 {
    0.1
}

fn unit_k() -> [f32; 3] {
    [1.0; 3]
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DielectricMaterialJson {
    pub ior: f32,
    #[serde(default)]
    pub absorption: [f32; 3],
    /// Radiance emitted from the front face, added to what the material
    /// reflects (`reference::Scene::emission`); absent or black: none.
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseLightMaterialJson {
    pub emission: ColorRef,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GgxMaterialJson {
    pub base_color: ColorRef,
    #[serde(default)]
    pub metallic: f32,
    #[serde(default = "default_roughness")]
    pub roughness: f32,
    /// The clear coat's weight (0: none) and roughness
    /// (`reference::material::ClearCoat`).
    #[serde(default)]
    pub clearcoat: f32,
    #[serde(default)]
    pub clearcoat_roughness: f32,
    /// Radiance emitted from the front face, added to what the material
    /// reflects (`reference::Scene::emission`); absent or black: none.
    #[serde(default)]
    pub emission: Option<ColorRef>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereJson {
    pub center: [f64; 3],
    pub radius: f32,
    pub material: String,
    #[serde(default)]
    pub transform: TransformJson,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadJson {
    pub corner: [f64; 3],
    pub u: [f32; 3],
    pub v: [f32; 3],
    pub material: String,
    #[serde(default)]
    pub transform: TransformJson,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxJson {
    pub min: [f64; 3],
    pub max: [f64; 3],
    pub material: String,
    #[serde(default)]
    pub transform: TransformJson,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshJson {
    pub path: PathBuf,
    pub material: String,
    #[serde(default)]
    pub transform: TransformJson,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GltfJson {
    pub path: PathBuf,
    #[serde(default)]
    pub transform: TransformJson,
    /// The units of the document's `KHR_lights_punctual` intensities
    /// (default: the loader's, photometric unless told otherwise).
    pub light_units: Option<LightUnitsJson>,
}

/// `gltf.light_units`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightUnitsJson {
    Photometric,
    Radiometric,
}

/// A whole scene document.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneJson {
    pub camera: Option<CameraJson>,
    /// Where render space's origin lies, in world coordinates (default:
    /// the camera's `look_from`; either moved to the checkers' lattice).
    pub render_origin: Option<[f64; 3]>,
    #[serde(default)]
    pub render: RenderJson,
    pub background: Option<BackgroundJson>,
    #[serde(default)]
    pub textures: BTreeMap<String, TextureJson>,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialJson>,
    pub objects: Vec<ObjectJson>,
    /// Point, spot and directional lights.
    #[serde(default)]
    pub lights: Vec<LightJson>,
    /// How each pixel's camera samples are spread (default: the box).
    pub filter: Option<FilterJson>,
}

/// The scene's pixel filter (`reference::filter::PixelFilter`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum FilterJson {
    Box,
    Gaussian {
        #[serde(default = "default_gaussian_stddev")]
        stddev: f32,
    },
}

fn default_gaussian_stddev() -> f32 {
    0.5
}

/// Parses a scene document; errors carry the path to the field and the
/// line and column.
pub fn parse_scene_json(text: &str, path: &Path) -> Result<SceneJson, SceneError> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let parsed: Result<SceneJson, _> = serde_path_to_error::deserialize(&mut *de);
    // Nothing but whitespace may follow the scene's object: `{...} }}}` is
    // a broken file, not a scene.
    if parsed.is_ok() {
        if let Err(e) = de.end() {
            return Err(SceneError::Parse {
                path: path.to_path_buf(),
                line: e.line(),
                column: e.column(),
                field: "(document)".into(),
                message: "trailing characters after the scene's JSON object".into(),
            });
        }
    }
    parsed.map_err(|e| {
        let mut field = e.path().to_string();
        let inner = e.inner();
        let mut message = strip_location(&inner.to_string());
        // Internally tagged enums (`"type": ...`) buffer their content, so
        // the path stops at the element; find the field inside it.
        if let Some((sub, msg)) = refine_tagged_error(text, &field) {
            field = format!("{field}.{sub}");
            message = msg;
        }
        SceneError::Parse {
            path: path.to_path_buf(),
            line: inner.line(),
            column: inner.column(),
            field: if field == "." {
                "(document)".into()
            } else {
                field
            },
            message,
        }
    })
}

/// serde_json appends " at line L column C"; the error prints those first.
fn strip_location(full: &str) -> String {
    full.rsplit_once(" at line ")
        .map_or(full, |(m, _)| m)
        .to_string()
}

/// The error of deserializing `value` as `T`, with its inner path.
fn inner_error<T: serde::de::DeserializeOwned>(
    value: serde_json::Value,
) -> Option<(String, String)> {
    serde_path_to_error::deserialize::<_, T>(value)
        .err()
        .map(|e| (e.path().to_string(), strip_location(&e.inner().to_string())))
}

/// Re-deserializes the tagged element at `field` (`objects[3]`,
/// `materials.NAME`, `textures.NAME`, `background`) as its variant's
/// struct to learn which field inside it is wrong.
fn refine_tagged_error(text: &str, field: &str) -> Option<(String, String)> {
    let doc: serde_json::Value = serde_json::from_str(text).ok()?;
    let (family, node) = if let Some(rest) = field.strip_prefix("objects[") {
        (
            "objects",
            doc.get("objects")?
                .get(rest.strip_suffix(']')?.parse::<usize>().ok()?)?,
        )
    } else if let Some(name) = field.strip_prefix("materials.") {
        ("materials", doc.get("materials")?.get(name)?)
    } else if let Some(name) = field.strip_prefix("textures.") {
        ("textures", doc.get("textures")?.get(name)?)
    } else if let Some(rest) = field.strip_prefix("lights[") {
        (
            "lights",
            doc.get("lights")?
                .get(rest.strip_suffix(']')?.parse::<usize>().ok()?)?,
        )
    } else if field == "background" {
        ("background", doc.get("background")?)
    } else {
        return None;
    };
    let mut map = node.as_object()?.clone();
    let tag = map.remove("type")?;
    let v = serde_json::Value::Object(map);
    let refined = match (family, tag.as_str()?) {
        ("objects", "sphere") => inner_error::<SphereJson>(v),
        ("objects", "quad") => inner_error::<QuadJson>(v),
        ("objects", "box") => inner_error::<BoxJson>(v),
        ("objects", "mesh") => inner_error::<MeshJson>(v),
        ("objects", "gltf") => inner_error::<GltfJson>(v),
        ("materials", "lambertian") => inner_error::<LambertianMaterialJson>(v),
        ("materials", "metal") => inner_error::<MetalMaterialJson>(v),
        ("materials", "dielectric") => inner_error::<DielectricMaterialJson>(v),
        ("materials", "diffuse_light") => inner_error::<DiffuseLightMaterialJson>(v),
        ("materials", "ggx") => inner_error::<GgxMaterialJson>(v),
        ("textures", "constant") => inner_error::<ConstantTextureJson>(v),
        ("textures", "checker") => inner_error::<CheckerTextureJson>(v),
        ("textures", "image") => inner_error::<ImageTextureJson>(v),
        ("lights", "point") => inner_error::<PointLightJson>(v),
        ("lights", "spot") => inner_error::<SpotLightJson>(v),
        ("lights", "directional") => inner_error::<DirectionalLightJson>(v),
        ("background", "solid") => inner_error::<SolidBackgroundJson>(v),
        ("background", "sky") => inner_error::<SkyBackgroundJson>(v),
        ("background", "envmap") => inner_error::<EnvmapBackgroundJson>(v),
        _ => None,
    };
    // A path of "." is the element itself (a missing field): the original
    // error already says that.
    refined.filter(|(p, _)| p != ".")
}

/// Reads, parses and builds a scene file.
pub fn load_json_scene(path: &Path) -> Result<Scene, SceneError> {
    load_json_scene_with(path, &GltfOptions::default())
}

/// [`load_json_scene`], its `gltf` objects read with `gltf` where they do
/// not say otherwise.
pub fn load_json_scene_with(path: &Path, gltf: &GltfOptions) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
        path: path.to_path_buf(),
        message: format!("cannot read scene: {e}"),
    })?;
    load_json_scene_text_with(path, &text, gltf)
}

/// [`load_json_scene`] of a scene file already in memory (`text`, named
/// `path`; a view file is the loader's to tell apart,
/// `crate::loader::load_scene_text`): nothing is read from disk but the
/// files it refers to, relative to `path`'s folder.
pub fn load_json_scene_text_with(
    path: &Path,
    text: &str,
    gltf: &GltfOptions,
) -> Result<Scene, SceneError> {
    let doc = parse_scene_json(text, path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    build(&doc, base, vec![path.to_path_buf()], gltf).map_err(|e| e.in_file(path))
}

impl TransformJson {
    pub fn to_transform(&self) -> Result<Transform, SceneError> {
        let scale = match self.scale {
            None => DVec3::ONE,
            Some(ScaleJson::Uniform(s)) => DVec3::splat(s),
            Some(ScaleJson::PerAxis(s)) => DVec3::from(s),
        };
        if !scale.is_finite() || scale.cmpeq(DVec3::ZERO).any() {
            return Err(SceneError::invalid(
                "scale",
                format!("{scale} must be finite and non-zero"),
            ));
        }
        let xyz = self.rotate_x.is_some() || self.rotate_y.is_some() || self.rotate_z.is_some();
        let rotation = match &self.rotate {
            Some(_) if xyz => {
                return Err(SceneError::invalid(
                    "rotate",
                    "give either rotate or rotate_x/rotate_y/rotate_z, not both".into(),
                ))
            }
            Some(AxisAngleJson { axis, angle }) => {
                let axis = DVec3::from(*axis).try_normalize().ok_or_else(|| {
                    SceneError::invalid(
                        "rotate.axis",
                        "the axis must be a finite non-zero vector".into(),
                    )
                })?;
                if !angle.is_finite() {
                    return Err(SceneError::invalid(
                        "rotate.angle",
                        format!("{angle} is not finite"),
                    ));
                }
                DQuat::from_axis_angle(axis, angle.to_radians())
            }
            None => Transform::rotation_xyz(
                self.rotate_x.unwrap_or(0.0),
                self.rotate_y.unwrap_or(0.0),
                self.rotate_z.unwrap_or(0.0),
            ),
        };
        let translate = DVec3::from(self.translate.unwrap_or([0.0; 3]));
        let t = Transform::from_parts_f64(scale, rotation, translate);
        if !t.is_finite() {
            return Err(SceneError::invalid(
                "",
                "the transform is not finite".into(),
            ));
        }
        Ok(t)
    }
}

/// Turns names into indices while building.
struct Resolver<'a> {
    doc: &'a SceneJson,
    base: &'a Path,
    /// How `gltf` objects are read where they do not say.
    gltf: GltfOptions,
    builder: SceneBuilder,
    textures: HashMap<String, u32>,
    materials: HashMap<String, u32>,
    images: HashMap<(PathBuf, Option<bool>), u32>,
    /// The wrapping materials being read (`mask`, `one_sided`), outermost
    /// first: a name met again is a loop.
    wrapping: Vec<String>,
}

impl Resolver<'_> {
    fn image(&mut self, rel: &Path, srgb: Option<bool>) -> Result<u32, SceneError> {
        let path = self.base.join(rel);
        if let Some(&id) = self.images.get(&(path.clone(), srgb)) {
            return Ok(id);
        }
        self.builder.sources.push(path.clone());
        let img = load_image(&path, srgb)?;
        let id = self.builder.add_image(img);
        self.images.insert((path, srgb), id);
        Ok(id)
    }

    /// A checker's two textures (texture `name`'s `even` and `odd`).
    fn pattern_leaves(
        &mut self,
        name: &str,
        even: &ColorRef,
        odd: &ColorRef,
        depth: u32,
    ) -> Result<(u32, u32), SceneError> {
        let even = self
            .colour(even, depth + 1)
            .map_err(|e| e.within(&format!("textures.{name}.even")))?;
        let odd = self
            .colour(odd, depth + 1)
            .map_err(|e| e.within(&format!("textures.{name}.odd")))?;
        Ok((even, odd))
    }

    /// A colour field as a texture index (constants become textures).
    /// An optional colour, white where absent.
    fn colour_or_white(&mut self, c: Option<&ColorRef>) -> Result<u32, SceneError> {
        match c {
            Some(c) => self.colour(c, 0),
            None => self.builder.constant(Vec3::ONE),
        }
    }

    /// A number field as a texture index (numbers become grey constants).
    fn scalar(&mut self, c: &ScalarRef) -> Result<u32, SceneError> {
        match c {
            ScalarRef::Value(v) => self.builder.constant(Vec3::splat(*v)),
            ScalarRef::Texture(name) => self.texture(name, 0),
        }
    }

    fn colour(&mut self, c: &ColorRef, depth: u32) -> Result<u32, SceneError> {
        match c {
            ColorRef::Rgb(rgb) => self.builder.constant(*rgb),
            ColorRef::Texture(name) => self.texture(name, depth),
        }
    }

    fn texture(&mut self, name: &str, depth: u32) -> Result<u32, SceneError> {
        if let Some(&id) = self.textures.get(name) {
            return Ok(id);
        }
        let doc = self.doc;
        let Some(t) = doc.textures.get(name) else {
            let known: Vec<&str> = doc.textures.keys().map(String::as_str).collect();
            return Err(SceneError::invalid(
                "",
                format!(
                    "unknown texture `{name}` (defined: {})",
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            ));
        };
        if depth > 1 {
            return Err(SceneError::invalid(
                &format!("textures.{name}"),
                "a checker cannot nest another checker".into(),
            ));
        }
        let at = |e: SceneError| e.within(&format!("textures.{name}"));
        let id = match t {
            TextureJson::Constant(ConstantTextureJson { color }) => {
                self.builder.constant(Vec3::from(*color)).map_err(at)?
            }
            TextureJson::Checker(CheckerTextureJson { scale, even, odd }) => {
                let (even, odd) = self.pattern_leaves(name, even, odd, depth)?;
                self.builder
                    .add_texture(Texture::Checker {
                        scale: *scale,
                        even,
                        odd,
                    })
                    .map_err(at)?
            }
            TextureJson::UvChecker(UvCheckerTextureJson { scale, even, odd }) => {
                let (even, odd) = self.pattern_leaves(name, even, odd, depth)?;
                self.builder
                    .add_texture(Texture::UvChecker {
                        sampler: Sampler {
                            transform: Some([scale[0], 0.0, 0.0, 0.0, scale[1], 0.0]),
                            ..Sampler::default()
                        },
                        even,
                        odd,
                    })
                    .map_err(at)?
            }
            TextureJson::Image(ImageTextureJson { path, srgb }) => {
                let image = self.image(path, *srgb)?;
                self.builder
                    .add_texture(Texture::Image {
                        image,
                        factor: Vec3::ONE,
                        sampler: Default::default(),
                    })
                    .map_err(at)?
            }
        };
        self.textures.insert(name.to_string(), id);
        Ok(id)
    }

    fn material(&mut self, name: &str) -> Result<u32, SceneError> {
        if let Some(&id) = self.materials.get(name) {
            return Ok(id);
        }
        let doc = self.doc;
        let Some(m) = doc.materials.get(name) else {
            let known: Vec<&str> = doc.materials.keys().map(String::as_str).collect();
            return Err(SceneError::invalid(
                "material",
                format!(
                    "unknown material `{name}` (defined: {})",
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            ));
        };
        let field =
            |f: &'static str| move |e: SceneError| e.within(&format!("materials.{name}.{f}"));
        let material = match m {
            MaterialJson::Lambertian(LambertianMaterialJson { albedo, .. }) => {
                Material::Lambertian {
                    albedo: self.colour(albedo, 0).map_err(field("albedo"))?,
                }
            }
            MaterialJson::Metal(MetalMaterialJson { albedo, fuzz, .. }) => Material::Metal {
                albedo: self.colour(albedo, 0).map_err(field("albedo"))?,
                fuzz: *fuzz,
            },
            MaterialJson::Dielectric(DielectricMaterialJson {
                ior, absorption, ..
            }) => Material::Dielectric {
                ior: *ior,
                absorption: Vec3::from(*absorption),
            },
            MaterialJson::Conductor(ConductorMaterialJson {
                eta, k, specular, ..
            }) => Material::Conductor {
                specular: self
                    .colour_or_white(specular.as_ref())
                    .map_err(field("specular"))?,
                eta: Vec3::from(*eta),
                k: Vec3::from(*k),
            },
            MaterialJson::RoughConductor(RoughConductorMaterialJson {
                distribution,
                alpha,
                alpha_v,
                eta,
                k,
                specular,
                ..
            }) => Material::RoughConductor {
                distribution: distribution.tag(),
                alpha: self.scalar(alpha).map_err(field("alpha"))?,
                alpha_v: alpha_v
                    .as_ref()
                    .map(|a| self.scalar(a))
                    .transpose()
                    .map_err(field("alpha_v"))?,
                specular: self
                    .colour_or_white(specular.as_ref())
                    .map_err(field("specular"))?,
                eta: Vec3::from(*eta),
                k: Vec3::from(*k),
            },
            MaterialJson::SmoothDielectric(d) | MaterialJson::ThinDielectric(d) => {
                Material::dielectric_of(
                    matches!(m, MaterialJson::ThinDielectric(_)),
                    d.eta,
                    self.colour_or_white(d.reflectance.as_ref())
                        .map_err(field("reflectance"))?,
                    self.colour_or_white(d.transmittance.as_ref())
                        .map_err(field("transmittance"))?,
                )
            }
            MaterialJson::RoughDielectric(d) => Material::RoughDielectric {
                distribution: d.distribution.tag(),
                alpha: self.scalar(&d.alpha).map_err(field("alpha"))?,
                alpha_v: d
                    .alpha_v
                    .as_ref()
                    .map(|a| self.scalar(a))
                    .transpose()
                    .map_err(field("alpha_v"))?,
                eta: d.eta,
                reflectance: self
                    .colour_or_white(d.reflectance.as_ref())
                    .map_err(field("reflectance"))?,
                transmittance: self
                    .colour_or_white(d.transmittance.as_ref())
                    .map_err(field("transmittance"))?,
            },
            MaterialJson::Plastic(p) => {
                let diffuse = self.colour(&p.diffuse, 0).map_err(field("diffuse"))?;
                let specular = self
                    .colour_or_white(p.specular.as_ref())
                    .map_err(field("specular"))?;
                self.builder
                    .plastic(diffuse, specular, p.eta, p.nonlinear)
                    .map_err(|e| e.within(&format!("materials.{name}")))?
            }
            MaterialJson::RoughPlastic(p) => {
                let diffuse = self.colour(&p.diffuse, 0).map_err(field("diffuse"))?;
                let specular = self
                    .colour_or_white(p.specular.as_ref())
                    .map_err(field("specular"))?;
                self.builder
                    .rough_plastic(
                        p.distribution.tag(),
                        p.alpha,
                        (diffuse, specular),
                        p.eta,
                        p.nonlinear,
                    )
                    .map_err(|e| e.within(&format!("materials.{name}")))?
            }
            MaterialJson::DiffuseLight(DiffuseLightMaterialJson { emission }) => {
                Material::DiffuseLight {
                    emission: self.colour(emission, 0).map_err(field("emission"))?,
                }
            }
            MaterialJson::Principled(p) => self
                .principled(p, false)
                .map_err(|e| e.within(&format!("materials.{name}")))?,
            MaterialJson::PrincipledThin(p) => self
                .principled(p, true)
                .map_err(|e| e.within(&format!("materials.{name}")))?,
            MaterialJson::Blend(b) => {
                let id = self.blend_material(name, b)?;
                self.materials.insert(name.to_string(), id);
                return Ok(id);
            }
            MaterialJson::Null(_) => {
                let at = |e: SceneError| e.within(&format!("materials.{name}"));
                let (material, wrappers) = self.builder.null_material().map_err(at)?;
                let id = self.builder.add_material(material).map_err(at)?;
                self.builder.set_wrappers(id, wrappers).map_err(at)?;
                self.materials.insert(name.to_string(), id);
                return Ok(id);
            }
            MaterialJson::Mask(_)
            | MaterialJson::OneSided(_)
            | MaterialJson::NormalMapped(_)
            | MaterialJson::BumpMapped(_) => {
                let id = self.wrapped_material(name, m)?;
                self.materials.insert(name.to_string(), id);
                return Ok(id);
            }
            MaterialJson::Ggx(GgxMaterialJson {
                base_color,
                metallic,
                roughness,
                clearcoat,
                clearcoat_roughness,
                ..
            }) => Material::Ggx {
                base_color: self.colour(base_color, 0).map_err(field("base_color"))?,
                metallic: *metallic,
                roughness: *roughness,
                metallic_roughness: None,
                normal_map: None,
                // Absent, none; the builder checks both are in [0, 1].
                clearcoat: (*clearcoat != 0.0 || *clearcoat_roughness != 0.0).then_some(
                    ClearCoat {
                        factor: *clearcoat,
                        texture: None,
                        roughness: *clearcoat_roughness,
                        roughness_texture: None,
                    },
                ),
            },
        };
        let id = self
            .builder
            .add_material(material)
            .map_err(|e| e.within(&format!("materials.{name}")))?;
        let emission = match m {
            MaterialJson::Lambertian(LambertianMaterialJson { emission, .. })
            | MaterialJson::Metal(MetalMaterialJson { emission, .. })
            | MaterialJson::Dielectric(DielectricMaterialJson { emission, .. })
            | MaterialJson::Ggx(GgxMaterialJson { emission, .. })
            | MaterialJson::Conductor(ConductorMaterialJson { emission, .. })
            | MaterialJson::RoughConductor(RoughConductorMaterialJson { emission, .. })
            | MaterialJson::SmoothDielectric(SmoothDielectricMaterialJson { emission, .. })
            | MaterialJson::ThinDielectric(SmoothDielectricMaterialJson { emission, .. })
            | MaterialJson::RoughDielectric(RoughDielectricMaterialJson { emission, .. })
            | MaterialJson::Plastic(PlasticMaterialJson { emission, .. })
            | MaterialJson::RoughPlastic(RoughPlasticMaterialJson { emission, .. })
            | MaterialJson::Principled(PrincipledMaterialJson { emission, .. })
            | MaterialJson::PrincipledThin(PrincipledMaterialJson { emission, .. }) => {
                emission.as_ref()
            }
            MaterialJson::DiffuseLight(_)
            | MaterialJson::Blend(_)
            | MaterialJson::Mask(_)
            | MaterialJson::Null(_)
            | MaterialJson::OneSided(_)
            | MaterialJson::NormalMapped(_)
            | MaterialJson::BumpMapped(_) => None,
        };
        match emission {
            None => {}
            // Black: no emission (and no emitter for light sampling).
            Some(ColorRef::Rgb(c)) if *c == Vec3::ZERO => {}
            Some(c) => {
                let texture = self.colour(c, 0).map_err(field("emission"))?;
                self.builder
                    .set_emission(id, texture)
                    .map_err(|e| e.within(&format!("materials.{name}")))?;
            }
        }
        self.materials.insert(name.to_string(), id);
        Ok(id)
    }

    /// A `mask`, `one_sided`, `normal_mapped` or `bump_mapped` material: a copy of the
    /// material it names (with its emission) under one more of Mitsuba's
    /// wrappers.
    fn wrapped_material(&mut self, name: &str, m: &MaterialJson) -> Result<u32, SceneError> {
        let at = |e: SceneError| e.within(&format!("materials.{name}"));
        // A map: its texture, and for a bump map its scale.
        let (inner, opacity, normal_map) = match m {
            MaterialJson::Mask(w) => (&w.material, Some(&w.opacity), None),
            MaterialJson::OneSided(w) => (&w.material, None, None),
            MaterialJson::NormalMapped(w) => (&w.material, None, Some((&w.normal_map, None))),
            MaterialJson::BumpMapped(w) => (&w.material, None, Some((&w.bump_map, Some(w.scale)))),
            _ => unreachable!(
                "wrapped_material is called for mask, one_sided, normal_mapped and bump_mapped"
            ),
        };
        let inner_id = self
            .wrapped(name, inner)
            .map_err(|e| e.within(&format!("materials.{name}.material")))?;
        let (material, mut wrappers, emission) = self
            .builder
            .material_parts(inner_id)
            .expect("a material the resolver made");
        match (opacity, normal_map) {
            (Some(_), _) if wrappers.opacity.is_some() => {
                return Err(at(SceneError::invalid(
                    "material",
                    format!("`{inner}` is a mask already: a material takes one mask"),
                )))
            }
            (Some(o), _) => {
                let texture = self
                    .scalar(o)
                    .map_err(|e| e.within(&format!("materials.{name}.opacity")))?;
                wrappers.opacity = Some(texture);
            }
            // Mitsuba's normalmap holds the BSDF the mask wraps, not the
            // mask (the reader refuses a mask inside a normalmap alike).
            (None, Some(_)) if wrappers.opacity.is_some() || wrappers.normal_map.is_some() => {
                return Err(at(SceneError::invalid(
                    "material",
                    format!("`{inner}` has a mask or a normal map already: put the normal map inside the mask, one a material"),
                )))
            }
            (None, Some((c, None))) => {
                let texture = self
                    .colour(c, 0)
                    .map_err(|e| e.within(&format!("materials.{name}.normal_map")))?;
                wrappers.normal_map = Some(texture);
            }
            (None, Some((c, Some(scale)))) => {
                let within = |e: SceneError| e.within(&format!("materials.{name}.bump_map"));
                let texture = self.colour(c, 0).map_err(within)?;
                wrappers.normal_map = Some(self.scaled(texture, scale).map_err(within)?);
                wrappers.bump_map = true;
            }
            (None, None) if wrappers.blend.is_some() => {
                return Err(at(SceneError::invalid(
                    "material",
                    format!("`{inner}` is a blend: make the materials it blends one_sided instead"),
                )))
            }
            (None, None) => wrappers.one_sided = true,
        }
        let id = self.builder.add_material(material).map_err(at)?;
        self.builder.set_wrappers(id, wrappers).map_err(at)?;
        if let Some(e) = emission {
            self.builder.set_emission(id, e).map_err(at)?;
        }
        Ok(id)
    }

    /// A `principled` (or, where `thin`, `principled_thin`) material's
    /// model: each lobe's texture (absent or 0: off) and its index.
    fn principled(
        &mut self,
        p: &PrincipledMaterialJson,
        thin: bool,
    ) -> Result<Material, SceneError> {
        let lobe = |this: &mut Self, what: &str, v: &Option<ScalarRef>| match v {
            None | Some(ScalarRef::Value(0.0)) => Ok(None),
            Some(v) => this.scalar(v).map(Some).map_err(|e| e.within(what)),
        };
        let given = |what: &'static str, v: bool| v.then_some(what);
        let other = if thin {
            [
                given("metallic", p.metallic.is_some()),
                given("clearcoat", p.clearcoat.is_some()),
                given("clearcoat_gloss", p.clearcoat_gloss.is_some()),
                given("specular", p.specular.is_some()),
            ]
        } else {
            [
                given("diff_trans", p.diff_trans.is_some()),
                None,
                None,
                None,
            ]
        };
        if let Some(what) = other.into_iter().flatten().next() {
            let model = if thin {
                "principled_thin"
            } else {
                "principled"
            };
            return Err(SceneError::invalid(
                what,
                format!("a {model} material has no {what}"),
            ));
        }
        let base_color = self
            .colour(&p.base_color, 0)
            .map_err(|e| e.within("base_color"))?;
        let roughness = self
            .scalar(&p.roughness)
            .map_err(|e| e.within("roughness"))?;
        if thin {
            return Ok(Material::Principled {
                base_color,
                roughness,
                lobes: PrincipledLobes {
                    anisotropic: lobe(self, "anisotropic", &p.anisotropic)?,
                    spec_trans: lobe(self, "spec_trans", &p.spec_trans)?,
                    sheen: lobe(self, "sheen", &p.sheen)?,
                    sheen_tint: lobe(self, "sheen_tint", &p.sheen_tint)?,
                    flatness: lobe(self, "flatness", &p.flatness)?,
                    spec_tint: lobe(self, "spec_tint", &p.spec_tint)?,
                    diff_trans: lobe(self, "diff_trans", &p.diff_trans)?,
                    ..PrincipledLobes::default()
                },
                eta: p.eta.unwrap_or(1.5),
                thin,
            });
        }
        let spec_trans = lobe(self, "spec_trans", &p.spec_trans)?;
        let clearcoat = lobe(self, "clearcoat", &p.clearcoat)?;
        let eta = match (p.eta, p.specular) {
            (Some(_), Some(_)) => {
                return Err(SceneError::invalid(
                    "eta",
                    "give eta or specular, not both".into(),
                ))
            }
            (Some(eta), None) if spec_trans.is_some() && eta == 1.0 => 1.001,
            (Some(eta), None) => eta,
            (None, specular) => {
                let specular = specular.unwrap_or(0.5);
                if !(specular.is_finite() && specular >= 0.0) {
                    return Err(SceneError::invalid(
                        "specular",
                        format!("{specular} is not a finite number of at least 0"),
                    ));
                }
                let specular = if spec_trans.is_some() && specular == 0.0 {
                    1e-3
                } else {
                    specular
                };
                crate::principled::eta_of_specular(specular)
            }
        };
        Ok(Material::Principled {
            base_color,
            roughness,
            lobes: PrincipledLobes {
                anisotropic: lobe(self, "anisotropic", &p.anisotropic)?,
                spec_trans,
                metallic: lobe(self, "metallic", &p.metallic)?,
                clearcoat_gloss: match clearcoat {
                    Some(_) => Some(match &p.clearcoat_gloss {
                        None => self.builder.constant(Vec3::ZERO)?,
                        Some(g) => self.scalar(g).map_err(|e| e.within("clearcoat_gloss"))?,
                    }),
                    None => None,
                },
                clearcoat,
                sheen: lobe(self, "sheen", &p.sheen)?,
                sheen_tint: lobe(self, "sheen_tint", &p.sheen_tint)?,
                flatness: lobe(self, "flatness", &p.flatness)?,
                spec_tint: lobe(self, "spec_tint", &p.spec_tint)?,
                diff_trans: None,
            },
            eta,
            thin,
        })
    }

    /// Material `inner`, read for the wrapping material `name` (a mask, a
    /// map, a side or a blend); a name met again while its wrappers are
    /// read is a loop.
    fn wrapped(&mut self, name: &str, inner: &str) -> Result<u32, SceneError> {
        if self.wrapping.iter().any(|n| n == name) {
            return Err(SceneError::invalid(
                "material",
                format!(
                    "materials wrap each other in a loop: {} -> {name}",
                    self.wrapping.join(" -> ")
                ),
            ));
        }
        self.wrapping.push(name.to_string());
        let id = self.material(inner);
        self.wrapping.pop();
        id
    }

    /// A `blend` material: a copy of its first material (with its
    /// emission) blended with its second by `weight`. Each may be
    /// `one_sided`; masks and maps go around the blend, not inside it.
    fn blend_material(&mut self, name: &str, b: &BlendMaterialJson) -> Result<u32, SceneError> {
        let at = |e: SceneError| e.within(&format!("materials.{name}"));
        let mut parts = Vec::with_capacity(2);
        for (k, inner) in b.materials.iter().enumerate() {
            let id = self
                .wrapped(name, inner)
                .map_err(|e| e.within(&format!("materials.{name}.materials[{k}]")))?;
            let (material, wrappers, emission) = self
                .builder
                .material_parts(id)
                .expect("a material the resolver made");
            if matches!(material, Material::DiffuseLight { .. }) {
                return Err(at(SceneError::invalid(
                    &format!("materials[{k}]"),
                    format!("`{inner}` is a light (diffuse_light), which has no BSDF to blend"),
                )));
            }
            if wrappers
                != (Wrappers {
                    one_sided: wrappers.one_sided,
                    ..Wrappers::default()
                })
            {
                return Err(at(SceneError::invalid(
                    &format!("materials[{k}]"),
                    format!("`{inner}` has a mask, a map or a blend: a blend's materials may only be one_sided (put masks and maps around the blend)"),
                )));
            }
            if k == 1 && emission.is_some() {
                return Err(at(SceneError::invalid(
                    "materials[1]",
                    format!("`{inner}` emits: a blend emits what its first material does (give the emission to that one)"),
                )));
            }
            parts.push((id, material, wrappers.one_sided, emission));
        }
        let weight = self
            .scalar(&b.weight)
            .map_err(|e| e.within(&format!("materials.{name}.weight")))?;
        let (_, material, one_sided, emission) = parts[0];
        let id = self.builder.add_material(material).map_err(at)?;
        let wrappers = Wrappers {
            one_sided,
            blend: Some(Blend {
                weight,
                second: parts[1].0,
            }),
            ..Wrappers::default()
        };
        self.builder.set_wrappers(id, wrappers).map_err(at)?;
        if let Some(e) = emission {
            self.builder.set_emission(id, e).map_err(at)?;
        }
        Ok(id)
    }

    /// Texture `t` times `scale` (a bump map's height: an image or a
    /// constant; the builder refuses the others as heights).
    fn scaled(&mut self, t: u32, scale: f32) -> Result<u32, SceneError> {
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(SceneError::invalid(
                "scale",
                format!("{scale} is not a finite number of at least 0"),
            ));
        }
        let scaled = match self.builder.texture(t) {
            Some(&Texture::Image {
                image,
                factor,
                sampler,
            }) => Texture::Image {
                image,
                factor: factor * scale,
                sampler,
            },
            Some(&Texture::Constant(c)) => Texture::Constant(c * scale),
            _ => return Ok(t),
        };
        self.builder.add_texture(scaled)
    }

    fn object(&mut self, o: &ObjectJson) -> Result<(), SceneError> {
        let transform = |t: &TransformJson| t.to_transform().map_err(|e| e.within("transform"));
        match o {
            ObjectJson::Sphere(SphereJson {
                center,
                radius,
                material,
                transform: t,
            }) => {
                let m = self.material(material)?;
                self.builder
                    .add_sphere(DVec3::from(*center), *radius, m, &transform(t)?)
            }
            ObjectJson::Quad(QuadJson {
                corner,
                u,
                v,
                material,
                transform: t,
            }) => {
                let m = self.material(material)?;
                self.builder.add_quad(
                    DVec3::from(*corner),
                    Vec3::from(*u),
                    Vec3::from(*v),
                    m,
                    &transform(t)?,
                )
            }
            ObjectJson::Box(BoxJson {
                min,
                max,
                material,
                transform: t,
            }) => {
                let m = self.material(material)?;
                self.builder
                    .add_box(DVec3::from(*min), DVec3::from(*max), m, &transform(t)?)
            }
            ObjectJson::Mesh(MeshJson {
                path,
                material,
                transform: t,
            }) => {
                let m = self.material(material)?;
                let mesh = crate::loader::gltf::load_gltf_mesh_reading(
                    &self.base.join(path),
                    &mut self.builder.sources,
                    &mut self.builder.warnings,
                )?;
                self.builder.add_mesh(&mesh, m, &transform(t)?)
            }
            ObjectJson::Gltf(GltfJson {
                path,
                transform: t,
                light_units,
            }) => {
                let t = transform(t)?;
                let take_camera = self.doc.camera.is_none();
                let mut options = self.gltf;
                if let Some(units) = light_units {
                    options.light_units = match units {
                        LightUnitsJson::Photometric => GltfLightUnits::Photometric,
                        LightUnitsJson::Radiometric => GltfLightUnits::Radiometric,
                    };
                }
                crate::loader::gltf::add_gltf_scene_with(
                    &mut self.builder,
                    &self.base.join(path),
                    &t,
                    take_camera,
                    &options,
                )
            }
        }
    }
}

/// Builds a parsed document; relative paths resolve against `base`.
pub fn build_scene(doc: &SceneJson, base: &Path) -> Result<Scene, SceneError> {
    build(doc, base, Vec::new(), &GltfOptions::default())
}

/// [`build_scene`], the scene's sources starting with `sources` (the
/// scene file, when there is one).
fn build(
    doc: &SceneJson,
    base: &Path,
    sources: Vec<PathBuf>,
    gltf: &GltfOptions,
) -> Result<Scene, SceneError> {
    let mut builder = SceneBuilder::new();
    builder.sources = sources;
    let mut r = Resolver {
        doc,
        base,
        gltf: *gltf,
        builder,
        textures: HashMap::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        wrapping: Vec::new(),
    };
    let defaults = RenderSettings::default();
    let rj = &doc.render;
    r.builder.render = RenderSettings {
        width: rj.width.unwrap_or(defaults.width),
        height: rj.height.unwrap_or(defaults.height),
        spp: rj.spp.unwrap_or(defaults.spp),
        max_depth: rj.max_depth.unwrap_or(defaults.max_depth),
        seed: rj.seed.unwrap_or(defaults.seed),
        roulette_depth: rj.roulette_depth.unwrap_or(defaults.roulette_depth),
        sampler: rj.sampler_or(defaults.sampler)?,
        camera: None,
    };
    r.builder.filter = match doc.filter {
        None | Some(FilterJson::Box) => PixelFilter::Box,
        Some(FilterJson::Gaussian { stddev }) => PixelFilter::Gaussian { stddev },
    };
    r.builder.render_origin = match doc.render_origin {
        Some(p) if !DVec3::from(p).is_finite() => {
            return Err(SceneError::invalid(
                "render_origin",
                format!("{} is not finite", DVec3::from(p)),
            ))
        }
        Some(p) => RenderOrigin::At(DVec3::from(p)),
        None => RenderOrigin::Camera,
    };
    if let Some(c) = &doc.camera {
        let (from, at) = c.positions();
        c.check()?;
        r.builder.set_camera_exact(from, at, c.settings());
    }
    r.builder.background = Some(match &doc.background {
        None => Background::Solid(Vec3::ZERO),
        Some(BackgroundJson::Solid(SolidBackgroundJson { color })) => {
            Background::Solid(Vec3::from(*color))
        }
        Some(BackgroundJson::Sky(SkyBackgroundJson { horizon, zenith })) => Background::Sky {
            horizon: Vec3::from(*horizon),
            zenith: Vec3::from(*zenith),
        },
        Some(BackgroundJson::Envmap(EnvmapBackgroundJson {
            path,
            intensity,
            rotate_y,
        })) => {
            let image = r
                .image(path, None)
                .map_err(|e| e.within("background.path"))?;
            if !rotate_y.is_finite() {
                return Err(SceneError::invalid(
                    "background.rotate_y",
                    format!("{rotate_y} is not finite"),
                ));
            }
            Background::Envmap {
                image,
                intensity: *intensity,
                to_map: turn_about_y(*rotate_y),
                rows: EnvRows::Bands,
            }
        }
    });
    for (i, o) in doc.objects.iter().enumerate() {
        r.object(o)
            .map_err(|e| e.within(&format!("objects[{i}]")))?;
    }
    for (i, l) in doc.lights.iter().enumerate() {
        r.builder
            .add_light(l.input())
            .map_err(|e| e.within(&format!("lights[{i}]")))?;
    }
    // Every file the document names is read, used or not: a typo in the
    // path of a texture no material uses yet must not go unnoticed.
    for (name, t) in &doc.textures {
        if let TextureJson::Image(ImageTextureJson { path, srgb }) = t {
            let full = base.join(path);
            if !r.images.contains_key(&(full.clone(), *srgb)) {
                r.builder.sources.push(full.clone());
                load_image(&full, *srgb).map_err(|e| {
                    SceneError::invalid(
                        &format!("textures.{name}.path"),
                        format!("(a texture no material uses) {e}"),
                    )
                })?;
            }
        }
    }
    if doc.camera.is_none() && !doc.objects.iter().any(|o| matches!(o, ObjectJson::Gltf(_))) {
        return Err(SceneError::invalid(
            "camera",
            "the scene has no camera (and no glTF document to take one from)".into(),
        ));
    }
    r.builder.build()
}
