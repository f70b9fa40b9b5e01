//! The materials and textures of `export-mitsuba`: each as Mitsuba 3's own
//! plugin where that computes the reference's formula (`diffuse`, the
//! `conductor` mirror, `area`), else as one of twintrace's Python plugins
//! (xtask/mitsuba/plugins/twintrace_plugins.py, registered by render.py
//! and checked by chi2.py): `tt_dielectric` (Schlick's Fresnel),
//! `tt_fuzzy_metal`, `tt_ggx` (glTF metallic-roughness with clear coat),
//! `tt_checker` (the 3-D sine checker). What neither can express is
//! refused with the feature named.

use anyhow::{bail, Result};
use glam::Vec3;
use reference::material::{AlphaMode, Material};
use reference::texture::{Sampler, Texture, Wrap};
use reference::Scene;
use std::path::Path;
use twintrace::image_io::{self, RenderImage, RenderMetadata};

/// How a shape's Mitsuba uv becomes the reference's: `uv_ref = (m0·u +
/// m1·v + m2, m3·u + m4·v + m5)`.
pub(super) type UvMap = [f64; 6];

/// PLY meshes carry the reference's own uv.
pub(super) const MESH_UV: UvMap = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// Spheres exported with [`sphere_to_world`]: Mitsuba's (φ, θ) in the
/// frame whose z is the world's −y and whose y is the world's +z give
/// v = acos(−y)/π, the reference's, and u = 0.5 − the reference's
/// `(atan2(−z, x) + π) / 2π` (its parameterization has the other
/// handedness, so no rotation gives it directly).
pub(super) const SPHERE_UV: UvMap = [-1.0, 0.0, 0.5, 0.0, 1.0, 0.0];

/// The `to_world` of a sphere whose uv is [`SPHERE_UV`]: local x → world
/// x, local y → world z, local z → world −y, times the radius, at the
/// centre (Mitsuba takes centre and radius from it, so it intersects the
/// same sphere).
pub(super) fn sphere_to_world(center: Vec3, radius: f32) -> String {
    let r = radius;
    let c = center;
    format!(
        r#"<transform name="to_world"><matrix value="{r:?} 0 0 {:?} 0 0 {:?} {:?} 0 {r:?} 0 {:?} 0 0 0 1"/></transform>"#,
        c.x, -r, c.y, c.z
    )
}

/// `a ∘ b`: first `b`, then `a`.
fn compose(a: UvMap, b: UvMap) -> UvMap {
    [
        a[0] * b[0] + a[1] * b[3],
        a[0] * b[1] + a[1] * b[4],
        a[0] * b[2] + a[1] * b[5] + a[2],
        a[3] * b[0] + a[4] * b[3],
        a[3] * b[1] + a[4] * b[4],
        a[3] * b[2] + a[4] * b[5] + a[5],
    ]
}

/// `m` as a texture's `to_uv` element.
fn to_uv(m: UvMap) -> String {
    format!(
        r#"<transform name="to_uv"><matrix value="{:?} {:?} 0 {:?} {:?} {:?} 0 {:?} 0 0 1 0 0 0 0 1"/></transform>"#,
        m[0], m[1], m[2], m[3], m[4], m[5]
    )
}

/// The image file of texture `id` in the output folder.
pub(super) fn texture_file(id: u32) -> String {
    format!("texture_{id}.exr")
}

/// A texture Mitsuba evaluates as the reference does.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Tex {
    Constant(Vec3),
    /// Mitsuba's `bitmap` of [`texture_file`]`(id)`: the reference's
    /// linear texels times the factor, as a float EXR read raw; texel
    /// centres at half-integers in both; one wrap mode for both axes.
    Image {
        id: u32,
        /// The wrap modes along u and v.
        wrap: (Wrap, Wrap),
        /// The texture coordinate set it reads (glTF's texCoord, 0 or 1).
        set: u32,
        nearest: bool,
        /// The reference's uv → the sampler's uv (KHR_texture_transform).
        transform: Box<UvMap>,
    },
    /// Mitsuba's own `checkerboard`: `color0` `even`, `color1` `odd`, at
    /// the reference's uv mapped by `transform`.
    UvChecker {
        transform: Box<UvMap>,
        even: Box<Tex>,
        odd: Box<Tex>,
    },
    /// `tt_checker`: the scene's (render-space) `even` and `odd`.
    Checker {
        scale: f32,
        even: Box<Tex>,
        odd: Box<Tex>,
    },
}

impl Tex {
    /// The texture as the XML child named `name`, on a shape whose uv
    /// becomes the reference's by `uv`.
    pub(super) fn xml(&self, name: &str, uv: UvMap) -> String {
        match self {
            Tex::Constant(c) => format!(r#"<rgb name="{name}" value="{}"/>"#, triple(*c)),
            Tex::Checker { scale, even, odd } => format!(
                r#"<texture type="tt_checker" name="{name}"><float name="scale" value="{scale:?}"/>{}{}</texture>"#,
                even.xml("even", uv),
                odd.xml("odd", uv)
            ),
            Tex::UvChecker {
                transform,
                even,
                odd,
            } => {
                format!(
                    r#"<texture type="checkerboard" name="{name}">{}{}{}</texture>"#,
                    even.xml("color0", uv),
                    odd.xml("color1", uv),
                    to_uv(compose(**transform, uv))
                )
            }
            Tex::Image {
                id,
                wrap,
                set,
                nearest,
                transform,
            } => {
                // Mitsuba's bitmap has v = 0 at the top row, the
                // reference v = 0 at the bottom; wrapping 1 − v is
                // wrapping v, mirrored, for every mode.
                let mode = |w: &Wrap| match w {
                    Wrap::Repeat => "repeat",
                    Wrap::ClampToEdge => "clamp",
                    Wrap::MirroredRepeat => "mirror",
                };
                if wrap.0 != wrap.1 || *set == 1 {
                    // `tt_image`: the reference's lookup itself, its uv
                    // (not flipped) from the shape's by `m0`..`m5`, or
                    // from the mesh's second set (`vertex_uv1`).
                    let (uv, uv1) = if *set == 1 {
                        (
                            MESH_UV,
                            r#"<texture type="mesh_attribute" name="uv1"><string name="name" value="vertex_uv1"/></texture>"#,
                        )
                    } else {
                        (uv, "")
                    };
                    let m = compose(**transform, uv);
                    let m: String = m
                        .iter()
                        .enumerate()
                        .map(|(i, v)| format!(r#"<float name="m{i}" value="{v:?}"/>"#))
                        .collect();
                    return format!(
                        r#"<texture type="tt_image" name="{name}"><string name="filename" value="{}"/><string name="wrap_u" value="{}"/><string name="wrap_v" value="{}"/><boolean name="nearest" value="{nearest}"/>{m}{uv1}</texture>"#,
                        texture_file(*id),
                        mode(&wrap.0),
                        mode(&wrap.1)
                    );
                }
                const FLIP: UvMap = [1.0, 0.0, 0.0, 0.0, -1.0, 1.0];
                let m = compose(FLIP, compose(**transform, uv));
                let wrap = mode(&wrap.0);
                format!(
                    // `accel` off: on CUDA, Mitsuba's bitmap otherwise filters with the
                    // texture units, whose bilinear weights are 8-bit fixed point (up to
                    // 4.3e-3 off the reference's lookup on the H100, chi2.py's check).
                    r#"<texture type="bitmap" name="{name}"><string name="filename" value="{}"/><boolean name="raw" value="true"/><boolean name="accel" value="false"/><string name="filter_type" value="{}"/><string name="wrap_mode" value="{wrap}"/>{}</texture>"#,
                    texture_file(*id),
                    if *nearest { "nearest" } else { "bilinear" },
                    to_uv(m)
                )
            }
        }
    }

    fn uses_plugins(&self) -> bool {
        match self {
            Tex::Constant(_) => false,
            Tex::Checker { .. } => true,
            Tex::UvChecker { even, odd, .. } => even.uses_plugins() || odd.uses_plugins(),
            Tex::Image { wrap, set, .. } => wrap.0 != wrap.1 || *set == 1,
        }
    }

    /// Whether it reads the second texture coordinates.
    fn uses_uv1(&self) -> bool {
        match self {
            Tex::Constant(_) => false,
            Tex::Image { set, .. } => *set == 1,
            Tex::Checker { even, odd, .. } | Tex::UvChecker { even, odd, .. } => {
                even.uses_uv1() || odd.uses_uv1()
            }
        }
    }

    fn uses_uv(&self) -> bool {
        match self {
            Tex::Constant(_) => false,
            Tex::Image { .. } | Tex::UvChecker { .. } => true,
            Tex::Checker { even, odd, .. } => even.uses_uv() || odd.uses_uv(),
        }
    }

    /// The image textures it reads, each once.
    pub(super) fn images(&self, out: &mut Vec<u32>) {
        match self {
            Tex::Constant(_) => {}
            Tex::Image { id, .. } => {
                if !out.contains(id) {
                    out.push(*id)
                }
            }
            Tex::Checker { even, odd, .. } | Tex::UvChecker { even, odd, .. } => {
                even.images(out);
                odd.images(out);
            }
        }
    }
}

/// A BSDF (and emitter) Mitsuba renders as twintrace does.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Surface {
    Diffuse(Tex),
    /// A smooth metal: a perfect mirror times the albedo.
    Mirror(Tex),
    /// Mitsuba's own smooth `dielectric` (`eta` inside over outside), or
    /// its `thindielectric` where `thin`.
    SmoothDielectric {
        eta: f32,
        reflectance: Tex,
        transmittance: Tex,
        thin: bool,
    },
    /// Mitsuba's own smooth `conductor`.
    Conductor {
        specular: Tex,
        eta: Vec3,
        k: Vec3,
    },
    /// Mitsuba's own `roughconductor` (a roughness constant over the
    /// surface).
    RoughConductor {
        /// `reference::microfacet::distribution`'s.
        distribution: u32,
        alpha: f32,
        /// Where anisotropic, the roughness across the tangent (`alpha`
        /// is then Mitsuba's `alpha_u`).
        alpha_v: Option<f32>,
        specular: Tex,
        eta: Vec3,
        k: Vec3,
    },
    /// Mitsuba's own `roughdielectric` (a roughness constant over the
    /// surface; both sides its own).
    RoughDielectric {
        distribution: u32,
        alpha: f32,
        alpha_v: Option<f32>,
        eta: f32,
        reflectance: Tex,
        transmittance: Tex,
    },
    /// Mitsuba's own smooth `plastic`.
    Plastic {
        diffuse: Tex,
        specular: Tex,
        eta: f32,
        nonlinear: bool,
    },
    /// Mitsuba's own `roughplastic`.
    RoughPlastic {
        distribution: u32,
        alpha: f32,
        diffuse: Tex,
        specular: Tex,
        eta: f32,
        nonlinear: bool,
    },
    FuzzyMetal {
        albedo: Tex,
        fuzz: f32,
    },
    /// Schlick's glass; an absorbing one gets an interior medium.
    Dielectric {
        ior: f32,
        absorption: Vec3,
    },
    Light(Vec3),
    Ggx {
        base_color: Tex,
        metallic: f32,
        roughness: f32,
        /// glTF's metallicRoughnessTexture (blue: metallic, green: roughness).
        metallic_roughness: Option<Tex>,
        /// The clear coat's weight and roughness (weight 0: none), and
        /// their textures (red, green).
        coat: (f32, f32),
        coat_textures: (Option<Tex>, Option<Tex>),
        /// glTF's normalTexture and its scale: applied on triangles with
        /// tangents (`tt_normalmap`), ignored elsewhere, as the reference.
        normal_map: Option<(Tex, f32)>,
    },
}

/// Where a shape's surface is: what its BSDF reads of the shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Placement {
    /// The shape's uv → the reference's.
    pub uv: UvMap,
    /// Triangles with shading normals: the reference's facing (the
    /// shading normal put on the geometric normal's side, then flipped
    /// toward the ray as the geometric one is) by `tt_facing` instead of
    /// Mitsuba's `twosided` (which flips by the shading normal alone).
    pub shading_normals: bool,
    /// The mesh carries vertex colours (`vertex_color`), which scale a
    /// `ggx` base colour.
    pub vertex_colors: bool,
    /// The mesh carries tangents (`vertex_tangent`, and `vertex_tsign`
    /// their w), which a `ggx` normal map reads.
    pub tangents: bool,
    /// The material is one-sided ([`Wrapping`]): its Mitsuba model without
    /// `twosided`.
    pub one_sided: bool,
}

impl Surface {
    /// The BSDF (with its emitter or interior medium) as the children of
    /// a `shape` placed at `at`.
    pub(super) fn xml(&self, at: Placement) -> String {
        let uv = at.uv;
        let sided = |inner: String| {
            if at.one_sided {
                inner
            } else if at.shading_normals {
                format!(r#"<bsdf type="tt_facing">{inner}</bsdf>"#)
            } else {
                format!(r#"<bsdf type="twosided">{inner}</bsdf>"#)
            }
        };
        match self {
            // Mitsuba's `diffuse` scatters nothing where the view is below
            // the shading normal; the reference's Lambertian does not look.
            Surface::Diffuse(c) if at.shading_normals => sided(format!(
                r#"<bsdf type="tt_diffuse">{}</bsdf>"#,
                c.xml("reflectance", uv)
            )),
            Surface::Diffuse(c) => sided(format!(
                r#"<bsdf type="diffuse">{}</bsdf>"#,
                c.xml("reflectance", uv)
            )),
            Surface::Mirror(c) => sided(format!(
                r#"<bsdf type="conductor"><string name="material" value="none"/>{}</bsdf>"#,
                c.xml("specular_reflectance", uv)
            )),
            Surface::Conductor { specular, eta, k } => sided(format!(
                r#"<bsdf type="conductor"><rgb name="eta" value="{}"/><rgb name="k" value="{}"/>{}</bsdf>"#,
                triple(*eta),
                triple(*k),
                specular.xml("specular_reflectance", uv)
            )),
            Surface::RoughConductor {
                distribution,
                alpha,
                alpha_v,
                specular,
                eta,
                k,
            } => sided(format!(
                r#"<bsdf type="roughconductor"><string name="distribution" value="{}"/>{}<rgb name="eta" value="{}"/><rgb name="k" value="{}"/>{}</bsdf>"#,
                distribution_name(*distribution),
                roughness_xml(*alpha, *alpha_v),
                triple(*eta),
                triple(*k),
                specular.xml("specular_reflectance", uv)
            )),
            Surface::RoughDielectric {
                distribution,
                alpha,
                alpha_v,
                eta,
                reflectance,
                transmittance,
            } => format!(
                r#"<bsdf type="roughdielectric"><string name="distribution" value="{}"/>{}<float name="int_ior" value="{eta:?}"/><float name="ext_ior" value="1.0"/>{}{}</bsdf>"#,
                distribution_name(*distribution),
                roughness_xml(*alpha, *alpha_v),
                reflectance.xml("specular_reflectance", uv),
                transmittance.xml("specular_transmittance", uv)
            ),
            // Mitsuba's dielectric takes both sides itself.
            Surface::SmoothDielectric {
                eta,
                reflectance,
                transmittance,
                thin,
            } => format!(
                r#"<bsdf type="{}"><float name="int_ior" value="{eta:?}"/><float name="ext_ior" value="1.0"/>{}{}</bsdf>"#,
                if *thin {
                    "thindielectric"
                } else {
                    "dielectric"
                },
                reflectance.xml("specular_reflectance", uv),
                transmittance.xml("specular_transmittance", uv)
            ),
            Surface::Plastic {
                diffuse,
                specular,
                eta,
                nonlinear,
            } => sided(format!(
                r#"<bsdf type="plastic"><float name="int_ior" value="{eta:?}"/><float name="ext_ior" value="1.0"/><boolean name="nonlinear" value="{nonlinear}"/>{}{}</bsdf>"#,
                diffuse.xml("diffuse_reflectance", uv),
                specular.xml("specular_reflectance", uv)
            )),
            Surface::RoughPlastic {
                distribution,
                alpha,
                diffuse,
                specular,
                eta,
                nonlinear,
            } => sided(format!(
                r#"<bsdf type="roughplastic"><string name="distribution" value="{}"/><float name="alpha" value="{alpha:?}"/><float name="int_ior" value="{eta:?}"/><float name="ext_ior" value="1.0"/><boolean name="nonlinear" value="{nonlinear}"/>{}{}</bsdf>"#,
                distribution_name(*distribution),
                diffuse.xml("diffuse_reflectance", uv),
                specular.xml("specular_reflectance", uv)
            )),
            Surface::FuzzyMetal { albedo, fuzz } => sided(format!(
                r#"<bsdf type="tt_fuzzy_metal">{}<float name="fuzz" value="{fuzz:?}"/></bsdf>"#,
                albedo.xml("albedo", uv)
            )),
            Surface::Dielectric { ior, absorption } => {
                // Under shading normals it picks its side by the geometric
                // normal and refracts about the reference's facing normal.
                let facing = if at.shading_normals {
                    r#"<boolean name="facing" value="true"/>"#
                } else {
                    ""
                };
                let bsdf = format!(
                    r#"<bsdf type="tt_dielectric"><float name="ior" value="{ior:?}"/>{facing}</bsdf>"#
                );
                if *absorption == Vec3::ZERO {
                    bsdf
                } else {
                    // Beer-Lambert: a medium that only absorbs, sigma_t
                    // the absorption per unit length (render space is the
                    // world's scale), written as a colour in [0, 1] (all
                    // Mitsuba reads as `rgb` there) times `scale`.
                    let scale = absorption.max_element();
                    format!(
                        r#"{bsdf}<medium type="homogeneous" name="interior"><rgb name="sigma_t" value="{}"/><float name="scale" value="{scale:?}"/><rgb name="albedo" value="0, 0, 0"/></medium>"#,
                        triple(*absorption / scale)
                    )
                }
            }
            Surface::Light(e) => format!(
                r#"<bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf><emitter type="area"><rgb name="radiance" value="{}"/></emitter>"#,
                triple(*e)
            ),
            Surface::Ggx {
                base_color,
                metallic,
                roughness,
                metallic_roughness,
                coat,
                coat_textures,
                normal_map,
            } => {
                let mut textures = String::new();
                for (name, t) in [
                    ("metallic_roughness", metallic_roughness),
                    ("clearcoat_texture", &coat_textures.0),
                    ("clearcoat_roughness_texture", &coat_textures.1),
                ] {
                    if let Some(t) = t {
                        textures += &t.xml(name, uv);
                    }
                }
                if at.vertex_colors {
                    textures += r#"<texture type="mesh_attribute" name="vertex_color"><string name="name" value="vertex_color"/></texture>"#;
                }
                let ggx = format!(
                    r#"<bsdf type="tt_ggx">{}<float name="metallic" value="{metallic:?}"/><float name="roughness" value="{roughness:?}"/><float name="clearcoat" value="{:?}"/><float name="clearcoat_roughness" value="{:?}"/>{textures}</bsdf>"#,
                    base_color.xml("base_color", uv),
                    coat.0,
                    coat.1
                );
                match normal_map {
                    Some((map, scale)) if at.tangents => format!(
                        r#"<bsdf type="tt_normalmap">{}<float name="scale" value="{scale:?}"/><texture type="mesh_attribute" name="tangent"><string name="name" value="vertex_tangent"/></texture><texture type="mesh_attribute" name="tsign"><string name="name" value="vertex_tsign"/></texture>{ggx}</bsdf>"#,
                        map.xml("normal_map", uv)
                    ),
                    _ => sided(ggx),
                }
            }
        }
    }

    fn textures(&self) -> Vec<&Tex> {
        match self {
            Surface::Diffuse(t) | Surface::Mirror(t) => vec![t],
            Surface::Conductor { specular, .. } | Surface::RoughConductor { specular, .. } => {
                vec![specular]
            }
            Surface::SmoothDielectric {
                reflectance,
                transmittance,
                ..
            }
            | Surface::RoughDielectric {
                reflectance,
                transmittance,
                ..
            } => vec![reflectance, transmittance],
            Surface::Plastic {
                diffuse, specular, ..
            }
            | Surface::RoughPlastic {
                diffuse, specular, ..
            } => vec![diffuse, specular],
            Surface::FuzzyMetal { albedo, .. } => vec![albedo],
            Surface::Dielectric { .. } | Surface::Light(_) => vec![],
            Surface::Ggx {
                base_color,
                metallic_roughness,
                coat_textures,
                normal_map,
                ..
            } => std::iter::once(base_color)
                .chain(metallic_roughness)
                .chain(&coat_textures.0)
                .chain(&coat_textures.1)
                .chain(normal_map.as_ref().map(|(t, _)| t))
                .collect(),
        }
    }

    /// Whether Mitsuba needs twintrace's Python plugins for it.
    pub(super) fn uses_plugins(&self) -> bool {
        match self {
            Surface::Diffuse(t) | Surface::Mirror(t) => t.uses_plugins(),
            Surface::Conductor { specular, .. } | Surface::RoughConductor { specular, .. } => {
                specular.uses_plugins()
            }
            Surface::SmoothDielectric {
                reflectance,
                transmittance,
                ..
            }
            | Surface::RoughDielectric {
                reflectance,
                transmittance,
                ..
            } => reflectance.uses_plugins() || transmittance.uses_plugins(),
            Surface::Plastic {
                diffuse, specular, ..
            }
            | Surface::RoughPlastic {
                diffuse, specular, ..
            } => diffuse.uses_plugins() || specular.uses_plugins(),
            Surface::Light(_) => false,
            // (Shading normals, which need `tt_facing`, are `Placement`'s.)
            Surface::FuzzyMetal { .. } | Surface::Dielectric { .. } | Surface::Ggx { .. } => true,
        }
    }

    /// Whether it reads the second texture coordinates (a mesh then
    /// carries them as `vertex_uv1`; elsewhere they are 0, as in the
    /// reference).
    pub(super) fn uses_uv1(&self) -> bool {
        self.textures().iter().any(|t| t.uses_uv1())
    }

    /// Whether it reads the shape's uv (spheres then need
    /// [`sphere_to_world`]).
    pub(super) fn uses_uv(&self) -> bool {
        self.textures().iter().any(|t| t.uses_uv())
    }

    /// The image textures it reads.
    pub(super) fn images(&self, out: &mut Vec<u32>) {
        for t in self.textures() {
            t.images(out);
        }
    }

    /// Whether it needs a volumetric path tracer (an absorbing interior).
    pub(super) fn has_medium(&self) -> bool {
        matches!(self, Surface::Dielectric { absorption, .. } if *absorption != Vec3::ZERO)
    }

    /// Why it cannot be on triangles with shading normals, if it cannot:
    /// the mirror, the fuzzy metal and the plastic's coat test their
    /// reflection against the geometric normal, which their Mitsuba forms do not see; Mitsuba's
    /// `area` light emits toward its shading normal's side, the
    /// reference's toward the geometric front.
    pub(super) fn shading_normals_refused(&self) -> Option<&'static str> {
        match self {
            // The rough plastic, as Mitsuba's, reads only the shading frame.
            Surface::Diffuse(_)
            | Surface::Ggx { .. }
            | Surface::Dielectric { .. }
            | Surface::RoughPlastic { .. } => None,
            Surface::Mirror(_)
            | Surface::Conductor { .. }
            | Surface::RoughConductor { .. }
            | Surface::FuzzyMetal { .. } => Some("a metal"),
            Surface::Light(_) => Some("a light"),
            // Mitsuba's picks its side by the shading normal, the
            // reference's by the geometric one.
            Surface::SmoothDielectric { .. } => Some("a smooth dielectric"),
            Surface::RoughDielectric { .. } => Some("a rough dielectric"),
            // Its coat's mirror, as a metal's.
            Surface::Plastic { .. } => Some("a plastic"),
        }
    }
}

pub(super) fn triple(v: Vec3) -> String {
    format!("{:?}, {:?}, {:?}", v.x, v.y, v.z)
}

/// Texture `id` of `scene` as Mitsuba evaluates it, or why it cannot be.
pub(super) fn texture(scene: &Scene, id: u32, what: &str) -> Result<Tex> {
    Ok(match scene.textures().get(id as usize) {
        Some(Texture::Constant(c)) => Tex::Constant(*c),
        Some(Texture::Checker { scale, even, odd }) => Tex::Checker {
            scale: *scale,
            even: Box::new(texture(scene, *even, what)?),
            odd: Box::new(texture(scene, *odd, what)?),
        },
        Some(Texture::Image { sampler, .. }) => image(id, sampler, what)?,
        Some(Texture::UvChecker { sampler, even, odd }) => {
            if sampler.tex_coord != 0 {
                bail!("{what} reads a uv checker at texture coordinates 1 (not exported)");
            }
            Tex::UvChecker {
                transform: Box::new(match sampler.transform {
                    None => MESH_UV,
                    Some(t) => t.map(f64::from),
                }),
                even: Box::new(texture(scene, *even, what)?),
                odd: Box::new(texture(scene, *odd, what)?),
            }
        }
        Some(Texture::VertexColor { .. }) => {
            bail!("{what} reads the mesh's vertex colours as a texture (not exported)")
        }
        None => bail!("{what} names texture {id}, which the scene lacks"),
    })
}

fn image(id: u32, sampler: &Sampler, what: &str) -> Result<Tex> {
    if sampler.tex_coord > 1 {
        bail!(
            "{what} reads texture coordinates {} (not exported)",
            sampler.tex_coord
        );
    }
    let transform = Box::new(match sampler.transform {
        None => MESH_UV,
        Some(t) => t.map(f64::from),
    });
    Ok(Tex::Image {
        id,
        wrap: (sampler.wrap_u, sampler.wrap_v),
        set: sampler.tex_coord,
        nearest: sampler.nearest,
        transform,
    })
}

/// An EXR of `mean` alone (`width` x `height`, rows from the top) for
/// Mitsuba's `envmap` or `bitmap` to read, signed by export-mitsuba.
pub(super) fn write_map(path: &Path, width: u32, height: u32, mean: Vec<Vec3>) -> Result<()> {
    let image = RenderImage {
        width,
        height,
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

/// Writes texture `id` (an image) as [`texture_file`] in `dir`: its
/// linear texels times its factor, rows from the top, as f32.
pub(super) fn write_texture(scene: &Scene, id: u32, dir: &Path) -> Result<()> {
    let Some(Texture::Image { image, factor, .. }) = scene.textures().get(id as usize) else {
        bail!("texture {id} is not an image");
    };
    let data = &scene.images()[*image as usize];
    write_map(
        &dir.join(texture_file(id)),
        data.width,
        data.height,
        data.texels.iter().map(|t| *factor * *t).collect(),
    )
}

/// Material `i` of `scene` as a Mitsuba surface, or why it cannot be.
pub(super) fn surface(scene: &Scene, i: usize) -> Result<Surface> {
    let what = format!("material {i}");
    if scene.added_emission(i as u32).is_some() {
        bail!("{what} emits as well as reflects (emission added to its BSDF is not exported)");
    }
    let optional = |t: Option<u32>| t.map(|t| texture(scene, t, &what)).transpose();
    Ok(match scene.materials()[i] {
        Material::Principled { thin, .. } => {
            let plugin = if thin { "principledthin" } else { "principled" };
            bail!("{what} is a principled BSDF (Mitsuba's {plugin}), which the export does not write (not exported)")
        }
        Material::Lambertian { albedo } => Surface::Diffuse(texture(scene, albedo, &what)?),
        Material::Metal { albedo, fuzz: 0.0 } => Surface::Mirror(texture(scene, albedo, &what)?),
        Material::Metal { albedo, fuzz } => Surface::FuzzyMetal {
            albedo: texture(scene, albedo, &what)?,
            fuzz,
        },
        Material::DiffuseLight { emission } => match texture(scene, emission, &what)? {
            Tex::Constant(e) => Surface::Light(e),
            _ => bail!("{what} is a textured light (not exported)"),
        },
        Material::Dielectric { ior, absorption } => Surface::Dielectric { ior, absorption },
        Material::SmoothDielectric {
            eta,
            reflectance,
            transmittance,
        }
        | Material::ThinDielectric {
            eta,
            reflectance,
            transmittance,
        } => Surface::SmoothDielectric {
            eta,
            reflectance: texture(scene, reflectance, &what)?,
            transmittance: texture(scene, transmittance, &what)?,
            thin: matches!(scene.materials()[i], Material::ThinDielectric { .. }),
        },
        Material::Conductor { specular, eta, k } => Surface::Conductor {
            specular: texture(scene, specular, &what)?,
            eta,
            k,
        },
        Material::RoughConductor {
            distribution,
            alpha,
            alpha_v,
            specular,
            eta,
            k,
        } => Surface::RoughConductor {
            distribution,
            alpha: constant_roughness(scene, alpha, &what)?,
            alpha_v: alpha_v
                .map(|v| constant_roughness(scene, v, &what))
                .transpose()?,
            specular: texture(scene, specular, &what)?,
            eta,
            k,
        },
        Material::RoughDielectric {
            distribution,
            alpha,
            alpha_v,
            eta,
            reflectance,
            transmittance,
        } => Surface::RoughDielectric {
            distribution,
            alpha: constant_roughness(scene, alpha, &what)?,
            alpha_v: alpha_v
                .map(|v| constant_roughness(scene, v, &what))
                .transpose()?,
            eta,
            reflectance: texture(scene, reflectance, &what)?,
            transmittance: texture(scene, transmittance, &what)?,
        },
        Material::Plastic {
            diffuse,
            specular,
            eta,
            nonlinear,
            ..
        } => Surface::Plastic {
            diffuse: texture(scene, diffuse, &what)?,
            specular: texture(scene, specular, &what)?,
            eta,
            nonlinear,
        },
        Material::RoughPlastic {
            distribution,
            alpha,
            diffuse,
            specular,
            eta,
            nonlinear,
            ..
        } => Surface::RoughPlastic {
            distribution,
            alpha,
            diffuse: texture(scene, diffuse, &what)?,
            specular: texture(scene, specular, &what)?,
            eta,
            nonlinear,
        },
        Material::Ggx {
            base_color,
            metallic,
            roughness,
            metallic_roughness,
            normal_map,
            clearcoat,
        } => {
            let (coat, coat_textures) = match clearcoat {
                None => ((0.0, 0.0), (None, None)),
                Some(c) => (
                    (c.factor, c.roughness),
                    (optional(c.texture)?, optional(c.roughness_texture)?),
                ),
            };
            Surface::Ggx {
                base_color: texture(scene, base_color, &what)?,
                metallic,
                roughness,
                metallic_roughness: optional(metallic_roughness)?,
                coat,
                coat_textures,
                normal_map: match normal_map {
                    Some(m) => Some((texture(scene, m.texture, &what)?, m.scale)),
                    None => None,
                },
            }
        }
    })
}

/// A material's wrappers (`reference::material::Wrappers`) as Mitsuba's:
/// its model without `twosided` where one-sided, inside a `normalmap` of
/// its normal map, inside a `mask` of its opacity.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Wrapping {
    pub one_sided: bool,
    pub opacity: Option<Tex>,
    pub normal_map: Option<Tex>,
}

impl Wrapping {
    /// `bsdf` inside the `mask` of its opacity (as it is without one). The
    /// opacity is Mitsuba's `eval_1` of the texture: a grey number, the
    /// luminance of a bitmap, a checkerboard of numbers (whose colours
    /// Mitsuba's `eval_1` takes swapped).
    pub(super) fn wrap(&self, bsdf: &str, uv: UvMap) -> String {
        let mapped;
        let bsdf = match &self.normal_map {
            Some(t) => {
                mapped = format!(
                    r#"<bsdf type="normalmap">{}{bsdf}</bsdf>"#,
                    t.xml("normalmap", uv)
                );
                mapped.as_str()
            }
            None => bsdf,
        };
        let Some(opacity) = &self.opacity else {
            return bsdf.to_string();
        };
        let texture = match opacity {
            Tex::Constant(c) => format!(
                r#"<float name="opacity" value="{:?}"/>"#,
                reference::material::opacity_of(*c)
            ),
            Tex::UvChecker {
                transform,
                even,
                odd,
            } => Tex::UvChecker {
                transform: transform.clone(),
                even: odd.clone(),
                odd: even.clone(),
            }
            .xml("opacity", uv),
            t => t.xml("opacity", uv),
        };
        format!(r#"<bsdf type="mask">{texture}{bsdf}</bsdf>"#)
    }

    pub(super) fn images(&self, out: &mut Vec<u32>) {
        for t in self.opacity.iter().chain(&self.normal_map) {
            t.images(out);
        }
    }

    pub(super) fn uses_uv(&self) -> bool {
        self.opacity
            .iter()
            .chain(&self.normal_map)
            .any(Tex::uses_uv)
    }
}

/// Material `i`'s wrappers as Mitsuba writes them, or why they cannot be:
/// one side only on the models Mitsuba makes one-sided, and an opacity of
/// a texture Mitsuba reads as a number alike.
pub(super) fn wrapping(scene: &Scene, i: usize, surface: &Surface) -> Result<Wrapping> {
    let what = format!("material {i}");
    let w = scene.wrappers(i as u32);
    if w.one_sided
        && !matches!(
            surface,
            Surface::Diffuse(_)
                | Surface::Mirror(_)
                | Surface::Conductor { .. }
                | Surface::RoughConductor { .. }
                | Surface::Plastic { .. }
                | Surface::RoughPlastic { .. }
        )
    {
        bail!("{what} is one-sided, which its Mitsuba form cannot be (not exported)");
    }
    let opacity = w.opacity.map(|t| texture(scene, t, &what)).transpose()?;
    if let Some(t @ (Tex::Checker { .. } | Tex::Image { .. })) = &opacity {
        if matches!(t, Tex::Checker { .. }) || t.uses_plugins() {
            bail!("{what} has a mask whose opacity Mitsuba would not read as a number alike (a 3-D checker, an image of two wrap modes or the second uv set: not exported)");
        }
    }
    if w.bump_map {
        bail!("{what} has a bump map (Mitsuba's bumpmap), which the export does not write (not exported)");
    }
    if w.blend.is_some() {
        bail!("{what} is a blend of two BSDFs (Mitsuba's blendbsdf), which the export does not write (not exported)");
    }
    if w.normal_map_mirrored {
        bail!("{what} reads its normal map in the frame turned to the viewer (Mitsuba's twosided around a normalmap), which the export does not write (not exported)");
    }
    let normal_map = w.normal_map.map(|t| texture(scene, t, &what)).transpose()?;
    Ok(Wrapping {
        one_sided: w.one_sided,
        opacity,
        normal_map,
    })
}

/// A material's coverage (glTF's alpha) as the opacity of Mitsuba's `mask`.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Coverage {
    texture: Tex,
    /// MASK's cutoff; `None`: BLEND.
    cutoff: Option<f32>,
}

impl Coverage {
    /// `bsdf` (a BSDF element) under this coverage, on a shape placed at
    /// `uv` whose mesh carries `vertex_alpha` or not.
    pub(super) fn wrap(&self, bsdf: &str, uv: UvMap, vertex_alpha: bool) -> String {
        let cutoff = match self.cutoff {
            Some(c) => format!(r#"<float name="cutoff" value="{c:?}"/>"#),
            None => String::new(),
        };
        let vertex = if vertex_alpha {
            r#"<texture type="mesh_attribute" name="vertex_alpha"><string name="name" value="vertex_alpha"/></texture>"#
        } else {
            ""
        };
        format!(
            r#"<bsdf type="mask"><texture type="tt_alpha" name="opacity">{}{vertex}{cutoff}</texture>{bsdf}</bsdf>"#,
            self.texture.xml("alpha", uv)
        )
    }

    pub(super) fn images(&self, out: &mut Vec<u32>) {
        self.texture.images(out);
    }

    pub(super) fn uses_uv1(&self) -> bool {
        self.texture.uses_uv1()
    }
}

/// Material `i`'s coverage, if it has one (it applies to the triangles
/// that carry alpha).
pub(super) fn coverage(scene: &Scene, i: usize) -> Result<Option<Coverage>> {
    let Some(alpha) = scene.alpha(i as u32) else {
        return Ok(None);
    };
    let what = format!("material {i}");
    if matches!(
        scene.materials()[i],
        Material::Dielectric { .. } | Material::DiffuseLight { .. }
    ) {
        bail!("{what} has an alpha coverage on a dielectric or a light (not exported)");
    }
    Ok(Some(Coverage {
        texture: texture(scene, alpha.texture, &what)?,
        cutoff: match alpha.mode {
            AlphaMode::Mask { cutoff } => Some(cutoff),
            AlphaMode::Blend => None,
        },
    }))
}

/// Mitsuba's name of a microfacet distribution.
fn distribution_name(distribution: u32) -> &'static str {
    if distribution == reference::microfacet::distribution::BECKMANN {
        "beckmann"
    } else {
        "ggx"
    }
}

/// A rough model's roughness in Mitsuba's XML: `alpha`, or `alpha_u` and
/// `alpha_v` where it is anisotropic.
fn roughness_xml(alpha: f32, alpha_v: Option<f32>) -> String {
    match alpha_v {
        None => format!(r#"<float name="alpha" value="{alpha:?}"/>"#),
        Some(v) => format!(
            r#"<float name="alpha_u" value="{alpha:?}"/><float name="alpha_v" value="{v:?}"/>"#
        ),
    }
}

/// A microfacet model's roughness, exported as a number: Mitsuba reads a
/// float texture's value where twintrace reads a texture's first
/// channel, so only a constant means one thing.
fn constant_roughness(scene: &Scene, alpha: u32, what: &str) -> Result<f32> {
    match texture(scene, alpha, what)? {
        Tex::Constant(c) => Ok(c.x),
        _ => bail!("{what} has a textured roughness (not exported)"),
    }
}
