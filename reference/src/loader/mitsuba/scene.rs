//! A Mitsuba 3 scene tree ([`super::xml`]) made into a twintrace scene:
//! each plugin read with the parameters and meaning of Mitsuba's `rgb`
//! variants, everything twintrace does not implement refused in one line
//! that names the plugin and its place, and every parameter a plugin does
//! not take refused as Mitsuba refuses it ("unreferenced property").
//!
//! docs/mitsuba.md tables what is read and how.

use super::meshes::{self, Mesh, MeshOptions};
use super::spectra::{self, SpectrumUse};
use super::xml::{Child, Document, Location, Object, Property, Spectrum, Value};
use crate::background::{Background, EnvRows};
use crate::camera::{CameraSettings, Projection};
use crate::error::SceneError;
use crate::filter::PixelFilter;
use crate::loader::image::load_image;
use crate::material::{Blend, Material, PrincipledLobes, Wrappers};

/// Mitsuba's models without `twosided`: black seen from behind.
const ONE_SIDED: Wrappers = Wrappers {
    one_sided: true,
    opacity: None,
    normal_map: None,
    normal_map_mirrored: false,
    bump_map: false,
    blend: None,
};
use crate::mutants::{self, Mutant};
use crate::rng::Sampler as PathSampler;
use crate::scene::RenderOrigin;
use crate::scene::{EmitterWeights, LightInput};
use crate::scene::{MeshInput, SceneBuilder};
use crate::scene::{RenderSettings, Scene, Transform, MAX_DEPTH};
use crate::shapes::{QUADRIC_CYLINDER, QUADRIC_DISK, QUADRIC_SPHERE};
use crate::texture::{Sampler, Texture, Wrap};
use glam::{DAffine3, DMat3, DMat4, DVec2, DVec3, Vec2, Vec3};
use std::cell::Cell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::rc::Rc;

/// The phrase every refusal of a plugin or parameter twintrace does not
/// implement carries (the CLI exits 2 on it; the runner reports REFUSED).
pub const NOT_SUPPORTED: &str = "is not supported";

/// Linear sRGB of the equal-energy illuminant at luminance 1: what
/// Mitsuba's `rgb` variants make of an emitter's uniform `spectrum`
/// (value 1). Read from Mitsuba 3.9.1 itself (`scalar_rgb`:
/// `mi.traverse(mi.load_dict({'type': 'point', 'intensity': {'type':
/// 'spectrum', 'value': 1.0}}))['intensity.value']` = [1.20479,
/// 0.948291, 0.908916]); a reflectance's uniform spectrum stays grey.
pub const EQUAL_ENERGY_RGB: [f64; 3] = [1.20479, 0.948291, 0.908916];

/// Mitsuba 3's tabulated conductors (its `conductor`'s `material`), as
/// its rgb variants hold them: the complex index `eta + i·k` of each
/// colour channel, Mitsuba's own reduction of the measured spectra (f32;
/// read back from Mitsuba 3.9.1's `scalar_rgb` with
/// `mi.traverse(mi.load_dict({'type': 'conductor', 'material': NAME}))`'s
/// `eta.value` and `k.value`, by xtask/mitsuba/named_conductors.py; where
/// a spectrum falls outside sRGB's gamut Mitsuba clamps the negative
/// channel to 0, as here). "none" is the default mirror (eta 0, k 1).
pub const NAMED_CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "a-C",
        [2.9440458, 2.2271364, 1.9681617],
        [0.8874649, 0.7992985, 0.81529],
    ),
    (
        "Ag",
        [0.1552762, 0.116727956, 0.13838764],
        [4.8283544, 3.1222224, 2.1469011],
    ),
    (
        "Al",
        [1.6575009, 0.8804047, 0.52124447],
        [9.223811, 6.269502, 4.837004],
    ),
    (
        "AlAs",
        [3.605296, 3.2329378, 2.2163186],
        [0.0006794373, 0.0, 0.007512709],
    ),
    (
        "AlAs_palik",
        [3.605296, 3.2329378, 2.2163186],
        [0.0006794373, 0.0, 0.007512709],
    ),
    (
        "AlSb",
        [0.0, 4.1393747, 4.6692543],
        [0.0, 0.09400908, 1.30057],
    ),
    (
        "AlSb_palik",
        [0.0, 4.1393747, 4.6692543],
        [0.0, 0.09400908, 1.30057],
    ),
    (
        "Au",
        [0.14303598, 0.37530708, 1.4420453],
        [3.982997, 2.3855565, 1.6033592],
    ),
    (
        "Be",
        [4.1850123, 3.1850293, 2.7840612],
        [3.835466, 3.0101223, 2.868994],
    ),
    (
        "Cr",
        [4.3696675, 2.9165053, 1.6549046],
        [5.206547, 4.231306, 3.7546988],
    ),
    ("CsI", [2.1448996, 1.7023189, 1.6624272], [0.0, 0.0, 0.0]),
    (
        "Cu",
        [0.20100547, 0.9237495, 1.1022154],
        [3.9132621, 2.4530451, 2.1420898],
    ),
    (
        "Cu_palik",
        [0.21322851, 0.9197154, 1.1024108],
        [3.9218733, 2.4573317, 2.136584],
    ),
    (
        "Cu2O",
        [3.5517726, 2.9498696, 2.7518754],
        [0.11420702, 0.19389686, 0.6061339],
    ),
    (
        "CuO",
        [3.247541, 2.4478052, 2.2102196],
        [0.52108955, 0.57003075, 0.72217894],
    ),
    ("d-C", [2.7087197, 2.3188257, 2.2288976], [0.0, 0.0, 0.0]),
    (
        "Hg",
        [2.3989387, 1.440028, 0.9095704],
        [6.327587, 4.371925, 3.4217637],
    ),
    (
        "HgTe",
        [4.77904, 3.2311962, 2.6599011],
        [1.6316127, 1.5808104, 1.7292874],
    ),
    (
        "Ir",
        [3.0863, 2.0821905, 1.6179146],
        [5.592153, 4.067088, 3.267312],
    ),
    (
        "K",
        [0.06404319, 0.046409767, 0.038184915],
        [2.1041996, 1.34894, 0.9131259],
    ),
    (
        "Li",
        [0.26579094, 0.19561832, 0.22094862],
        [3.540155, 2.3111234, 1.6686072],
    ),
    (
        "MgO",
        [2.0895839, 1.6507235, 1.594879],
        [4.3326952e-12, 0.0, 2.4986457e-11],
    ),
    (
        "Mo",
        [4.483974, 3.5251307, 2.7763104],
        [4.1114373, 3.420827, 3.1506073],
    ),
    (
        "Na_palik",
        [0.060269356, 0.056140948, 0.061988432],
        [3.1792734, 2.1124904, 1.5790411],
    ),
    (
        "Nb",
        [3.420074, 2.7900932, 2.3956294],
        [3.4413946, 2.7376661, 2.5797458],
    ),
    (
        "Ni_palik",
        [2.3673046, 1.6633731, 1.4670781],
        [4.4988117, 3.050153, 2.3454392],
    ),
    (
        "Rh",
        [2.5857935, 1.8602164, 1.5542634],
        [6.7822604, 4.702987, 3.976073],
    ),
    (
        "Se",
        [4.0583115, 2.842935, 2.8208535],
        [0.75404954, 0.6384435, 0.52180755],
    ),
    (
        "Se_palik",
        [4.0583115, 2.842935, 2.8208535],
        [0.75404954, 0.6384435, 0.52180755],
    ),
    (
        "SiC",
        [3.1723416, 2.5259717, 2.4793706],
        [7.5376636e-07, 0.0, 1.0192531e-05],
    ),
    ("SnTe", [4.5242496, 1.981645, 1.2815913], [0.0, 0.0, 0.0]),
    (
        "Ta",
        [2.062721, 2.3929389, 2.6279287],
        [2.4083598, 1.7414864, 1.9470278],
    ),
    (
        "Te",
        [7.3902335, 4.482105, 2.637106],
        [3.2560222, 3.5270588, 3.2920542],
    ),
    ("ThF4", [1.8307136, 1.4422286, 1.3876476], [0.0, 0.0, 0.0]),
    (
        "TiC",
        [3.7005284, 2.8374221, 2.582287],
        [3.265635, 2.3515892, 2.1727905],
    ),
    (
        "TiN",
        [1.6484497, 1.150516, 1.3798234],
        [3.368328, 1.9434981, 1.1020677],
    ),
    (
        "TiO2",
        [3.45661, 2.8017359, 2.905175],
        [0.00010526484, 0.0, 0.0006528865],
    ),
    (
        "VC",
        [3.657566, 2.752736, 2.532672],
        [3.0683007, 2.1986873, 1.9631927],
    ),
    (
        "V_palik",
        [4.277582, 3.5129488, 2.7610714],
        [3.4913008, 2.8894548, 3.111522],
    ),
    (
        "VN",
        [2.8656023, 2.119189, 1.9400911],
        [3.0322425, 2.0561156, 1.6163063],
    ),
    (
        "W",
        [4.3708167, 3.3002465, 2.9984074],
        [3.5006406, 2.604874, 2.2732332],
    ),
];

/// Mitsuba 3's named indices of refraction (its `dielectric`'s
/// documentation's table), as its rgb variants hold them (f32; read back
/// from Mitsuba 3.9.1 with `mi.traverse(mi.load_dict({'type':
/// 'dielectric', 'int_ior': NAME, 'ext_ior': 'vacuum'}))['eta']`).
pub const NAMED_IORS: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// Millimetres of the diagonal of the 35 mm film (36 × 24 mm) that
/// Mitsuba's `focal_length` refers to.
const FILM_DIAGONAL_MM: f64 = 43.266_615_305_567_87;

/// An object's parameters as a plugin reads them: each one read is
/// marked, and [`Props::finish`] refuses any left unread.
struct Props<'a> {
    object: &'a Object,
    read: Vec<Cell<bool>>,
    children_read: Vec<Cell<bool>>,
}

/// A refusal or error at a place.
fn fail(at: &Location, message: String) -> SceneError {
    SceneError::Parse {
        path: at.file.clone(),
        line: at.line as usize,
        column: at.column as usize,
        field: String::new(),
        message,
    }
}

/// A plugin twintrace does not implement, refused by name.
fn unsupported(object: &Object, what: &str) -> SceneError {
    fail(
        &object.at,
        format!("{} {NOT_SUPPORTED}{what}", object.describe()),
    )
}

impl<'a> Props<'a> {
    fn new(object: &'a Object) -> Self {
        Self {
            object,
            read: object.props.iter().map(|_| Cell::new(false)).collect(),
            children_read: object.children.iter().map(|_| Cell::new(false)).collect(),
        }
    }

    fn get(&self, name: &str) -> Option<&'a Property> {
        let i = self.object.props.iter().rposition(|p| p.name == name)?;
        self.read[i].set(true);
        Some(&self.object.props[i])
    }

    fn wrong(&self, p: &Property, wanted: &str) -> SceneError {
        fail(
            &p.at,
            format!(
                "{}: \"{}\" must be {wanted}, not {}",
                self.object.describe(),
                p.name,
                p.value.kind()
            ),
        )
    }

    fn float(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        match self.get(name) {
            None => Ok(default),
            Some(p) => match p.value {
                Value::Float(v) => finite(p, v),
                Value::Integer(v) => Ok(v as f64),
                _ => Err(self.wrong(p, "a float")),
            },
        }
    }

    fn integer(&self, name: &str, default: i64) -> Result<i64, SceneError> {
        match self.get(name) {
            None => Ok(default),
            Some(p) => match p.value {
                Value::Integer(v) => Ok(v),
                _ => Err(self.wrong(p, "an integer")),
            },
        }
    }

    fn boolean(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        match self.get(name) {
            None => Ok(default),
            Some(p) => match p.value {
                Value::Boolean(v) => Ok(v),
                _ => Err(self.wrong(p, "a boolean")),
            },
        }
    }

    /// An index of refraction: a number, or one of Mitsuba's named
    /// materials ([`NAMED_IORS`]); `default` (a name) where absent.
    fn ior(&self, name: &str, default: &str) -> Result<f64, SceneError> {
        let named = |s: &str, at: &Location| {
            NAMED_IORS
                .iter()
                .find(|(n, _)| *n == s)
                .map(|(_, v)| *v)
                .ok_or_else(|| {
                    let names: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
                    fail(
                        at,
                        format!(
                            "\"{s}\" is not one of Mitsuba's named indices ({})",
                            names.join(", ")
                        ),
                    )
                })
        };
        match self.get(name) {
            None => named(default, &self.object.at),
            Some(p) => {
                let v = match &p.value {
                    Value::Float(v) => finite(p, *v)?,
                    Value::Integer(v) => *v as f64,
                    Value::String(s) => named(s, &p.at)?,
                    _ => return Err(self.wrong(p, "an index of refraction (a number or a name)")),
                };
                if v > 0.0 {
                    Ok(v)
                } else {
                    Err(fail(&p.at, format!("\"{name}\" = {v} must be positive")))
                }
            }
        }
    }

    fn string(&self, name: &str) -> Result<Option<&'a str>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::String(v) => Ok(Some(v.as_str())),
                _ => Err(self.wrong(p, "a string")),
            },
        }
    }

    fn transform(&self, name: &str) -> Result<Option<(DMat4, &'a Location)>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Transform(m) => Ok(Some((m, &p.at))),
                _ => Err(self.wrong(p, "a transform")),
            },
        }
    }

    fn point(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Point(v) | Value::Vector(v) => {
                    if v.is_finite() {
                        Ok(Some(v))
                    } else {
                        Err(fail(&p.at, format!("\"{}\" is not finite", p.name)))
                    }
                }
                _ => Err(self.wrong(p, "a point or vector")),
            },
        }
    }

    /// The nested objects of element `tag` (`bsdf`, `emitter`, ...),
    /// marked read.
    fn children(&self, tag: &str) -> Vec<&'a Child> {
        self.object
            .children
            .iter()
            .enumerate()
            .filter(|(_, c)| c.object.tag == tag)
            .map(|(i, c)| {
                self.children_read[i].set(true);
                c
            })
            .collect()
    }

    /// At most one nested object of element `tag`.
    fn child(&self, tag: &str) -> Result<Option<&'a Child>, SceneError> {
        let c = self.children(tag);
        match c.as_slice() {
            [] => Ok(None),
            [one] => Ok(Some(one)),
            [_, second, ..] => Err(fail(
                &second.object.at,
                format!("{} takes one {tag}, not several", self.object.describe()),
            )),
        }
    }

    /// A nested object filling parameter `name` (a texture or spectrum
    /// given as an object with `name="..."`).
    fn named_child(&self, name: &str) -> Option<&'a Child> {
        let i = self
            .object
            .children
            .iter()
            .position(|c| c.name.as_deref() == Some(name))?;
        self.children_read[i].set(true);
        Some(&self.object.children[i])
    }

    /// Refuses every parameter and nested object no one read.
    fn finish(self) -> Result<(), SceneError> {
        for (p, read) in self.object.props.iter().zip(&self.read) {
            if !read.get() {
                return Err(fail(
                    &p.at,
                    format!(
                        "parameter \"{}\" of {} {NOT_SUPPORTED} (or is misspelt)",
                        p.name,
                        self.object.describe()
                    ),
                ));
            }
        }
        for (c, read) in self.object.children.iter().zip(&self.children_read) {
            if !read.get() {
                let o = &c.object;
                return Err(fail(
                    &o.at,
                    format!(
                        "{} inside {} {NOT_SUPPORTED}",
                        o.describe(),
                        self.object.describe()
                    ),
                ));
            }
        }
        Ok(())
    }
}

fn finite(p: &Property, v: f64) -> Result<f64, SceneError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(fail(&p.at, format!("\"{}\" = {v} is not finite", p.name)))
    }
}

/// What a colour parameter feeds: reflectances keep a uniform spectrum
/// grey; emitters take it as the equal-energy illuminant
/// ([`EQUAL_ENERGY_RGB`]); a number (a roughness) is read as a
/// reflectance, but Mitsuba reads its textures through `eval_1`, where
/// its `checkerboard` gives `color0` on the squares where `eval` gives
/// `color1` (Mitsuba 3.9.1's checkerboard.cpp: `eval` takes `color0`
/// where the two half-period tests agree, `eval_1` where they differ).
#[derive(Clone, Copy, PartialEq)]
enum ColourUse {
    Reflectance,
    Emission,
    Number,
}

/// A colour parameter: a constant, or a texture (by id in the builder).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Colour {
    Constant(Vec3),
    Texture(u32),
}

/// The reader's state: the builder, the document, and what was made of
/// shared objects (a BSDF referenced by many shapes is one material; an
/// image read once).
struct Reader<'d> {
    doc: &'d Document,
    builder: SceneBuilder,
    /// Materials made, by (BSDF object, emitter object) identity.
    materials: HashMap<(usize, usize), u32>,
    images: HashMap<(PathBuf, bool), u32>,
    /// Meshes read, by (file, options) (instances of a group read their
    /// files once).
    meshes: HashMap<(PathBuf, bool, Option<bool>, u32), Rc<Mesh>>,
    sensor_seen: bool,
    /// The mesh attributes the `mesh_attribute` textures read since the
    /// material being made began, each with whether it is read as a
    /// number (Mitsuba's `eval_1`, of one channel only).
    attributes_read: Vec<(String, bool)>,
    /// By material: the mesh attributes its textures read (a shape's mesh
    /// gives them as its vertex colours).
    material_attributes: HashMap<u32, Vec<(String, bool)>>,
    /// The instanced group of each `shapegroup` drawn so far (by where it
    /// is in the file): its meshes' one copy, `None` where it has none.
    groups: HashMap<String, Option<u32>>,
}

/// Whether a shape plugin is a triangle mesh (what an instanced group
/// keeps one copy of).
fn is_mesh(kind: &str) -> bool {
    matches!(kind, "obj" | "ply" | "serialized" | "rectangle" | "cube")
}

/// Loads a Mitsuba 3 scene file with the command line's `-D` parameters.
pub fn load(path: &std::path::Path, defines: &[(String, String)]) -> Result<Scene, SceneError> {
    let doc = super::xml::parse_file(path, defines).map_err(|e| fail(&e.at, e.message))?;
    build(&doc)
}

/// Makes the scene of a parsed document.
pub fn build(doc: &Document) -> Result<Scene, SceneError> {
    let mut r = Reader {
        doc,
        builder: SceneBuilder::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        meshes: HashMap::new(),
        sensor_seen: false,
        attributes_read: Vec::new(),
        material_attributes: HashMap::new(),
        groups: HashMap::new(),
    };
    r.builder.render_origin = RenderOrigin::Camera;
    r.builder.background = Some(Background::Solid(Vec3::ZERO));
    // Mitsuba picks an emitter by its sampling_weight (default 1).
    r.builder.emitter_weights = Some(EmitterWeights {
        environment: 1.0,
        ..EmitterWeights::default()
    });
    r.builder.sources.push(doc.root.at.file.clone());
    let root = &doc.root;
    // Media first: a scene with media is refused for them, whatever else
    // it holds, since no image of it without them would be right.
    refuse_media(root)?;
    let mut settings = RenderSettings::default();
    let mut integrator_seen = false;
    for child in &root.children {
        let o = &child.object;
        match o.tag.as_str() {
            "integrator" => {
                if integrator_seen {
                    return Err(fail(&o.at, "the scene has more than one integrator".into()));
                }
                integrator_seen = true;
                integrator(o, &mut settings)?;
            }
            "sensor" => {
                if r.sensor_seen {
                    return Err(fail(
                        &o.at,
                        "the scene has more than one sensor (twintrace renders one camera)".into(),
                    ));
                }
                r.sensor_seen = true;
                r.sensor(o, &mut settings)?;
            }
            "emitter" => r.emitter(o)?,
            "shape" => r.shape(o, &Transform::default())?,
            // Objects defined at the top level only to be referenced.
            "bsdf" | "texture" => {}
            _ => return Err(unsupported(o, " at the scene's top level")),
        }
    }
    if !integrator_seen {
        // Mitsuba's default integrator: path, max_depth -1, rr_depth 5.
        settings.max_depth = MAX_DEPTH;
        settings.roulette_depth = 5;
    }
    if !r.sensor_seen {
        return Err(fail(&root.at, "the scene has no sensor".into()));
    }
    r.builder.render = settings;
    r.builder.build()
}

/// Refuses the first medium, phase function or volume anywhere in the
/// tree, and shapes that name a medium.
fn refuse_media(o: &Object) -> Result<(), SceneError> {
    for c in &o.children {
        let t = c.object.tag.as_str();
        if matches!(t, "medium" | "phase" | "volume") {
            return Err(fail(
                &c.object.at,
                format!(
                    "{} {NOT_SUPPORTED} (participating media are not implemented)",
                    c.object.describe()
                ),
            ));
        }
        refuse_media(&c.object)?;
    }
    Ok(())
}

fn integrator(o: &Object, settings: &mut RenderSettings) -> Result<(), SceneError> {
    let props = Props::new(o);
    match o.kind.as_str() {
        "moment" => {
            // The moment integrator renders its nested integrators'
            // images with their second moments: the image is the nested
            // one's.
            let nested = props.children("integrator");
            match nested.as_slice() {
                [one] => integrator(&one.object, settings)?,
                _ => return Err(unsupported(o, " with other than one nested integrator")),
            }
        }
        "path" | "direct" | "ptracer" => {
            let (depth, rr) = match o.kind.as_str() {
                // Mitsuba's direct illumination: emitters seen directly
                // and one scattering toward them (depth 2 in its terms).
                "direct" => {
                    for (name, default) in [("emitter_samples", 1), ("bsdf_samples", 1)] {
                        let n = props.integer(name, default)?;
                        if n != 1 {
                            return Err(unsupported(
                                o,
                                &format!(" with {name} = {n} (only 1 is read)"),
                            ));
                        }
                    }
                    (2, 5)
                }
                _ => {
                    let depth = props.integer("max_depth", -1)?;
                    let rr = props.integer("rr_depth", 5)?;
                    if o.kind == "ptracer" {
                        props.integer("samples_per_pass", -1)?;
                    }
                    (depth, rr)
                }
            };
            if props.boolean("hide_emitters", false)? {
                return Err(unsupported(o, " with hide_emitters"));
            }
            // Mitsuba's max_depth counts path vertices as twintrace's
            // counts ray segments: 1 sees emitters only, 2 adds direct
            // light, -1 is unbounded (twintrace's MAX_DEPTH).
            settings.max_depth = match depth {
                -1 => MAX_DEPTH,
                d if d >= 1 && d <= MAX_DEPTH as i64 => d as u32,
                d => {
                    return Err(fail(
                        &o.at,
                        format!("max_depth {d} must be -1 or between 1 and {MAX_DEPTH}"),
                    ))
                }
            };
            if rr < 1 || rr > MAX_DEPTH as i64 {
                return Err(fail(
                    &o.at,
                    format!("rr_depth {rr} must be between 1 and {MAX_DEPTH}"),
                ));
            }
            settings.roulette_depth = rr as u32;
        }
        _ => return Err(unsupported(o, "")),
    }
    props.finish()
}

impl Reader<'_> {
    fn sensor(&mut self, o: &Object, settings: &mut RenderSettings) -> Result<(), SceneError> {
        let props = Props::new(o);
        if !matches!(o.kind.as_str(), "perspective" | "thinlens" | "orthographic") {
            return Err(unsupported(o, ""));
        }
        let orthographic = o.kind == "orthographic";
        // The film first: the field of view's axis needs its aspect.
        let (width, height, filter) = match props.child("film")? {
            Some(f) => film(&f.object)?,
            // Mitsuba's default film: hdrfilm 768 x 576, gaussian filter.
            None => (768, 576, PixelFilter::Gaussian { stddev: 0.5 }),
        };
        self.builder.filter = filter;
        settings.width = width;
        settings.height = height;
        match props.child("sampler")? {
            Some(s) => sampler(&s.object, settings)?,
            None => {
                // Mitsuba's default sampler: independent, 4 samples.
                settings.sampler = PathSampler::Independent;
                settings.spp = 4;
            }
        }
        let aspect = width as f64 / height as f64;
        let vfov = if orthographic {
            CameraSettings::default().vfov as f64
        } else {
            perspective_vfov(o, &props, aspect)?
        };
        // twintrace's camera sees from its lens (an orthographic one from
        // its window) to infinity; the clip distances are read, not
        // applied, but where Mitsuba's orthographic window lies
        // (docs/mitsuba.md).
        let near = props.float("near_clip", 1e-2)?;
        props.float("far_clip", 1e4)?;
        for name in ["principal_point_offset_x", "principal_point_offset_y"] {
            if props.float(name, 0.0)? != 0.0 {
                return Err(unsupported(o, &format!(" with {name}")));
            }
        }
        let (aperture, focus) = if o.kind == "thinlens" {
            let r = props.float("aperture_radius", 0.0)?;
            let d = props.float("focus_distance", 0.0)?;
            (2.0 * r, d)
        } else {
            (0.0, 1.0)
        };
        let (m, at) = props
            .transform("to_world")?
            .map(|(m, at)| (m, at.clone()))
            .unwrap_or((DMat4::IDENTITY, o.at.clone()));
        let dir = m.transform_vector3(DVec3::Z);
        let up = m.transform_vector3(DVec3::Y);
        let left = m.transform_vector3(DVec3::X);
        // Mitsuba's orthographic window lies at near_clip along the view
        // (the sensor's z, scaled as to_world scales it).
        let origin = m.transform_point3(
            if orthographic && !mutants::is(Mutant::MitsubaOrthographicNearIgnored) {
                DVec3::new(0.0, 0.0, near)
            } else {
                DVec3::ZERO
            },
        );
        if !(dir.length() > 0.0 && up.length() > 0.0 && origin.is_finite()) {
            return Err(fail(&at, "the sensor's to_world is degenerate".into()));
        }
        // Mitsuba's frame has +x to the image's left (x = y × z); a
        // to_world that mirrors it would flip the image, which
        // twintrace's camera does not.
        if up.cross(dir).dot(left) <= 0.0 {
            return Err(fail(
                &at,
                format!("a sensor to_world that mirrors the image {NOT_SUPPORTED}"),
            ));
        }
        // Mitsuba maps the image through to_world: a shear or an unequal
        // scale of the image's two axes stretches it, which twintrace's
        // cameras (square pixels, the window as wide as the aspect makes
        // it) cannot; a perspective sensor's scale along the view only
        // moves its clip planes. 1e-6: far above the f64 rounding of a
        // lookat and a scale, far below any stretch one could see.
        let stretched = (left.length() - up.length()).abs() > 1e-6 * up.length()
            || left.dot(up).abs() > 1e-6 * left.length() * up.length()
            || (!orthographic
                && (left.dot(dir).abs() > 1e-6 * left.length() * dir.length()
                    || up.dot(dir).abs() > 1e-6 * up.length() * dir.length()));
        if stretched {
            return Err(fail(
                &at,
                format!("a sensor to_world that shears or stretches the image {NOT_SUPPORTED}"),
            ));
        }
        let projection = if orthographic {
            // The window: 2 wide and 2 / aspect tall in the sensor's space.
            Projection::Orthographic {
                height: (2.0 * up.length() / aspect) as f32,
            }
        } else {
            Projection::Perspective
        };
        let dir = dir.normalize();
        let camera = CameraSettings {
            look_from: origin.as_vec3(),
            look_at: (origin + dir).as_vec3(),
            up: up.normalize().as_vec3(),
            vfov: vfov as f32,
            aperture: aperture as f32,
            focus_distance: focus as f32,
            projection,
        };
        self.builder.set_camera_exact(origin, origin + dir, camera);
        props.finish()
    }

    fn emitter(&mut self, o: &Object) -> Result<(), SceneError> {
        let props = Props::new(o);
        let transform = props.transform("to_world")?;
        match o.kind.as_str() {
            "point" => {
                let intensity =
                    self.constant_colour(&props, "intensity", ColourUse::Emission, 1.0)?;
                let position = match (props.point("position")?, transform) {
                    (Some(_), Some((_, at))) => {
                        return Err(fail(at, "give position or to_world, not both".into()))
                    }
                    (Some(p), None) => p,
                    (None, Some((m, _))) => m.transform_point3(DVec3::ZERO),
                    (None, None) => DVec3::ZERO,
                };
                self.builder
                    .add_light(LightInput::Point {
                        position,
                        intensity,
                    })
                    .map_err(|e| fail(&o.at, e.to_string()))?;
            }
            "directional" => {
                let irradiance =
                    self.constant_colour(&props, "irradiance", ColourUse::Emission, 1.0)?;
                let direction = match (props.point("direction")?, transform) {
                    (Some(_), Some((_, at))) => {
                        return Err(fail(at, "give direction or to_world, not both".into()))
                    }
                    (Some(d), None) => d,
                    (None, Some((m, _))) => m.transform_vector3(DVec3::Z),
                    (None, None) => DVec3::Z,
                };
                let direction = direction
                    .try_normalize()
                    .ok_or_else(|| fail(&o.at, "the direction is zero".into()))?;
                self.builder
                    .add_light(LightInput::Directional {
                        direction: direction.as_vec3(),
                        irradiance,
                    })
                    .map_err(|e| fail(&o.at, e.to_string()))?;
            }
            // A constant environment is the same turned any way: its
            // to_world (read above) changes nothing.
            "constant" => {
                let radiance =
                    self.constant_colour(&props, "radiance", ColourUse::Emission, 1.0)?;
                if !matches!(self.builder.background, Some(Background::Solid(c)) if c == Vec3::ZERO)
                {
                    return Err(unsupported(o, " beside another environment emitter"));
                }
                self.builder.background = Some(Background::Solid(radiance));
            }
            "envmap" => {
                let name = props
                    .string("filename")?
                    .ok_or_else(|| fail(&o.at, format!("{} has no filename", o.describe())))?;
                let path = self.doc.resolve(name);
                let scale = props.float("scale", 1.0)?;
                if !(scale.is_finite() && scale >= 0.0) {
                    return Err(fail(
                        &o.at,
                        format!("scale {scale} must be finite and not negative"),
                    ));
                }
                if let Some(f) = props.string("filter_type")? {
                    if f != "bilinear" {
                        return Err(unsupported(o, &format!(" with filter_type \"{f}\"")));
                    }
                }
                // Mitsuba's envmap sampling option: the image is the same.
                props.boolean("mis_compensation", false)?;
                // Mitsuba reads the map at l = to_world⁻¹ · d, u = 0 along
                // −z of l; twintrace's equirect_uv has u = ½ there: half a
                // turn H about +y, so to_map = H · to_world⁻¹.
                let half_turn = if mutants::is(Mutant::MitsubaEnvmapNoHalfTurn) {
                    DMat3::IDENTITY
                } else {
                    DMat3::from_diagonal(DVec3::new(-1.0, 1.0, -1.0))
                };
                let to_map = match transform {
                    None => half_turn,
                    Some((m, at)) => {
                        let r = DMat3::from_mat4(m);
                        if !is_rotation(r) {
                            return Err(unsupported(
                                o,
                                &format!(" with a to_world that is not a rotation (at {at})"),
                            ));
                        }
                        half_turn * r.transpose()
                    }
                };
                if !matches!(self.builder.background, Some(Background::Solid(c)) if c == Vec3::ZERO)
                {
                    return Err(unsupported(o, " beside another environment emitter"));
                }
                let image = self.image(path, false, &o.at)?;
                self.builder.background = Some(Background::Envmap {
                    image,
                    intensity: scale as f32,
                    to_map: to_map.as_mat3(),
                    rows: EnvRows::Poles,
                });
            }
            "spot" => {
                let intensity =
                    self.constant_colour(&props, "intensity", ColourUse::Emission, 1.0)?;
                // Mitsuba's spot takes only a texture that varies.
                let texture = match self.colour(&props, "texture", ColourUse::Reflectance, 1.0)? {
                    Colour::Texture(t) => Some(t),
                    Colour::Constant(_) if props.get("texture").is_some() => {
                        return Err(fail(
                            &o.at,
                            "a spot's \"texture\" must vary over it (a bitmap or a checkerboard), as Mitsuba's must".into(),
                        ))
                    }
                    Colour::Constant(_) => None,
                };
                let cutoff = props.float("cutoff_angle", 20.0)?;
                let beam = props.float("beam_width", cutoff * 0.75)?;
                let (position, frame) = light_frame(o, transform)?;
                self.builder
                    .add_light(LightInput::SpotLinear {
                        position,
                        frame,
                        intensity,
                        cutoff_angle: cutoff.to_radians() as f32,
                        beam_width: beam.to_radians() as f32,
                        texture,
                    })
                    .map_err(|e| fail(&o.at, e.to_string()))?;
            }
            "projector" => {
                let scale = props.float("scale", 1.0)?;
                if !(scale.is_finite() && scale >= 0.0) {
                    return Err(fail(
                        &o.at,
                        format!("scale {scale} must be finite and not negative"),
                    ));
                }
                let factor = (std::f64::consts::PI * scale) as f32;
                let (intensity, texture) =
                    match self.colour(&props, "irradiance", ColourUse::Emission, 1.0)? {
                        Colour::Constant(c) => (c * factor, None),
                        Colour::Texture(t) => (Vec3::splat(factor), Some(t)),
                    };
                // Mitsuba's projector frames its field of view by its
                // texture's resolution (a bitmap's; 1 x 1 for others).
                let aspect = match texture.and_then(|t| self.builder.texture(t)) {
                    Some(Texture::Image { image, .. }) => {
                        let im = self.builder.image(*image).expect("the reader's image");
                        im.width as f64 / im.height as f64
                    }
                    _ => 1.0,
                };
                let tan_y = (perspective_vfov(o, &props, aspect)?.to_radians() / 2.0).tan();
                let (position, frame) = light_frame(o, transform)?;
                self.builder
                    .add_light(LightInput::Projector {
                        position,
                        frame,
                        intensity,
                        tan_half: DVec2::new(tan_y * aspect, tan_y).as_vec2(),
                        texture,
                    })
                    .map_err(|e| fail(&o.at, e.to_string()))?;
            }
            "area" => return Err(fail(&o.at, "an area emitter belongs inside a shape".into())),
            _ => return Err(unsupported(o, "")),
        }
        let weight = sampling_weight(&props)?;
        let weights = self.weights();
        match o.kind.as_str() {
            "envmap" => weights.environment = weight,
            // A constant environment is no light of twintrace's light set.
            "constant" => {}
            _ => weights.punctual.push(weight),
        }
        props.finish()
    }

    /// The emitter weights the reader fills (set when it starts).
    fn weights(&mut self) -> &mut EmitterWeights {
        self.builder
            .emitter_weights
            .get_or_insert_with(EmitterWeights::default)
    }

    /// A colour parameter that must be a constant (lights' intensities).
    fn constant_colour(
        &mut self,
        props: &Props,
        name: &str,
        usage: ColourUse,
        default: f64,
    ) -> Result<Vec3, SceneError> {
        match self.colour(props, name, usage, default)? {
            Colour::Constant(c) => Ok(c),
            Colour::Texture(_) => Err(fail(
                &props.object.at,
                format!(
                    "a textured \"{name}\" of {} {NOT_SUPPORTED}",
                    props.object.describe()
                ),
            )),
        }
    }

    /// A colour parameter: `rgb`, `spectrum`, a number, or a texture.
    fn colour(
        &mut self,
        props: &Props,
        name: &str,
        usage: ColourUse,
        default: f64,
    ) -> Result<Colour, SceneError> {
        if let Some(p) = props.get(name) {
            if props.named_child(name).is_some() {
                return Err(fail(&p.at, format!("\"{name}\" is given twice")));
            }
            let c = match &p.value {
                Value::Rgb(c) => *c,
                Value::Float(v) => DVec3::splat(*v),
                Value::Integer(v) => DVec3::splat(*v as f64),
                Value::Spectrum(Spectrum::Uniform(v)) => match usage {
                    ColourUse::Reflectance | ColourUse::Number => DVec3::splat(*v),
                    ColourUse::Emission if mutants::is(Mutant::MitsubaIlluminantGrey) => {
                        DVec3::splat(*v)
                    }
                    ColourUse::Emission => DVec3::from(EQUAL_ENERGY_RGB) * *v,
                },
                Value::Spectrum(Spectrum::Pairs(pairs)) => {
                    let converted = spectra::to_srgb(
                        pairs,
                        match usage {
                            ColourUse::Reflectance | ColourUse::Number => SpectrumUse::Reflectance,
                            ColourUse::Emission => SpectrumUse::Emission,
                        },
                    );
                    if converted.clamped {
                        self.builder.warnings.push(format!(
                            "{}: spectrum \"{name}\" is outside sRGB's gamut{}: clamped to {} as Mitsuba's rgb variants clamp it",
                            p.at,
                            if usage == ColourUse::Emission { "" } else { " or above 1" },
                            converted.rgb.as_vec3()
                        ));
                    }
                    converted.rgb
                }
                _ => return Err(props.wrong(p, "a colour")),
            };
            let c = c.as_vec3();
            if !c.is_finite() || c.min_element() < 0.0 {
                return Err(fail(
                    &p.at,
                    format!("\"{name}\" = {c} must be finite and not negative"),
                ));
            }
            return Ok(Colour::Constant(c));
        }
        match props.named_child(name) {
            None => Ok(Colour::Constant(Vec3::splat(default as f32))),
            Some(child) => {
                let t = &child.object;
                if t.tag != "texture" {
                    return Err(unsupported(t, &format!(" as \"{name}\"")));
                }
                Ok(Colour::Texture(self.texture(t, usage)?))
            }
        }
    }

    fn texture(&mut self, o: &Object, usage: ColourUse) -> Result<u32, SceneError> {
        let props = Props::new(o);
        match o.kind.as_str() {
            "bitmap" => {}
            "checkerboard" => return self.checkerboard(props, usage),
            "mesh_attribute" => return self.mesh_attribute(props, usage),
            "rawconstant" => return self.raw_constant(props),
            _ => return Err(unsupported(o, "")),
        }
        let name = props
            .string("filename")?
            .ok_or_else(|| fail(&o.at, format!("{} has no filename", o.describe())))?;
        let path = self.doc.resolve(name);
        let raw = props.boolean("raw", false)?;
        let wrap = match props.string("wrap_mode")?.unwrap_or("repeat") {
            "repeat" => Wrap::Repeat,
            "mirror" => Wrap::MirroredRepeat,
            "clamp" => Wrap::ClampToEdge,
            other => {
                return Err(fail(
                    &o.at,
                    format!("wrap_mode \"{other}\" is not repeat, mirror or clamp"),
                ))
            }
        };
        let nearest = match props.string("filter_type")?.unwrap_or("bilinear") {
            "bilinear" => false,
            "nearest" => true,
            other => {
                return Err(fail(
                    &o.at,
                    format!("filter_type \"{other}\" is not bilinear or nearest"),
                ))
            }
        };
        // Mitsuba's GPU texture units (`accel`, default on) filter with
        // 8-bit weights; twintrace's lookup is the exact one either way.
        props.boolean("accel", true)?;
        if let Some(format) = props.string("format")? {
            if format != "variant" {
                return Err(unsupported(o, &format!(" with format \"{format}\"")));
            }
        }
        // The bitmap's rows from the top, as twintrace's images: its lookup
        // is at F(A·F(uv) + b) in twintrace's coordinates.
        let transform = to_uv(&props)?.map(|m| {
            let [c0, c1, c2, c3, c4, c5] = m;
            [c0, c1, c2, -c3, -c4, 1.0 - c5].map(|x| x as f32)
        });
        let image = self.image(path, raw, &o.at)?;
        props.finish()?;
        self.builder
            .add_texture(Texture::Image {
                image,
                factor: Vec3::ONE,
                sampler: Sampler {
                    wrap_u: wrap,
                    wrap_v: wrap,
                    nearest,
                    transform,
                    tex_coord: 0,
                },
            })
            .map_err(|e| fail(&o.at, e.to_string()))
    }

    /// Mitsuba's `rawconstant`: its `value` (a number or a vector) as it
    /// is written, no colour conversion (data, as a normal map's).
    fn raw_constant(&mut self, props: Props) -> Result<u32, SceneError> {
        let o = props.object;
        let v = match props.get("value") {
            None => return Err(fail(&o.at, format!("{} has no value", o.describe()))),
            Some(p) => match p.value {
                Value::Float(v) => DVec3::splat(finite(p, v)?),
                Value::Integer(v) => DVec3::splat(v as f64),
                Value::Vector(v) | Value::Point(v) | Value::Rgb(v) if v.is_finite() => v,
                _ => return Err(props.wrong(p, "a finite number or vector")),
            },
        };
        props.finish()?;
        self.builder
            .add_texture(Texture::Constant(v.as_vec3()))
            .map_err(|e| fail(&o.at, e.to_string()))
    }

    /// The image at `path` (read once): `raw`, the values as stored, no
    /// sRGB decoding; else Mitsuba decodes 8- and 16-bit images' sRGB
    /// curve and keeps float images linear, as `load_image` does.
    fn image(&mut self, path: PathBuf, raw: bool, at: &Location) -> Result<u32, SceneError> {
        let key = (path.clone(), raw);
        if let Some(&i) = self.images.get(&key) {
            return Ok(i);
        }
        let data = load_image(&path, if raw { Some(false) } else { None })
            .map_err(|e| fail(at, e.to_string()))?;
        self.builder.sources.push(path);
        let i = self.builder.add_image(data);
        self.images.insert(key, i);
        Ok(i)
    }

    /// Mitsuba's `checkerboard`: `color0` (default 0.4) where the
    /// fractional parts of its coordinates (the shape's, through `to_uv`)
    /// are both above ½ or both at most ½, `color1` (default 0.2)
    /// elsewhere.
    fn checkerboard(&mut self, props: Props, usage: ColourUse) -> Result<u32, SceneError> {
        let o = props.object;
        let even = self.colour(&props, "color0", usage, 0.4)?;
        let even = self.texture_of(even, &o.at)?;
        let odd = self.colour(&props, "color1", usage, 0.2)?;
        let odd = self.texture_of(odd, &o.at)?;
        let (even, odd) = if usage == ColourUse::Number
            && !mutants::is(Mutant::MitsubaCheckerboardNumberUnswapped)
        {
            (odd, even)
        } else {
            (even, odd)
        };
        // The squares are found at Mitsuba's own coordinates, A·F(uv) + b.
        let [c0, c1, c2, c3, c4, c5] = to_uv(&props)?.unwrap_or([1.0, 0.0, 0.0, 0.0, -1.0, 1.0]);
        let transform = if mutants::is(Mutant::MitsubaCheckerboardUnflipped) {
            // A·uv + b: without Mitsuba's v flip.
            [c0, -c1, c2 + c1, c3, -c4, c5 + c4]
        } else {
            [c0, c1, c2, c3, c4, c5]
        }
        .map(|x| x as f32);
        props.finish()?;
        self.builder
            .add_texture(Texture::UvChecker {
                sampler: Sampler {
                    transform: Some(transform),
                    ..Sampler::default()
                },
                even,
                odd,
            })
            .map_err(|e| fail(&o.at, e.to_string()))
    }

    /// Mitsuba's `mesh_attribute`: the attribute `name` (`vertex_…` or
    /// `face_…`) of the mesh of the shape that uses it, times `scale`. The
    /// shape's mesh gives the attribute as its vertex colours
    /// ([`with_attribute`]), which the texture reads.
    fn mesh_attribute(&mut self, props: Props, usage: ColourUse) -> Result<u32, SceneError> {
        let o = props.object;
        let name = props
            .string("name")?
            .ok_or_else(|| fail(&o.at, format!("{} has no name", o.describe())))?
            .to_string();
        if !(name.starts_with("vertex_") || name.starts_with("face_")) {
            return Err(fail(
                &o.at,
                format!("mesh attribute \"{name}\" does not start with vertex_ or face_"),
            ));
        }
        let scale = props.float("scale", 1.0)? as f32;
        props.finish()?;
        self.attributes_read
            .push((name, usage == ColourUse::Number));
        self.builder
            .add_texture(Texture::VertexColor {
                factor: Vec3::splat(scale),
            })
            .map_err(|e| fail(&o.at, e.to_string()))
    }

    /// The material of a shape: its BSDF (Mitsuba's default, diffuse 0.5,
    /// where it has none) with its area emitter.
    fn material(
        &mut self,
        bsdf: Option<&Object>,
        emitter: Option<&Object>,
    ) -> Result<u32, SceneError> {
        let key = (
            bsdf.map_or(0, |b| b as *const Object as usize),
            emitter.map_or(0, |e| e as *const Object as usize),
        );
        if let Some(&m) = self.materials.get(&key) {
            return Ok(m);
        }
        let outer = std::mem::take(&mut self.attributes_read);
        let made = self.new_material(bsdf, emitter);
        let read = std::mem::replace(&mut self.attributes_read, outer);
        let id = made?;
        if !read.is_empty() {
            self.material_attributes.insert(id, read);
        }
        self.materials.insert(key, id);
        Ok(id)
    }

    /// [`Self::material`] made anew.
    fn new_material(
        &mut self,
        bsdf: Option<&Object>,
        emitter: Option<&Object>,
    ) -> Result<u32, SceneError> {
        let emission = match emitter {
            None => None,
            Some(e) => {
                if e.kind != "area" {
                    return Err(unsupported(e, " on a shape (only area emitters)"));
                }
                let props = Props::new(e);
                let c = self.colour(&props, "radiance", ColourUse::Emission, 1.0)?;
                sampling_weight(&props)?;
                props.finish()?;
                Some(self.texture_of(c, &e.at)?)
            }
        };
        let (material, wrap) = match (bsdf, emission) {
            // Mitsuba gives an emitter without a BSDF a black diffuse one:
            // it emits and reflects nothing.
            (None, Some(e)) => (Material::DiffuseLight { emission: e }, Wrappers::default()),
            // A shape without either: Mitsuba's one-sided diffuse 0.5.
            (None, None) => (
                Material::Lambertian {
                    albedo: self
                        .builder
                        .constant(Vec3::splat(0.5))
                        .map_err(|e| SceneError::invalid("bsdf", e.to_string()))?,
                },
                ONE_SIDED,
            ),
            (Some(b), _) => self.bsdf(b)?,
        };
        // Where an error is told: the BSDF, else the emitter, else (the
        // default material) the shape's "bsdf".
        let at = bsdf.map(|b| &b.at).or(emitter.map(|e| &e.at));
        let fail_at = |e: SceneError| match at {
            Some(at) => fail(at, e.to_string()),
            None => SceneError::invalid("bsdf", e.to_string()),
        };
        let id = self.builder.add_material(material).map_err(fail_at)?;
        self.builder.set_wrappers(id, wrap).map_err(fail_at)?;
        if let (Some(_), Some(e)) = (bsdf, emission) {
            self.builder
                .set_emission(id, e)
                .map_err(|err| fail(&emitter.unwrap().at, err.to_string()))?;
        }
        Ok(id)
    }

    fn texture_of(&mut self, c: Colour, at: &Location) -> Result<u32, SceneError> {
        match c {
            Colour::Texture(t) => Ok(t),
            Colour::Constant(c) => self
                .builder
                .constant(c)
                .map_err(|e| fail(at, e.to_string())),
        }
    }

    /// A BSDF and its wrappers: Mitsuba's `twosided` (both sides), `mask`
    /// (an opacity), and its models, one-sided unless they are dielectrics.
    fn bsdf(&mut self, o: &Object) -> Result<(Material, Wrappers), SceneError> {
        if o.kind == "null" {
            Props::new(o).finish()?;
            return self
                .builder
                .null_material()
                .map_err(|e| fail(&o.at, e.to_string()));
        }
        if o.kind == "mask" {
            let props = Props::new(o);
            let nested = props.children("bsdf");
            let [one] = nested.as_slice() else {
                return Err(unsupported(o, " with other than one nested bsdf"));
            };
            let (material, wrap) = self.bsdf(&one.object)?;
            if wrap.opacity.is_some() {
                return Err(unsupported(&one.object, " inside a mask"));
            }
            let opacity = self.one_channel(&props, "opacity", 0.5)?;
            props.finish()?;
            return Ok((
                material,
                Wrappers {
                    opacity: Some(opacity),
                    ..wrap
                },
            ));
        }
        if o.kind == "blendbsdf" {
            return self.blend(o, false);
        }
        if o.kind == "principled" || o.kind == "principledthin" {
            return Ok((self.principled(o)?, Wrappers::default()));
        }
        if o.kind == "normalmap" {
            return self.normal_map(o);
        }
        if o.kind == "bumpmap" {
            return self.bump_map(o);
        }
        if o.kind == "twosided" {
            let props = Props::new(o);
            let nested = props.children("bsdf");
            if let [one] = nested.as_slice() {
                if matches!(one.object.kind.as_str(), "normalmap" | "bumpmap") {
                    // Both sides, each seeing the map in the frame turned
                    // to it.
                    let (m, wrap) = if one.object.kind == "normalmap" {
                        self.normal_map(&one.object)?
                    } else {
                        self.bump_map(&one.object)?
                    };
                    if !wrap.one_sided {
                        return Err(unsupported(
                            &one.object,
                            " inside twosided around a model that takes both sides itself",
                        ));
                    }
                    // A blend's second BSDF takes both sides too.
                    if let Some(b) = wrap.blend {
                        self.builder
                            .set_wrappers(b.second, Wrappers::default())
                            .map_err(|e| fail(&o.at, e.to_string()))?;
                    }
                    props.finish()?;
                    return Ok((
                        m,
                        Wrappers {
                            one_sided: false,
                            normal_map_mirrored: true,
                            ..wrap
                        },
                    ));
                }
            }
            if let [one] = nested.as_slice() {
                if one.object.kind == "blendbsdf" {
                    let blend = self.blend(&one.object, true)?;
                    props.finish()?;
                    return Ok(blend);
                }
            }
            let m = match nested.as_slice() {
                [one]
                    if matches!(
                        one.object.kind.as_str(),
                        "diffuse" | "conductor" | "roughconductor" | "plastic" | "roughplastic"
                    ) =>
                {
                    self.one_sided_bsdf(&one.object)?
                }
                [one] => return Err(unsupported(&one.object, " inside twosided")),
                _ => return Err(unsupported(o, " with other than one nested bsdf")),
            };
            props.finish()?;
            return Ok((m, Wrappers::default()));
        }
        if matches!(o.kind.as_str(), "dielectric" | "thindielectric") {
            return Ok((self.dielectric(o)?, Wrappers::default()));
        }
        if o.kind == "roughdielectric" {
            return Ok((self.rough_dielectric(o)?, Wrappers::default()));
        }
        Ok((self.one_sided_bsdf(o)?, ONE_SIDED))
    }

    /// A texture that Mitsuba reads by `eval_1` (a mask's opacity, a
    /// blend's weight, the principled BSDF's numbers), `default` where
    /// absent: an `rgb` constant's mean (a bitmap's
    /// luminance, which `material::opacity_of` reads); a checkerboard of
    /// colours is refused (Mitsuba reads their means).
    fn one_channel(&mut self, props: &Props, name: &str, default: f64) -> Result<u32, SceneError> {
        let o = props.object;
        let value = match self.colour(props, name, ColourUse::Number, default)? {
            Colour::Constant(c) => Colour::Constant(Vec3::splat((c.x + c.y + c.z) / 3.0)),
            t => t,
        };
        let texture = self.texture_of(value, &o.at)?;
        if let Some(Texture::UvChecker { even, odd, .. }) = self.builder.texture(texture) {
            let coloured = |t: &u32| matches!(self.builder.texture(*t), Some(Texture::Constant(c)) if c.x != c.y || c.y != c.z);
            if coloured(even) || coloured(odd) {
                return Err(unsupported(
                    o,
                    &format!(" with a checkerboard of colours as its {name} (Mitsuba reads their means; give numbers)"),
                ));
            }
        }
        Ok(texture)
    }

    /// Mitsuba's `blendbsdf`: `weight` (a number or a texture, read as a
    /// mask's opacity, [`Self::one_channel`]) of the second of its two
    /// nested BSDFs against the first ([`crate::material::Blend`]). Each is
    /// a model with its own side (inside `twosided` there: both sides); a
    /// mask, a map or a blend inside is refused (put it around the blend).
    /// The first is the material returned, the second a material of its
    /// own. `two_sided`: the blend is inside `twosided`, which gives both
    /// BSDFs both sides.
    fn blend(&mut self, o: &Object, two_sided: bool) -> Result<(Material, Wrappers), SceneError> {
        let props = Props::new(o);
        let nested = props.children("bsdf");
        let [first, second] = nested.as_slice() else {
            return Err(unsupported(o, " with other than two nested bsdfs"));
        };
        let weight = self.one_channel(&props, "weight", 0.5)?;
        let read = |this: &mut Self, one: &Object| -> Result<(Material, bool), SceneError> {
            if matches!(
                one.kind.as_str(),
                "normalmap" | "mask" | "bumpmap" | "blendbsdf"
            ) {
                return Err(unsupported(
                    one,
                    " inside a blendbsdf (put it around the blend)",
                ));
            }
            let (m, wrap) = this.bsdf(one)?;
            if wrap.normal_map.is_some() {
                return Err(unsupported(
                    one,
                    " with a map, inside a blendbsdf (put the map around the blend)",
                ));
            }
            Ok((m, wrap.one_sided && !two_sided))
        };
        let (m0, one_sided0) = read(self, &first.object)?;
        let (m1, one_sided1) = read(self, &second.object)?;
        let at = &second.object.at;
        let id = self
            .builder
            .add_material(m1)
            .map_err(|e| fail(at, e.to_string()))?;
        self.builder
            .set_wrappers(
                id,
                Wrappers {
                    one_sided: one_sided1,
                    ..Wrappers::default()
                },
            )
            .map_err(|e| fail(at, e.to_string()))?;
        props.finish()?;
        Ok((
            m0,
            Wrappers {
                one_sided: one_sided0,
                blend: Some(Blend { weight, second: id }),
                ..Wrappers::default()
            },
        ))
    }

    /// Mitsuba's `principled` (both sides its own; [`crate::principled`]):
    /// `base_color` (0.5) a colour or a texture, `roughness` (0.5) and the
    /// lobes' numbers, each a number or a texture read by `eval_1`; a lobe
    /// absent or given as the number 0 is off, as Mitsuba's `get_flag`
    /// reads it; `eta`, or `specular` (0.5) standing for one, not both.
    /// Sampling rates other than 1 are refused. Its thin sheet,
    /// `principledthin`, has `diff_trans` and no metal or clear coat, and
    /// its `eta` (1.5) a number (a texture is refused).
    fn principled(&mut self, o: &Object) -> Result<Material, SceneError> {
        let thin = o.kind == "principledthin";
        let props = Props::new(o);
        let base_color = self.colour(&props, "base_color", ColourUse::Reflectance, 0.5)?;
        let base_color = self.texture_of(base_color, &o.at)?;
        let roughness = self.one_channel(&props, "roughness", 0.5)?;
        let lobe = |this: &mut Self, name: &str| -> Result<Option<u32>, SceneError> {
            let given = props.object.props.iter().rposition(|p| p.name == name);
            let off = given.is_some_and(
                |i| matches!(props.object.props[i].value, Value::Float(v) if v == 0.0),
            );
            if off {
                props.get(name);
                return Ok(None);
            }
            if given.is_none() && props.named_child(name).is_none() {
                return Ok(None);
            }
            this.one_channel(&props, name, 0.0).map(Some)
        };
        let anisotropic = lobe(self, "anisotropic")?;
        let spec_trans = lobe(self, "spec_trans")?;
        let sheen = lobe(self, "sheen")?;
        let sheen_tint = lobe(self, "sheen_tint")?;
        let flatness = lobe(self, "flatness")?;
        let spec_tint = lobe(self, "spec_tint")?;
        if thin {
            let diff_trans = lobe(self, "diff_trans")?;
            for rate in [
                "specular_reflectance_sampling_rate",
                "specular_transmittance_sampling_rate",
                "diffuse_reflectance_sampling_rate",
                "diffuse_transmittance_sampling_rate",
            ] {
                if props.float(rate, 1.0)? != 1.0 {
                    return Err(unsupported(o, &format!(" with a {rate} other than 1")));
                }
            }
            if props.named_child("eta").is_some() {
                return Err(unsupported(o, " with a textured \"eta\""));
            }
            let eta = props.float("eta", 1.5)? as f32;
            props.finish()?;
            return Ok(Material::Principled {
                base_color,
                roughness,
                lobes: PrincipledLobes {
                    anisotropic,
                    spec_trans,
                    sheen,
                    sheen_tint,
                    flatness,
                    spec_tint,
                    diff_trans,
                    ..PrincipledLobes::default()
                },
                eta,
                thin,
            });
        }
        let metallic = lobe(self, "metallic")?;
        let clearcoat = lobe(self, "clearcoat")?;
        let clearcoat_gloss = match clearcoat {
            Some(_) => Some(self.one_channel(&props, "clearcoat_gloss", 0.0)?),
            None => {
                // Read (and checked) as Mitsuba reads it, unused without a coat.
                self.one_channel(&props, "clearcoat_gloss", 0.0)?;
                None
            }
        };
        for rate in [
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
            "diffuse_reflectance_sampling_rate",
        ] {
            if props.float(rate, 1.0)? != 1.0 {
                return Err(unsupported(o, &format!(" with a {rate} other than 1")));
            }
        }
        let has = |name: &str| props.object.props.iter().any(|p| p.name == name);
        let eta = match (has("eta"), has("specular")) {
            (true, true) => {
                return Err(fail(
                    &o.at,
                    format!("{}: give \"eta\" or \"specular\", not both", o.describe()),
                ))
            }
            (true, false) => {
                let eta = props.float("eta", 1.5)? as f32;
                if spec_trans.is_some() && eta == 1.0 {
                    // Mitsuba's: an index of 1 transmits through no interface.
                    1.001
                } else {
                    eta
                }
            }
            (false, _) => {
                let mut specular = props.float("specular", 0.5)? as f32;
                if spec_trans.is_some() && specular == 0.0 {
                    // Mitsuba's: a specular of 0 is an index of 1.
                    specular = 1e-3;
                }
                crate::principled::eta_of_specular(specular)
            }
        };
        props.finish()?;
        Ok(Material::Principled {
            base_color,
            roughness,
            lobes: PrincipledLobes {
                anisotropic,
                spec_trans,
                metallic,
                clearcoat,
                clearcoat_gloss,
                sheen,
                sheen_tint,
                flatness,
                spec_tint,
                diff_trans: None,
            },
            eta,
            thin,
        })
    }

    /// Mitsuba's `normalmap` around a BSDF: its `normalmap` texture (data:
    /// a bitmap is read `raw` only where the file says so, as Mitsuba
    /// reads it) perturbs the shading frame the BSDF sees
    /// ([`crate::material::NormalMapped`]). A mask or another map inside
    /// it is refused (put the mask outside).
    fn normal_map(&mut self, o: &Object) -> Result<(Material, Wrappers), SceneError> {
        let props = Props::new(o);
        let (material, wrap) = self.mapped_bsdf(&props)?;
        if props.named_child("normalmap").is_none() && props.get("normalmap").is_none() {
            return Err(fail(
                &o.at,
                format!("{} has no \"normalmap\" texture", o.describe()),
            ));
        }
        let map = self.colour(&props, "normalmap", ColourUse::Reflectance, 0.0)?;
        let map = self.texture_of(map, &o.at)?;
        map_defaults(&props)?;
        props.finish()?;
        Ok((
            material,
            Wrappers {
                normal_map: Some(map),
                normal_map_mirrored: false,
                ..wrap
            },
        ))
    }

    /// Mitsuba's `bumpmap` around a BSDF: the gradient of its one texture
    /// (a `bitmap`, the only texture whose gradient Mitsuba 3.9.1 gives;
    /// read `raw` only where the file says so) times `scale` bends the
    /// shading frame the BSDF sees ([`crate::material::NormalMapped::bumped`]).
    /// The scale is the texture's factor, so a negative one is refused. A
    /// mask or another map inside it is refused (put the mask outside).
    fn bump_map(&mut self, o: &Object) -> Result<(Material, Wrappers), SceneError> {
        let props = Props::new(o);
        let (material, wrap) = self.mapped_bsdf(&props)?;
        let textures = props.children("texture");
        let [height] = textures.as_slice() else {
            return Err(fail(
                &o.at,
                format!(
                    "{} has {} textures (it takes one: the height)",
                    o.describe(),
                    textures.len()
                ),
            ));
        };
        if height.object.kind != "bitmap" {
            return Err(unsupported(
                &height.object,
                " as a bumpmap's height (Mitsuba 3.9.1 takes the gradient of a bitmap only)",
            ));
        }
        let scale = props.float("scale", 1.0)?;
        if scale < 0.0 {
            return Err(unsupported(o, &format!(" with a negative scale ({scale})")));
        }
        let id = self.texture(&height.object, ColourUse::Number)?;
        let Some(&Texture::Image { image, sampler, .. }) = self.builder.texture(id) else {
            return Err(fail(&o.at, "a bitmap did not read as an image".into()));
        };
        let map = self
            .builder
            .add_texture(Texture::Image {
                image,
                factor: Vec3::splat(scale as f32),
                sampler,
            })
            .map_err(|e| fail(&o.at, e.to_string()))?;
        map_defaults(&props)?;
        props.finish()?;
        Ok((
            material,
            Wrappers {
                normal_map: Some(map),
                normal_map_mirrored: false,
                bump_map: true,
                ..wrap
            },
        ))
    }

    /// The one BSDF inside a `normalmap` or `bumpmap` (`props`' object),
    /// read; a mask or another map there is refused.
    fn mapped_bsdf(&mut self, props: &Props) -> Result<(Material, Wrappers), SceneError> {
        let o = props.object;
        let nested = props.children("bsdf");
        let [one] = nested.as_slice() else {
            return Err(unsupported(o, " with other than one nested bsdf"));
        };
        if matches!(one.object.kind.as_str(), "normalmap" | "mask" | "bumpmap") {
            return Err(unsupported(&one.object, &format!(" inside a {}", o.kind)));
        }
        self.bsdf(&one.object)
    }

    /// Mitsuba's smooth `dielectric` or `thindielectric` (both sides their
    /// own): `int_ior` (default "bk7") over `ext_ior` (default "air"), each
    /// a number or a name, and the two tints.
    fn dielectric(&mut self, o: &Object) -> Result<Material, SceneError> {
        let props = Props::new(o);
        let (eta, reflectance, transmittance) = self.interface(&props)?;
        let m =
            Material::dielectric_of(o.kind == "thindielectric", eta, reflectance, transmittance);
        props.finish()?;
        Ok(m)
    }

    /// A dielectric's `int_ior` (default "bk7") over `ext_ior` (default
    /// "air"), and its two tints as textures.
    fn interface(&mut self, props: &Props) -> Result<(f32, u32, u32), SceneError> {
        let at = &props.object.at;
        let eta = props.ior("int_ior", "bk7")? / props.ior("ext_ior", "air")?;
        let reflectance =
            self.colour(props, "specular_reflectance", ColourUse::Reflectance, 1.0)?;
        let transmittance =
            self.colour(props, "specular_transmittance", ColourUse::Reflectance, 1.0)?;
        Ok((
            eta as f32,
            self.texture_of(reflectance, at)?,
            self.texture_of(transmittance, at)?,
        ))
    }

    /// Mitsuba's `roughdielectric` (both sides its own): the smooth
    /// dielectric's indices and tints on microfacets
    /// ([`Self::microfacets`]).
    fn rough_dielectric(&mut self, o: &Object) -> Result<Material, SceneError> {
        let props = Props::new(o);
        let (eta, reflectance, transmittance) = self.interface(&props)?;
        let (distribution, (alpha, alpha_v)) = self.microfacets(&props)?;
        let m = Material::RoughDielectric {
            distribution,
            alpha,
            alpha_v,
            eta,
            reflectance,
            transmittance,
        };
        props.finish()?;
        Ok(m)
    }

    /// A microfacet model's `distribution` (default Beckmann) and
    /// roughness ([`Self::roughness`]). Visible normals sampled or not
    /// (`sample_visible`), the same BSDF: only the noise differs, and
    /// twintrace always samples the visible ones.
    fn microfacets(&mut self, props: &Props) -> Result<(u32, (u32, Option<u32>)), SceneError> {
        let distribution = match props.string("distribution")?.unwrap_or("beckmann") {
            "beckmann" => crate::microfacet::distribution::BECKMANN,
            "ggx" => crate::microfacet::distribution::GGX,
            other => {
                return Err(fail(
                    &props.object.at,
                    format!("distribution \"{other}\" is not beckmann or ggx"),
                ))
            }
        };
        props.boolean("sample_visible", true)?;
        Ok((distribution, self.roughness(props)?))
    }

    /// A BSDF Mitsuba makes one-sided (`twosided` makes it two-sided; all
    /// twintrace's materials are).
    fn one_sided_bsdf(&mut self, o: &Object) -> Result<Material, SceneError> {
        let props = Props::new(o);
        let m = match o.kind.as_str() {
            "diffuse" => {
                let c = self.colour(&props, "reflectance", ColourUse::Reflectance, 0.5)?;
                Material::Lambertian {
                    albedo: self.texture_of(c, &o.at)?,
                }
            }
            "conductor" => {
                let (eta, k) = self.conductor_index(&props)?;
                let specular =
                    self.colour(&props, "specular_reflectance", ColourUse::Reflectance, 1.0)?;
                Material::Conductor {
                    specular: self.texture_of(specular, &o.at)?,
                    eta,
                    k,
                }
            }
            "roughconductor" => {
                let (eta, k) = self.conductor_index(&props)?;
                let specular =
                    self.colour(&props, "specular_reflectance", ColourUse::Reflectance, 1.0)?;
                let (distribution, (alpha, alpha_v)) = self.microfacets(&props)?;
                Material::RoughConductor {
                    distribution,
                    alpha,
                    alpha_v,
                    specular: self.texture_of(specular, &o.at)?,
                    eta,
                    k,
                }
            }
            "plastic" => {
                // Mitsuba's defaults: polypropylene (1.49) over air.
                let eta = props.ior("int_ior", "polypropylene")? / props.ior("ext_ior", "air")?;
                let diffuse =
                    self.colour(&props, "diffuse_reflectance", ColourUse::Reflectance, 0.5)?;
                let specular =
                    self.colour(&props, "specular_reflectance", ColourUse::Reflectance, 1.0)?;
                let nonlinear = props.boolean("nonlinear", false)?;
                let (diffuse, specular) = (
                    self.texture_of(diffuse, &o.at)?,
                    self.texture_of(specular, &o.at)?,
                );
                self.builder
                    .plastic(diffuse, specular, eta as f32, nonlinear)
                    .map_err(|e| fail(&o.at, e.to_string()))?
            }
            "roughplastic" => {
                let eta = props.ior("int_ior", "polypropylene")? / props.ior("ext_ior", "air")?;
                let (distribution, (alpha, alpha_v)) = self.microfacets(&props)?;
                if alpha_v.is_some() {
                    return Err(unsupported(
                        o,
                        " with alpha_u other than alpha_v (Mitsuba's roughplastic is isotropic)",
                    ));
                }
                // Mitsuba's roughplastic takes its roughness as a number.
                let alpha = match self.builder.texture(alpha) {
                    Some(&Texture::Constant(c)) => c.x,
                    _ => return Err(unsupported(o, " with a textured roughness")),
                };
                let diffuse =
                    self.colour(&props, "diffuse_reflectance", ColourUse::Reflectance, 0.5)?;
                let specular =
                    self.colour(&props, "specular_reflectance", ColourUse::Reflectance, 1.0)?;
                let nonlinear = props.boolean("nonlinear", false)?;
                let textures = (
                    self.texture_of(diffuse, &o.at)?,
                    self.texture_of(specular, &o.at)?,
                );
                self.builder
                    .rough_plastic(distribution, alpha, textures, eta as f32, nonlinear)
                    .map_err(|e| fail(&o.at, e.to_string()))?
            }
            _ => return Err(unsupported(o, "")),
        };
        props.finish()?;
        Ok(m)
    }

    /// A conductor's complex index. Mitsuba's rule: `eta` given, or
    /// `material` "none" (the default), reads eta (default 0) and k
    /// (default 1); a named material reads Mitsuba's tabulated spectra.
    fn conductor_index(&mut self, props: &Props) -> Result<(Vec3, Vec3), SceneError> {
        let o = props.object;
        let material = props.string("material")?.unwrap_or("none");
        let explicit = ["eta", "k"]
            .iter()
            .any(|n| props.get(n).is_some() || props.named_child(n).is_some());
        match (material, explicit) {
            ("none", _) => {}
            (_, true) => {
                return Err(fail(
                    &o.at,
                    "give either eta and k or a material, not both".into(),
                ))
            }
            (name, false) => {
                let Some((_, eta, k)) = NAMED_CONDUCTORS.iter().find(|(n, ..)| *n == name) else {
                    let names: Vec<&str> = NAMED_CONDUCTORS.iter().map(|(n, ..)| *n).collect();
                    return Err(fail(
                        &o.at,
                        format!(
                            "material \"{name}\" is not one of Mitsuba's tabulated conductors (none, {})",
                            names.join(", ")
                        ),
                    ));
                };
                return Ok((Vec3::from_array(*eta), Vec3::from_array(*k)));
            }
        }
        let eta = self.constant_colour(props, "eta", ColourUse::Reflectance, 0.0)?;
        let k = self.constant_colour(props, "k", ColourUse::Reflectance, 1.0)?;
        Ok((eta, k))
    }

    /// A microfacet model's roughness (`alpha`, default 0.1, or `alpha_u`
    /// and `alpha_v`), each a number or a checkerboard of numbers, as a
    /// texture: `alpha`, or `alpha_u` and, where it differs, `alpha_v`
    /// (anisotropic: along and across the surface's tangent,
    /// [`crate::material::rough_lobe`]).
    fn roughness(&mut self, props: &Props) -> Result<(u32, Option<u32>), SceneError> {
        let o = props.object;
        let given = |name: &str| props.get(name).is_some() || props.named_child(name).is_some();
        let one = |reader: &mut Self, name: &str| -> Result<Colour, SceneError> {
            if let Some(child) = props.named_child(name) {
                if child.object.kind != "checkerboard" {
                    return Err(unsupported(&child.object, &format!(" as \"{name}\"")));
                }
            }
            match reader.colour(props, name, ColourUse::Number, 0.1)? {
                Colour::Constant(c) if c.x != c.y || c.y != c.z => Err(fail(
                    &o.at,
                    format!("\"{name}\" = {c} is a colour, not a roughness"),
                )),
                c => Ok(c),
            }
        };
        let alpha = match (given("alpha"), given("alpha_u"), given("alpha_v")) {
            (_, false, false) => one(self, "alpha")?,
            (false, true, true) => {
                let (u, v) = (one(self, "alpha_u")?, one(self, "alpha_v")?);
                if u != v {
                    let u = self.texture_of(u, &o.at)?;
                    return Ok((u, Some(self.texture_of(v, &o.at)?)));
                }
                u
            }
            (true, _, _) => {
                return Err(fail(
                    &o.at,
                    "give either alpha or alpha_u and alpha_v, not both".into(),
                ))
            }
            _ => return Err(fail(&o.at, "give both alpha_u and alpha_v".into())),
        };
        Ok((self.texture_of(alpha, &o.at)?, None))
    }

    /// A shape, placed by `outer` (an instance's transform, or none).
    fn shape(&mut self, o: &Object, outer: &Transform) -> Result<(), SceneError> {
        let props = Props::new(o);
        match o.kind.as_str() {
            "shapegroup" => {
                // Defined here, drawn by its instances. Mitsuba instances
                // neither groups nor emitters.
                for c in props.children("shape") {
                    if matches!(c.object.kind.as_str(), "shapegroup" | "instance") {
                        return Err(unsupported(&c.object, " inside a shapegroup"));
                    }
                    if let Some(e) = Props::new(&c.object).child("emitter")? {
                        return Err(unsupported(
                            &e.object,
                            " on a shape of a shapegroup (Mitsuba cannot instance an emitter)",
                        ));
                    }
                }
                return props.finish();
            }
            "instance" => {
                let group = props.children("shape");
                let group = match group.as_slice() {
                    [g] if g.object.kind == "shapegroup" => g.object.clone(),
                    _ => {
                        return Err(fail(
                            &o.at,
                            "an instance takes one shapegroup reference".into(),
                        ))
                    }
                };
                let m = self.placement(&props, outer)?;
                props.finish()?;
                // The group's meshes: one copy in the group's own space,
                // made at its first instance, seen through each; its
                // analytic shapes (a map and a few numbers each) placed
                // by each instance.
                if let Some(g) = self.mesh_group(&group)? {
                    self.builder
                        .add_instance(g, &m)
                        .map_err(|e| fail(&o.at, format!("{}: {e}", o.describe())))?;
                }
                for c in &group.children {
                    if c.object.tag == "shape" && !is_mesh(&c.object.kind) {
                        self.shape(&c.object, &m)?;
                    }
                }
                return Ok(());
            }
            _ => {}
        }
        // An emitting shape's primitives share its weight.
        let first = self.builder.primitive_count() as u32;
        let weight = match props.child("emitter")? {
            Some(e) => Some(sampling_weight(&Props::new(&e.object))?),
            None => None,
        };
        self.surface(o, props, outer)?;
        if let Some(w) = weight {
            let end = self.builder.primitive_count() as u32;
            self.weights().shapes.push((first..end, w));
        }
        Ok(())
    }

    /// The instanced group of `group`'s meshes (made once: at its first
    /// instance), `None` where it has none.
    fn mesh_group(&mut self, group: &Object) -> Result<Option<u32>, SceneError> {
        let key = format!("{:?}", group.at);
        if let Some(&g) = self.groups.get(&key) {
            return Ok(g);
        }
        let meshes: Vec<&Object> = (group.children.iter())
            .filter(|c| c.object.tag == "shape" && is_mesh(&c.object.kind))
            .map(|c| &*c.object)
            .collect();
        let g = if meshes.is_empty() {
            None
        } else {
            let place = |e: SceneError| fail(&group.at, format!("{}: {e}", group.describe()));
            self.builder.begin_group().map_err(place)?;
            for m in meshes {
                self.shape(m, &Transform::default())?;
            }
            Some(self.builder.end_group().map_err(place)?)
        };
        self.groups.insert(key, g);
        Ok(g)
    }

    /// A shape that is not a group or an instance: its primitives.
    fn surface(&mut self, o: &Object, props: Props, outer: &Transform) -> Result<(), SceneError> {
        let bsdf = props.child("bsdf")?.map(|c| c.object.clone());
        let emitter = props.child("emitter")?.map(|c| c.object.clone());
        let flip = props.boolean("flip_normals", false)?;
        let transform = self.placement(&props, outer)?;
        let material = self.material(bsdf.as_deref(), emitter.as_deref())?;
        let at = o.at.clone();
        let place = |e: SceneError| fail(&at, format!("{}: {e}", o.describe()));
        // The mesh attribute its material's textures read (one at most).
        let attribute = match self.material_attributes.get(&material).map(Vec::as_slice) {
            None | Some([]) => None,
            Some([first, rest @ ..]) => {
                if let Some((other, _)) = rest.iter().find(|(n, _)| *n != first.0) {
                    let first = &first.0;
                    return Err(unsupported(
                        o,
                        &format!(
                            " whose textures read two mesh attributes (\"{first}\", \"{other}\")"
                        ),
                    ));
                }
                if !matches!(o.kind.as_str(), "obj" | "ply" | "serialized") {
                    return Err(fail(
                        &o.at,
                        format!("{}: a mesh_attribute texture needs a mesh", o.describe()),
                    ));
                }
                let number = rest.iter().chain([first]).any(|(_, number)| *number);
                Some((first.0.clone(), number))
            }
        };
        match o.kind.as_str() {
            "sphere" => {
                let center = props.point("center")?.unwrap_or(DVec3::ZERO);
                let radius = props.float("radius", 1.0)?;
                let mut framed =
                    self.reads_uv(material) || bsdf.as_deref().is_some_and(uses_texture);
                if let Some((m, w, _)) = self.builder.material_parts(material) {
                    let anisotropic = |m: &Material| {
                        matches!(
                            m,
                            Material::RoughConductor {
                                alpha_v: Some(_),
                                ..
                            } | Material::RoughDielectric {
                                alpha_v: Some(_),
                                ..
                            }
                        ) || matches!(m, Material::Principled { lobes, .. } if lobes.anisotropic.is_some())
                    };
                    let second = w
                        .blend
                        .and_then(|b| self.builder.material_parts(b.second))
                        .is_some_and(|(m, ..)| anisotropic(&m));
                    framed |= anisotropic(&m) || second || w.normal_map.is_some();
                }
                if framed {
                    // Mitsuba's texture coordinates and tangent frame: the
                    // unit sphere of the object's own frame.
                    if transform.uniform_scale().is_none() {
                        return Err(unsupported(
                            o,
                            " with a texture or tangent frame and a to_world that is not a similarity (uniform scale, no shear)",
                        ));
                    }
                    let to_world = transform.matrix
                        * DAffine3::from_translation(center)
                        * DAffine3::from_scale(DVec3::splat(radius));
                    self.builder
                        .add_quadric(
                            QUADRIC_SPHERE,
                            flip,
                            material,
                            &Transform { matrix: to_world },
                        )
                        .map_err(place)?;
                } else {
                    if flip && emitter.is_some() {
                        return Err(unsupported(o, " with flip_normals and an emitter"));
                    }
                    self.builder
                        .add_sphere(center, radius as f32, material, &transform)
                        .map_err(place)?;
                }
            }
            "sdfgrid" => {
                if emitter.is_some() {
                    // Mitsuba's sdfgrid has no area: seen when hit, never
                    // sampled; refused rather than half supported.
                    return Err(unsupported(o, " with an emitter"));
                }
                let name = props
                    .string("filename")?
                    .ok_or_else(|| fail(&o.at, format!("{} has no filename", o.describe())))?;
                let smooth = match props.string("normals")?.unwrap_or("smooth") {
                    "smooth" => true,
                    "analytic" => false,
                    other => {
                        return Err(fail(
                            &o.at,
                            format!("normals \"{other}\" is not smooth or analytic"),
                        ))
                    }
                };
                let path = self.doc.resolve(name);
                let grid = meshes::read_vol(&path).map_err(|e| {
                    fail(&o.at, format!("{}: {}: {e}", o.describe(), path.display()))
                })?;
                self.builder.sources.push(path.clone());
                self.builder
                    .add_sdf_grid(grid.dims, grid.values, smooth, material, &transform)
                    .map_err(place)?;
            }
            "disk" => {
                self.builder
                    .add_quadric(QUADRIC_DISK, flip, material, &transform)
                    .map_err(place)?;
            }
            "cylinder" => {
                let radius = props.float("radius", 1.0)?;
                let p0 = props.point("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = props.point("p1")?.unwrap_or(DVec3::Z);
                let axis = p1 - p0;
                let length = axis.length();
                if !(length > 0.0 && length.is_finite() && radius > 0.0 && radius.is_finite()) {
                    return Err(fail(
                        &o.at,
                        format!(
                            "{}: p0 and p1 must differ and the radius be positive",
                            o.describe()
                        ),
                    ));
                }
                // Mitsuba's placement: translate(p0) · to_frame(Frame(axis))
                // · scale(r, r, length), the frame's tangents from the
                // axis as its `coordinate_system` makes them.
                let n = axis / length;
                let sign = 1.0f64.copysign(n.z);
                let a = -1.0 / (sign + n.z);
                let b = n.x * n.y * a;
                let s_axis = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
                let t_axis = DVec3::new(b, sign + n.y * n.y * a, -n.y);
                let (s_axis, t_axis) = if mutants::is(Mutant::CylinderFrameSwapped) {
                    (t_axis, s_axis)
                } else {
                    (s_axis, t_axis)
                };
                let frame = DAffine3::from_cols(s_axis * radius, t_axis * radius, n * length, p0);
                let to_world = transform.matrix * frame;
                if emitter.is_some() {
                    // Mitsuba's area and sampling assume a round section:
                    // its sample_position is uniform in (φ, z).
                    let m = to_world.matrix3;
                    let (c0, c1, c2) = (m.x_axis, m.y_axis, m.z_axis);
                    let tol = 1e-4 * c0.length().max(c1.length());
                    let round = (c0.length() - c1.length()).abs() <= tol
                        && c0.dot(c1).abs() <= tol * c1.length()
                        && c0.dot(c2).abs() <= tol * c2.length()
                        && c1.dot(c2).abs() <= tol * c2.length();
                    if !round {
                        return Err(unsupported(
                            o,
                            " with an emitter and a to_world that does not keep its section round (non-uniform scale across its axis, or shear)",
                        ));
                    }
                }
                self.builder
                    .add_quadric(
                        QUADRIC_CYLINDER,
                        flip,
                        material,
                        &Transform { matrix: to_world },
                    )
                    .map_err(place)?;
            }
            "rectangle" | "cube" => {
                let mesh = if o.kind == "rectangle" {
                    rectangle()
                } else {
                    cube()
                };
                let mesh = oriented(&mesh_input(&mesh), flip, &transform);
                self.builder
                    .add_mesh(&mesh, material, &transform)
                    .map_err(place)?;
            }
            "obj" | "ply" | "serialized" => {
                let name = props
                    .string("filename")?
                    .ok_or_else(|| fail(&o.at, format!("{} has no filename", o.describe())))?;
                let path = self.doc.resolve(name);
                let face_normals = props.boolean("face_normals", false)?;
                // None: the plugin's own default (meshes::MeshOptions).
                let flip_tex = if o.props.iter().any(|p| p.name == "flip_tex_coords") {
                    Some(props.boolean("flip_tex_coords", false)?)
                } else {
                    None
                };
                let shape_index = if o.kind == "serialized" {
                    let i = props.integer("shape_index", 0)?;
                    u32::try_from(i).map_err(|_| {
                        fail(&o.at, format!("shape_index {i} is negative or too large"))
                    })?
                } else {
                    0
                };
                let key = (path.clone(), face_normals, flip_tex, shape_index);
                let mesh = match self.meshes.get(&key) {
                    Some(m) => m.clone(),
                    None => {
                        let opts = MeshOptions {
                            face_normals,
                            flip_tex_coords: flip_tex,
                            shape_index,
                        };
                        let read = match o.kind.as_str() {
                            "obj" => meshes::read_obj(&path, &opts),
                            "ply" => meshes::read_ply(&path, &opts),
                            _ => meshes::read_serialized(&path, &opts),
                        };
                        let mesh = Rc::new(read.map_err(|e| {
                            fail(&o.at, format!("{}: {}: {e}", o.describe(), path.display()))
                        })?);
                        self.builder.sources.push(path.clone());
                        self.meshes.insert(key, mesh.clone());
                        mesh
                    }
                };
                if mesh.indices.is_empty() {
                    return Err(fail(
                        &o.at,
                        format!("{}: {} has no triangles", o.describe(), path.display()),
                    ));
                }
                let mut input = mesh_input(&mesh);
                if let Some((name, number)) = &attribute {
                    let Some(a) = mesh.attributes.iter().find(|a| &a.name == name) else {
                        let known: Vec<&str> =
                            mesh.attributes.iter().map(|a| a.name.as_str()).collect();
                        return Err(fail(
                            &o.at,
                            format!(
                                "{}: {} has no attribute \"{name}\" (it has: {})",
                                o.describe(),
                                path.display(),
                                if known.is_empty() {
                                    "none".to_string()
                                } else {
                                    known.join(", ")
                                }
                            ),
                        ));
                    };
                    // Mitsuba's `eval_attribute` reads 1 or 3 channels,
                    // its `eval_attribute_1` 1.
                    if a.channels == 4 || (*number && a.channels != 1) {
                        return Err(fail(
                            &o.at,
                            format!(
                                "{}: mesh attribute \"{name}\" has {} channels, which Mitsuba cannot read {}",
                                o.describe(),
                                a.channels,
                                if *number { "as a number" } else { "as a colour" }
                            ),
                        ));
                    }
                    input = with_attribute(input, a);
                }
                if input.uvs.is_none() && self.reads_uv(material) {
                    input = barycentric_uvs(input);
                }
                let input = oriented(&input, flip, &transform);
                self.builder
                    .add_mesh(&input, material, &transform)
                    .map_err(place)?;
            }
            _ => return Err(unsupported(o, "")),
        }
        props.finish()
    }

    /// Whether material `material` reads its surface's texture
    /// coordinates: under a normal or bump map, or through a texture of
    /// it, its wrappers or its added emission that is an image or a
    /// checkerboard in uv (or a 3-D checker of images).
    fn reads_uv(&self, material: u32) -> bool {
        let Some((m, w, emission)) = self.builder.material_parts(material) else {
            return false;
        };
        let leaf = |t: u32| {
            matches!(
                self.builder.texture(t),
                Some(Texture::Image { .. } | Texture::UvChecker { .. })
            )
        };
        let reads = |t: u32| match self.builder.texture(t) {
            Some(Texture::Checker { even, odd, .. }) => leaf(*even) || leaf(*odd),
            _ => leaf(t),
        };
        let second = w
            .blend
            .and_then(|b| self.builder.material_parts(b.second))
            .map(|(m, ..)| m.texture_ids())
            .unwrap_or_default();
        w.normal_map.is_some()
            || m.texture_ids()
                .into_iter()
                .chain(w.opacity)
                .chain(w.blend.map(|b| b.weight))
                .chain(second)
                .chain(emission)
                .any(reads)
    }

    /// A shape's `to_world` after `outer`.
    fn placement(&self, props: &Props, outer: &Transform) -> Result<Transform, SceneError> {
        match props.transform("to_world")? {
            None => Ok(*outer),
            Some((m, at)) => {
                let affine = affine(&m).ok_or_else(|| {
                    fail(
                        at,
                        "a projective to_world is not an affine placement".into(),
                    )
                })?;
                if affine.matrix3.determinant() == 0.0 {
                    return Err(fail(at, "the to_world is singular".into()));
                }
                Ok(Transform {
                    matrix: outer.matrix * affine,
                })
            }
        }
    }
}

/// An emitter's `sampling_weight` (default 1): finite and above 0.
fn sampling_weight(props: &Props) -> Result<f32, SceneError> {
    let w = props.float("sampling_weight", 1.0)?;
    if !(w.is_finite() && w > 0.0) {
        return Err(fail(
            &props.object.at,
            format!("sampling_weight {w} must be finite and above 0"),
        ));
    }
    Ok(w as f32)
}

/// Whether `r` is a rotation: orthonormal to 1e-6 (far above the f64
/// rounding of a lookat or a rotate, far below any scale one could see)
/// and not a mirror.
fn is_rotation(r: DMat3) -> bool {
    let e = r.transpose() * r - DMat3::IDENTITY;
    e.to_cols_array().iter().all(|x| x.abs() < 1e-6) && r.determinant() > 0.0
}

/// A spot's or projector's place and frame: its `to_world`'s origin and
/// axes, which must be a rotation (Mitsuba's profiles read directions
/// through the inverse of any `to_world`; a scale or shear of one is
/// refused here).
fn light_frame(
    o: &Object,
    transform: Option<(DMat4, &Location)>,
) -> Result<(DVec3, [Vec3; 3]), SceneError> {
    let Some((m, at)) = transform else {
        return Ok((DVec3::ZERO, [Vec3::X, Vec3::Y, Vec3::Z]));
    };
    let r = DMat3::from_mat4(m);
    if !is_rotation(r) {
        return Err(unsupported(
            o,
            &format!(" with a to_world that is not a rotation and a translation (at {at})"),
        ));
    }
    let position = m.transform_point3(DVec3::ZERO);
    Ok((
        position,
        [r.x_axis, r.y_axis, r.z_axis].map(|a| a.as_vec3()),
    ))
}

/// A perspective sensor's vertical field of view, degrees, from its
/// `fov` and `fov_axis` or its `focal_length`.
fn perspective_vfov(o: &Object, props: &Props, aspect: f64) -> Result<f64, SceneError> {
    let fov = match (props.get("fov"), props.get("focal_length")) {
        (Some(_), Some(p)) => return Err(fail(&p.at, "give fov or focal_length, not both".into())),
        (Some(p), None) => match p.value {
            Value::Float(v) => finite(p, v)?,
            Value::Integer(v) => v as f64,
            _ => return Err(props.wrong(p, "a float")),
        },
        (None, focal) => {
            let mm = match focal {
                None => 50.0,
                Some(p) => match &p.value {
                    Value::String(s) => parse_mm(s).ok_or_else(|| {
                        fail(&p.at, format!("focal_length \"{s}\" is not like \"50mm\""))
                    })?,
                    Value::Float(v) => *v,
                    _ => return Err(props.wrong(p, "a length like \"50mm\"")),
                },
            };
            // Mitsuba: the field of view along the 35 mm film's
            // diagonal, fov_axis then taken as the diagonal.
            2.0 * (FILM_DIAGONAL_MM / (2.0 * mm)).atan().to_degrees()
        }
    };
    // A focal length (the default one included) gives the field of
    // view along the film's diagonal, whatever fov_axis says.
    let axis = props.string("fov_axis")?.unwrap_or("x");
    let axis = if fov_given(o) { axis } else { "diagonal" };
    let half = (fov.to_radians() / 2.0).tan();
    let tan_v = match axis {
        "x" => half / aspect,
        "y" => half,
        "diagonal" => half / (aspect * aspect + 1.0).sqrt(),
        "smaller" if aspect >= 1.0 => half,
        "smaller" => half / aspect,
        "larger" if aspect >= 1.0 => half / aspect,
        "larger" => half,
        other => {
            return Err(fail(
                &o.at,
                format!("fov_axis \"{other}\" is not x, y, diagonal, smaller or larger"),
            ))
        }
    };
    let vfov = 2.0 * tan_v.atan().to_degrees();
    if !(vfov > 0.0 && vfov < 180.0) {
        return Err(fail(
            &o.at,
            format!("field of view {fov} is not between 0 and 180 degrees"),
        ));
    }
    Ok(vfov)
}

/// A texture's `to_uv` (linear part A, offset b: Mitsuba's coordinates,
/// v down) as an affine map of twintrace's coordinates (v up), giving
/// Mitsuba's: `A·F(uv) + b` with `F(u, v) = (u, 1 − v)`, as
/// `[t0..t5]` for `(t0·u + t1·v + t2, t3·u + t4·v + t5)`. `None`: no
/// `to_uv`.
fn to_uv(props: &Props) -> Result<Option<[f64; 6]>, SceneError> {
    let Some((m, at)) = props.transform("to_uv")? else {
        return Ok(None);
    };
    if m.z_axis.x != 0.0 || m.z_axis.y != 0.0 {
        return Err(fail(
            at,
            "a to_uv that reads z is not a 2-D transform".into(),
        ));
    }
    let [a0, a1, a2, a3] = [m.x_axis.x, m.y_axis.x, m.x_axis.y, m.y_axis.y];
    let [b0, b1] = [m.w_axis.x, m.w_axis.y];
    Ok(Some([a0, -a1, a1 + b0, a2, -a3, a3 + b1]))
}

fn fov_given(o: &Object) -> bool {
    o.props.iter().any(|p| p.name == "fov")
}

/// `"50mm"` or `"50"`: millimetres.
fn parse_mm(s: &str) -> Option<f64> {
    let t = s.trim();
    let t = t.strip_suffix("mm").unwrap_or(t);
    t.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
}

fn affine(m: &DMat4) -> Option<DAffine3> {
    let row = m.row(3);
    (row == glam::DVec4::new(0.0, 0.0, 0.0, 1.0)).then(|| DAffine3 {
        matrix3: DMat3::from_mat4(*m),
        translation: m.w_axis.truncate(),
    })
}

/// Whether a BSDF reads a texture anywhere.
fn uses_texture(o: &Object) -> bool {
    o.children
        .iter()
        .any(|c| c.object.tag == "texture" || (c.object.tag == "bsdf" && uses_texture(&c.object)))
}

fn film(o: &Object) -> Result<(u32, u32, PixelFilter), SceneError> {
    let props = Props::new(o);
    if o.kind != "hdrfilm" {
        return Err(unsupported(o, ""));
    }
    let w = props.integer("width", 768)?;
    let h = props.integer("height", 576)?;
    let size = |v: i64, name: &str| {
        u32::try_from(v)
            .ok()
            .filter(|v| (1..=crate::scene::MAX_IMAGE_SIDE).contains(v))
            .ok_or_else(|| {
                fail(
                    &o.at,
                    format!(
                        "{name} {v} must be between 1 and {}",
                        crate::scene::MAX_IMAGE_SIDE
                    ),
                )
            })
    };
    let (w, h) = (size(w, "width")?, size(h, "height")?);
    for (name, full) in [
        ("crop_offset_x", 0),
        ("crop_offset_y", 0),
        ("crop_width", w as i64),
        ("crop_height", h as i64),
    ] {
        if props.integer(name, full)? != full {
            return Err(unsupported(o, &format!(" with a crop ({name})")));
        }
    }
    // What is written and how: twintrace writes its own outputs.
    for name in ["pixel_format", "component_format", "file_format"] {
        props.string(name)?;
    }
    for name in ["compensate", "banner", "high_quality_edges"] {
        props.boolean(name, false)?;
    }
    let filter = match props.child("rfilter")? {
        None if mutants::is(Mutant::MitsubaDefaultFilterBox) => PixelFilter::Box,
        // Mitsuba's default.
        None => PixelFilter::Gaussian { stddev: 0.5 },
        Some(f) => {
            let f = &f.object;
            let fp = Props::new(f);
            let filter = match f.kind.as_str() {
                "box" => {
                    // A box of radius 0.5: each sample counts for the
                    // pixel it falls in, as twintrace's film.
                    let r = fp.float("radius", 0.5)?;
                    if r != 0.5 {
                        return Err(unsupported(f, &format!(" with radius {r} (only 0.5)")));
                    }
                    PixelFilter::Box
                }
                "gaussian" => {
                    let stddev = fp.float("stddev", 0.5)?;
                    let filter = PixelFilter::Gaussian {
                        stddev: stddev as f32,
                    };
                    filter.validate().map_err(|e| fail(&f.at, e.to_string()))?;
                    filter
                }
                _ => return Err(unsupported(f, "")),
            };
            fp.finish()?;
            filter
        }
    };
    // Mitsuba samples the image alone unless asked to sample a border
    // around it, which only a filter wider than the pixel reaches.
    if props.boolean("sample_border", false)? && filter != PixelFilter::Box {
        return Err(unsupported(
            o,
            " with sample_border and a filter wider than a pixel",
        ));
    }
    props.finish()?;
    Ok((w, h, filter))
}

fn sampler(o: &Object, settings: &mut RenderSettings) -> Result<(), SceneError> {
    let props = Props::new(o);
    settings.sampler = match o.kind.as_str() {
        "independent" => PathSampler::Independent,
        // Mitsuba's stratified and low-discrepancy samplers: twintrace's
        // own low-discrepancy sequence (Owen-scrambled Sobol'), which
        // renders the same image in expectation.
        "stratified" | "multijitter" | "orthogonal" | "ldsampler" => PathSampler::Sobol,
        _ => return Err(unsupported(o, "")),
    };
    let n = props.integer("sample_count", 4)?;
    settings.spp = u32::try_from(n)
        .ok()
        .filter(|n| (1..=crate::scene::MAX_SPP).contains(n))
        .ok_or_else(|| {
            fail(
                &o.at,
                format!(
                    "sample_count {n} must be between 1 and {}",
                    crate::scene::MAX_SPP
                ),
            )
        })?;
    let seed = props.integer("seed", 0)?;
    settings.seed = seed as u32;
    if o.kind != "independent" {
        props.boolean("jitter", true)?;
        props.integer("strength", 2)?;
    }
    props.finish()
}

/// Mitsuba's `rectangle`: the square [−1, 1]² in the plane z = 0, facing
/// +z, texture coordinates (u, v) = ((x + 1)/2, (y + 1)/2) in Mitsuba's
/// convention (here v up: twintrace's v = 1 − Mitsuba's).
fn rectangle() -> Mesh {
    let p = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    Mesh {
        positions: p.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect(),
        normals: Some(vec![Vec3::Z; 4]),
        uvs: Some(
            p.iter()
                .map(|&(x, y)| Vec2::new((x + 1.0) / 2.0, (y + 1.0) / 2.0))
                .collect(),
        ),
        indices: vec![0, 1, 2, 0, 2, 3],
        attributes: Vec::new(),
    }
}

/// Mitsuba's `cube`: [−1, 1]³, each face its own four vertices with the
/// face's normal, laid out as Mitsuba 3.9.1 lays them (read from its
/// `vertex_positions`, `vertex_texcoords` and `faces`): face by face
/// −y, +y, +x, +z, −x, −z, corners `n ∓ e1 ∓ e2` in the order (−,−),
/// (+,−), (+,+), (−,+) with texture coordinates (0, 1), (1, 1), (1, 0),
/// (0, 0), triangles (0, 1, 2) and (3, 0, 2).
fn cube() -> Mesh {
    let mut mesh = Mesh::default();
    // (normal, e1, e2): e1 × e2 = normal, so each face winds
    // counter-clockwise seen from outside.
    let faces = [
        (Vec3::NEG_Y, Vec3::Z, Vec3::NEG_X),
        (Vec3::Y, Vec3::NEG_X, Vec3::Z),
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::Z, Vec3::Y, Vec3::NEG_X),
        (Vec3::NEG_X, Vec3::Y, Vec3::NEG_Z),
        (Vec3::NEG_Z, Vec3::NEG_Y, Vec3::NEG_X),
    ];
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for (n, e1, e2) in faces {
        let base = mesh.positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            mesh.positions.push(n + a * e1 + b * e2);
            normals.push(n);
            uvs.push(Vec2::new((a + 1.0) / 2.0, (1.0 - b) / 2.0));
        }
        mesh.indices
            .extend([base, base + 1, base + 2, base + 3, base, base + 2]);
    }
    mesh.normals = Some(normals);
    mesh.uvs = Some(uvs);
    mesh
}

/// A mesh as the builder takes it: texture coordinates turned to v up.
fn mesh_input(mesh: &Mesh) -> MeshInput {
    MeshInput {
        positions: mesh.positions.clone(),
        normals: mesh.normals.clone(),
        uvs: mesh
            .uvs
            .as_ref()
            .map(|uvs| uvs.iter().map(|uv| Vec2::new(uv.x, 1.0 - uv.y)).collect()),
        indices: mesh.indices.clone(),
        ..MeshInput::default()
    }
}

/// `mesh` with attribute `a` as its vertex colours (what a
/// `mesh_attribute` texture reads): a vertex attribute's value a vertex,
/// a face attribute's on the three corners of its triangle, each
/// triangle then given vertices of its own. One channel is grey (the
/// reader refuses four, as Mitsuba's `eval_attribute` does).
fn with_attribute(mesh: MeshInput, a: &meshes::Attribute) -> MeshInput {
    let colour = |k: usize| {
        let v = &a.values[k * a.channels..(k + 1) * a.channels];
        match v {
            [g] => glam::Vec4::new(*g, *g, *g, 1.0),
            [r, g, b, ..] => glam::Vec4::new(*r, *g, *b, 1.0),
            _ => glam::Vec4::ONE,
        }
    };
    let count = a.values.len() / a.channels.max(1);
    if !a.per_face() || mutants::is(Mutant::MitsubaFaceAttributeByVertex) {
        let colors = (0..mesh.positions.len())
            .map(|k| {
                if k < count {
                    colour(k)
                } else {
                    glam::Vec4::ONE
                }
            })
            .collect();
        return MeshInput {
            colors: Some(colors),
            ..mesh
        };
    }
    let corners = &mesh.indices;
    MeshInput {
        positions: corners
            .iter()
            .map(|&i| mesh.positions[i as usize])
            .collect(),
        normals: pick(&mesh.normals, corners),
        uvs: pick(&mesh.uvs, corners),
        colors: Some((0..corners.len()).map(|c| colour(c / 3)).collect()),
        indices: (0..corners.len() as u32).collect(),
        ..MeshInput::default()
    }
}

/// A `normalmap`'s or `bumpmap`'s switches at Mitsuba 3.9.1's defaults,
/// the only behaviour twintrace has (others refused).
fn map_defaults(props: &Props) -> Result<(), SceneError> {
    for name in ["flip_invalid_normals", "use_shadowing_function"] {
        if !props.boolean(name, true)? {
            return Err(unsupported(props.object, &format!(" with {name} false")));
        }
    }
    Ok(())
}

/// `mesh` (without texture coordinates) given Mitsuba's: a triangle's
/// point at barycentrics (b1, b2) is at uv (b1, b2), which twintrace
/// reads v up as (b1, 1 − b2). Each triangle's corners get vertices of
/// their own at (0, 1), (1, 1) and (0, 0), keeping their positions and
/// normals, so that a texture, a bump map or a tangent reads the surface
/// where Mitsuba's does (also after `flip_normals` rewinds the triangle,
/// as Mitsuba's does not).
fn barycentric_uvs(mesh: MeshInput) -> MeshInput {
    let corners = &mesh.indices;
    let at = [
        Vec2::new(0.0, 1.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 0.0),
    ];
    MeshInput {
        positions: corners
            .iter()
            .map(|&i| mesh.positions[i as usize])
            .collect(),
        normals: pick(&mesh.normals, corners),
        uvs: Some((0..corners.len()).map(|c| at[c % 3]).collect()),
        colors: pick(&mesh.colors, corners),
        tangents: pick(&mesh.tangents, corners),
        uvs1: pick(&mesh.uvs1, corners),
        indices: (0..corners.len() as u32).collect(),
    }
}

/// A vertex attribute (where the mesh has it) read at each of `corners`.
fn pick<T: Copy>(v: &Option<Vec<T>>, corners: &[u32]) -> Option<Vec<T>> {
    v.as_ref()
        .map(|v| corners.iter().map(|&i| v[i as usize]).collect())
}

/// `flip_normals`: the triangles wound the other way and the normals
/// reversed, so the surface faces the other side.
/// `mesh` as Mitsuba orients it: `flip_normals` negates its normals and
/// turns its faces; and a mesh with vertex normals placed by a mirroring
/// `transform` has its faces turned. Mitsuba keeps a mirrored mesh's face
/// normal the edges' cross product (now opposite the normals the inverse
/// transpose carries) and shades by the vertex normals, while twintrace
/// puts the shading normal on the face normal's side: turning the faces
/// keeps the two on one side, so the shading is Mitsuba's (and a
/// `rectangle`'s face normal is Mitsuba's `L⁻ᵀ ẑ`).
fn oriented(mesh: &MeshInput, flip: bool, transform: &Transform) -> MeshInput {
    let turn = flip != (transform.mirrors() && mesh.normals.is_some());
    let mut m = mesh.clone();
    if turn {
        for t in m.indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
    }
    if flip {
        if let Some(n) = &mut m.normals {
            n.iter_mut().for_each(|n| *n = -*n);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use std::path::Path;

    fn scene(body: &str) -> Result<Scene, SceneError> {
        let text = format!(r#"<scene version="3.0.0">{body}</scene>"#);
        let doc = crate::loader::mitsuba::xml::parse_text(&text, Path::new("s.xml"), &[])
            .map_err(|e| fail(&e.at, e.message))?;
        build(&doc)
    }

    const FILM: &str = r#"<film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/><rfilter type="box"/></film>"#;

    /// A scene of one PLY shape (`ply`'s text, written beside the scene as
    /// m.ply) whose bsdf is `bsdf`.
    fn ply_scene(ply: &str, bsdf: &str) -> Result<Scene, SceneError> {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.ply"), ply).unwrap();
        let text = format!(
            r#"<scene version="3.0.0"><sensor type="perspective">{FILM}</sensor><shape type="ply"><string name="filename" value="m.ply"/>{bsdf}</shape></scene>"#
        );
        let path = dir.path().join("s.xml");
        let doc = crate::loader::mitsuba::xml::parse_text(&text, &path, &[])
            .map_err(|e| fail(&e.at, e.message))?;
        build(&doc)
    }

    /// [`ply_scene`] whose diffuse reflectance is the mesh attribute `name`.
    fn attribute_scene(ply: &str, name: &str) -> Result<Scene, SceneError> {
        ply_scene(
            ply,
            &format!(
                r#"<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="{name}"/><float name="scale" value="0.5"/></texture></bsdf>"#
            ),
        )
    }

    #[test]
    fn anisotropic_roughness_normal_maps_and_tabulated_metals_are_read() {
        let s = scene(&format!(
            r#"<sensor type="perspective">{FILM}</sensor><shape type="rectangle"><bsdf type="twosided"><bsdf type="normalmap">
            <texture name="normalmap" type="rawconstant"><vector name="value" value="0.6, 0.5, 0.9"/></texture>
            <bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha_u" value="0.3"/><float name="alpha_v" value="0.05"/></bsdf>
            </bsdf></bsdf></shape>"#
        ))
        .unwrap();
        let Material::RoughConductor {
            alpha,
            alpha_v,
            eta,
            k,
            ..
        } = s.materials()[0]
        else {
            panic!("{:?}", s.materials())
        };
        let value = |t: u32| s.textures()[t as usize];
        assert_eq!(value(alpha), Texture::Constant(Vec3::splat(0.3)));
        assert_eq!(
            alpha_v.map(value),
            Some(Texture::Constant(Vec3::splat(0.05)))
        );
        let (_, au_eta, au_k) = NAMED_CONDUCTORS.iter().find(|(n, ..)| *n == "Au").unwrap();
        assert_eq!(
            (eta, k),
            (Vec3::from_array(*au_eta), Vec3::from_array(*au_k))
        );
        let w = s.wrappers(0);
        assert!(!w.one_sided && w.normal_map_mirrored, "{w:?}");
        // The rawconstant as written: data, no colour conversion.
        assert_eq!(
            w.normal_map.map(value),
            Some(Texture::Constant(Vec3::new(0.6, 0.5, 0.9)))
        );
        // Isotropic where the two are the same; normalmap alone is one-sided
        // and read in the shape's frame.
        let s = scene(&format!(
            r#"<sensor type="perspective">{FILM}</sensor><shape type="rectangle"><bsdf type="normalmap">
            <rgb name="normalmap" value="0.5, 0.5, 1"/>
            <bsdf type="roughconductor"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/></bsdf></bsdf></shape>"#
        ))
        .unwrap();
        assert!(matches!(
            s.materials()[0],
            Material::RoughConductor { alpha_v: None, .. }
        ));
        let w = s.wrappers(0);
        assert!(w.one_sided && !w.normal_map_mirrored && w.normal_map.is_some());
    }

    #[test]
    fn shapes_twintrace_cannot_take_as_mitsuba_does_are_refused_by_name() {
        let vol = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../fixtures/mitsuba_shapes/blob.vol"
        );
        for (shape, says) in [
            (
                format!(
                    r#"<shape type="sdfgrid"><string name="filename" value="{vol}"/><emitter type="area"/></shape>"#
                ),
                "shape \"sdfgrid\" is not supported with an emitter",
            ),
            (
                format!(
                    r#"<shape type="sdfgrid"><string name="filename" value="{vol}"/><string name="normals" value="flat"/></shape>"#
                ),
                "normals \"flat\" is not smooth or analytic",
            ),
            (
                r#"<shape type="sdfgrid"><string name="filename" value="/nonexistent/g.vol"/></shape>"#.into(),
                "cannot read the file",
            ),
            (
                r#"<shape type="cylinder"><emitter type="area"/><transform name="to_world"><scale x="2" y="1" z="1"/></transform></shape>"#.into(),
                "does not keep its section round",
            ),
            (
                r#"<shape type="cylinder"><point name="p0" x="1" y="1" z="1"/><point name="p1" x="1" y="1" z="1"/></shape>"#.into(),
                "p0 and p1 must differ",
            ),
            (
                r#"<shape type="disk"><transform name="to_world"><scale x="0" y="1" z="1"/></transform></shape>"#.into(),
                "singular",
            ),
        ] {
            let err = scene(&format!(r#"<sensor type="perspective">{FILM}</sensor>{shape}"#))
                .unwrap_err()
                .to_string();
            assert!(err.contains(says), "{shape}: {err}");
            assert!(!err.contains('\n'), "{err}");
        }
    }

    #[test]
    fn what_the_frame_does_not_support_is_refused_by_name() {
        for (body, says) in [
            (
                r#"<bsdf type="roughplastic"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.1"/></bsdf>"#,
                "roughplastic\" is not supported with alpha_u other than alpha_v",
            ),
            (
                r#"<bsdf type="normalmap"><rgb name="normalmap" value="0.5, 0.5, 1"/><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>"#,
                "mask\" is not supported inside a normalmap",
            ),
            (
                r#"<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>"#,
                "has no \"normalmap\" texture",
            ),
            (
                r#"<bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf>"#,
                "\"Unobtainium\" is not one of Mitsuba's tabulated conductors (none, a-C, Ag, Al",
            ),
            (
                r#"<bsdf type="twosided"><bsdf type="normalmap"><rgb name="normalmap" value="0.5, 0.5, 1"/><bsdf type="dielectric"/></bsdf></bsdf>"#,
                "inside twosided around a model that takes both sides itself",
            ),
            (
                // Mitsuba's textured sphere is a quadric of its own frame,
                // which a shear would turn into an ellipsoid.
                r#"<bsdf type="roughconductor"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.1"/></bsdf><transform name="to_world"><scale x="2" y="1" z="1"/></transform>"#,
                "sphere\" is not supported with a texture or tangent frame and a to_world that is not a similarity",
            ),
        ] {
            let err = scene(&format!(
                r#"<sensor type="perspective">{FILM}</sensor><shape type="sphere">{body}</shape>"#
            ))
            .unwrap_err()
            .to_string();
            assert!(err.contains(says), "{body}: {err}");
        }
    }

    /// [`ply_scene`] of [`ATTRIBUTE_PLY`] (no texture coordinates) whose
    /// bsdf is `bsdf`, `HEIGHT` in it the path of fixtures/mitsuba/bumps'
    /// height image.
    fn bump_scene(bsdf: &str) -> Result<Scene, SceneError> {
        let height = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/mitsuba/bumps/textures/height.png");
        ply_scene(
            ATTRIBUTE_PLY,
            &bsdf.replace("HEIGHT", &height.to_string_lossy()),
        )
    }

    #[test]
    fn bump_maps_are_read_with_their_scale_and_uvless_meshes_get_mitsubas_barycentrics() {
        let s = bump_scene(
            r#"<bsdf type="twosided"><bsdf type="bumpmap"><float name="scale" value="0.25"/>
            <texture name="h" type="bitmap"><boolean name="raw" value="true"/><string name="filename" value="HEIGHT"/></texture>
            <bsdf type="diffuse"/></bsdf></bsdf>"#,
        )
        .unwrap();
        let w = s.wrappers(0);
        assert!(w.bump_map && w.normal_map_mirrored && !w.one_sided, "{w:?}");
        let Some(Texture::Image { factor, .. }) = w.normal_map.map(|t| s.textures()[t as usize])
        else {
            panic!("{w:?}: {:?}", s.textures())
        };
        assert_eq!(factor, Vec3::splat(0.25));
        // The PLY has no texture coordinates: each triangle's corners get
        // vertices of their own at Mitsuba's barycentric (b1, b2), v up.
        let m = s.mesh();
        assert_eq!((s.triangles().len(), m.positions.len()), (2, 6));
        let at = [
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 0.0),
        ];
        assert_eq!(m.uvs, [at, at].concat());
        // A material that reads no coordinates leaves the mesh shared.
        let s = bump_scene(r#"<bsdf type="diffuse"/>"#).unwrap();
        assert_eq!(s.mesh().positions.len(), 4);
        // One-sided without twosided; the default scale 1.
        let s = bump_scene(
            r#"<bsdf type="bumpmap"><texture name="h" type="bitmap"><string name="filename" value="HEIGHT"/></texture><bsdf type="roughconductor"/></bsdf>"#,
        )
        .unwrap();
        let w = s.wrappers(0);
        assert!(w.bump_map && w.one_sided && !w.normal_map_mirrored, "{w:?}");
        assert!(matches!(
            w.normal_map.map(|t| s.textures()[t as usize]),
            Some(Texture::Image { factor, .. }) if factor == Vec3::ONE
        ));
        for (bsdf, says) in [
            (
                r#"<bsdf type="bumpmap"><float name="scale" value="-1"/><texture name="h" type="bitmap"><string name="filename" value="HEIGHT"/></texture><bsdf type="diffuse"/></bsdf>"#,
                "is not supported with a negative scale",
            ),
            (
                r#"<bsdf type="bumpmap"><texture name="h" type="checkerboard"/><bsdf type="diffuse"/></bsdf>"#,
                "checkerboard\" is not supported as a bumpmap's height",
            ),
            (
                r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#,
                "has 0 textures (it takes one: the height)",
            ),
            (
                r#"<bsdf type="bumpmap"><texture name="h" type="bitmap"><string name="filename" value="HEIGHT"/></texture><bsdf type="normalmap"><rgb name="normalmap" value="0.5, 0.5, 1"/><bsdf type="diffuse"/></bsdf></bsdf>"#,
                "normalmap\" is not supported inside a bumpmap",
            ),
            (
                r#"<bsdf type="bumpmap"><boolean name="use_shadowing_function" value="false"/><texture name="h" type="bitmap"><string name="filename" value="HEIGHT"/></texture><bsdf type="diffuse"/></bsdf>"#,
                "with use_shadowing_function false",
            ),
        ] {
            let err = bump_scene(bsdf).unwrap_err().to_string();
            assert!(err.contains(says), "{bsdf}: {err}");
        }
    }

    /// A square of two triangles (one PLY quad, fanned) with a vertex
    /// colour (`r g b`) and a face attribute (`w_0`).
    const ATTRIBUTE_PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float r\nproperty float g\nproperty float b\nelement face 1\nproperty list uchar int vertex_indices\nproperty float w_0\nend_header\n0 0 0 1 0 0\n1 0 0 0 1 0\n1 1 0 0 0 1\n0 1 0 1 1 1\n4 0 1 2 3 0.25\n";

    #[test]
    fn mesh_attributes_become_the_meshs_vertex_colours() {
        use crate::texture::Texture;
        let s = attribute_scene(ATTRIBUTE_PLY, "vertex_color").unwrap();
        let colours: Vec<Vec3> = s.mesh().colors.iter().map(|c| c.truncate()).collect();
        assert_eq!(colours, [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE]);
        assert!(s.textures().contains(&Texture::VertexColor {
            factor: Vec3::splat(0.5)
        }));
        // A face attribute: each triangle's corners of their own, the
        // polygon's value on both triangles of its fan.
        let s = attribute_scene(ATTRIBUTE_PLY, "face_w").unwrap();
        assert_eq!(s.triangles().len(), 2);
        assert_eq!(s.mesh().positions.len(), 6);
        assert!(s
            .mesh()
            .colors
            .iter()
            .all(|c| *c == glam::Vec4::new(0.25, 0.25, 0.25, 1.0)));
    }

    #[test]
    fn a_blendbsdf_is_its_first_bsdf_with_the_second_as_a_material_of_its_own() {
        use crate::texture::Texture;
        let shape = |bsdf: &str| {
            scene(&format!(
                r#"<sensor type="perspective">{FILM}</sensor><shape type="rectangle">{bsdf}</shape>"#
            ))
        };
        let s = shape(
            r#"<bsdf type="blendbsdf"><float name="weight" value="0.25"/><bsdf type="diffuse"/><bsdf type="twosided"><bsdf type="conductor"/></bsdf></bsdf>"#,
        )
        .unwrap();
        let m = s.triangles()[0].material;
        let w = s.wrappers(m);
        let b = w.blend.unwrap();
        assert!(w.one_sided, "Mitsuba's diffuse is one-sided");
        assert!(matches!(
            s.materials()[m as usize],
            Material::Lambertian { .. }
        ));
        assert!(matches!(
            s.materials()[b.second as usize],
            Material::Conductor { .. }
        ));
        assert!(!s.wrappers(b.second).one_sided, "inside twosided");
        assert_eq!(
            s.textures()[b.weight as usize],
            Texture::Constant(Vec3::splat(0.25))
        );
        // Inside twosided, both take both sides; a mask and a normal map
        // go around it.
        let s = shape(
            r#"<bsdf type="mask"><bsdf type="twosided"><bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="plastic"/></bsdf></bsdf></bsdf>"#,
        )
        .unwrap();
        let w = s.wrappers(s.triangles()[0].material);
        assert!(w.opacity.is_some() && !w.one_sided);
        assert!(!s.wrappers(w.blend.unwrap().second).one_sided);
        let s = shape(
            r#"<bsdf type="twosided"><bsdf type="normalmap"><rgb name="normalmap" value="0.5, 0.5, 1"/><bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="plastic"/></bsdf></bsdf></bsdf>"#,
        )
        .unwrap();
        let w = s.wrappers(s.triangles()[0].material);
        assert!(w.normal_map.is_some() && !w.one_sided);
        assert!(!s.wrappers(w.blend.unwrap().second).one_sided);
        for (bsdf, says) in [
            (
                r#"<bsdf type="blendbsdf"><bsdf type="diffuse"/></bsdf>"#,
                "other than two nested bsdfs",
            ),
            (
                r#"<bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>"#,
                "inside a blendbsdf",
            ),
            (
                r#"<bsdf type="blendbsdf"><bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf><bsdf type="diffuse"/></bsdf>"#,
                "inside a blendbsdf",
            ),
            (
                r#"<bsdf type="blendbsdf"><texture type="checkerboard" name="weight"><rgb name="color0" value="0.2, 0.5, 0.8"/></texture><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
                "checkerboard of colours",
            ),
        ] {
            let err = shape(bsdf).unwrap_err().to_string();
            assert!(err.contains(says), "{bsdf}: {err}");
        }
    }

    #[test]
    fn a_principledthin_is_the_thin_principled_sheet() {
        let shape = |bsdf: &str| {
            scene(&format!(
                r#"<sensor type="perspective">{FILM}</sensor><shape type="rectangle">{bsdf}</shape>"#
            ))
        };
        let s = shape(
            r#"<bsdf type="principledthin"><float name="diff_trans" value="1.2"/><float name="spec_trans" value="0"/><float name="eta" value="1.33"/></bsdf>"#,
        )
        .unwrap();
        let m = s.triangles()[0].material as usize;
        let Material::Principled {
            lobes, eta, thin, ..
        } = s.materials()[m]
        else {
            panic!("{:?}", s.materials()[m]);
        };
        assert!(thin && eta == 1.33);
        assert!(lobes.diff_trans.is_some(), "given");
        assert!(lobes.spec_trans.is_none(), "the number 0: off");
        assert!(!s.wrappers(m as u32).one_sided, "the same from both sides");
        for (bsdf, says) in [
            (
                r#"<bsdf type="principledthin"><float name="metallic" value="0.5"/></bsdf>"#,
                "metallic",
            ),
            (
                r#"<bsdf type="principledthin"><texture type="checkerboard" name="eta"/></bsdf>"#,
                "textured \"eta\"",
            ),
            (
                r#"<bsdf type="principledthin"><float name="diffuse_transmittance_sampling_rate" value="2"/></bsdf>"#,
                "diffuse_transmittance_sampling_rate other than 1",
            ),
        ] {
            let err = shape(bsdf).unwrap_err().to_string();
            assert!(err.contains(says), "{bsdf}: {err}");
        }
    }

    #[test]
    fn a_mask_reads_an_rgb_opacity_as_its_mean_as_mitsubas_eval_1() {
        use crate::texture::Texture;
        // Mitsuba 3.9.1: `srgb` [0.2, 0.5, 0.8].eval_1 = 0.5.
        let s = scene(&format!(
            r#"<sensor type="perspective">{FILM}</sensor><shape type="sphere"><bsdf type="mask"><rgb name="opacity" value="0.2, 0.5, 0.8"/><bsdf type="diffuse"/></bsdf></shape>"#
        ))
        .unwrap();
        let m = s.spheres()[0].material;
        let t = s.wrappers(m).opacity.unwrap();
        let Texture::Constant(c) = s.textures()[t as usize] else {
            panic!("{:?}", s.textures()[t as usize]);
        };
        assert!((c - Vec3::splat(0.5)).abs().max_element() < 1e-7, "{c}");
        let e = scene(&format!(
            r#"<sensor type="perspective">{FILM}</sensor><shape type="rectangle"><bsdf type="mask"><texture type="checkerboard" name="opacity"><rgb name="color0" value="0.2, 0.5, 0.8"/></texture><bsdf type="diffuse"/></bsdf></shape>"#
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("checkerboard of colours"), "{e}");
    }

    #[test]
    fn mesh_attributes_of_channels_mitsuba_cannot_read_are_refused() {
        // Four channels (r g b a), and three read as a number (a mask's
        // opacity).
        let rgba = ATTRIBUTE_PLY
            .replace("property float b\n", "property float b\nproperty float a\n")
            .replace("0 0 0 1 0 0\n", "0 0 0 1 0 0 1\n")
            .replace("1 0 0 0 1 0\n", "1 0 0 0 1 0 1\n")
            .replace("1 1 0 0 0 1\n", "1 1 0 0 0 1 1\n")
            .replace("0 1 0 1 1 1\n", "0 1 0 1 1 1 1\n");
        let e = attribute_scene(&rgba, "vertex_color")
            .unwrap_err()
            .to_string();
        assert!(e.contains("has 4 channels"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.ply"), ATTRIBUTE_PLY).unwrap();
        let text = format!(
            r#"<scene version="3.0.0"><sensor type="perspective">{FILM}</sensor><shape type="ply"><string name="filename" value="m.ply"/>
            <bsdf type="mask"><texture type="mesh_attribute" name="opacity"><string name="name" value="vertex_color"/></texture><bsdf type="diffuse"/></bsdf></shape></scene>"#
        );
        let doc =
            crate::loader::mitsuba::xml::parse_text(&text, &dir.path().join("s.xml"), &[]).unwrap();
        let e = build(&doc).unwrap_err().to_string();
        assert!(
            e.contains("has 3 channels") && e.contains("as a number"),
            "{e}"
        );
        // One channel as a number: read.
        let text = text.replace("vertex_color", "face_w");
        let doc =
            crate::loader::mitsuba::xml::parse_text(&text, &dir.path().join("s.xml"), &[]).unwrap();
        build(&doc).unwrap();
    }

    #[test]
    fn a_mesh_attribute_the_shape_lacks_or_cannot_have_is_named() {
        let e = attribute_scene(ATTRIBUTE_PLY, "vertex_weight")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no attribute \"vertex_weight\"") && e.contains("vertex_color, face_w"),
            "{e}"
        );
        let e = attribute_scene(ATTRIBUTE_PLY, "colour")
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not start with vertex_ or face_"), "{e}");
        let e = scene(
            r#"<shape type="sphere"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture></bsdf></shape>"#,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("needs a mesh"), "{e}");
    }
    const SPHERE: &str = r#"<shape type="sphere"/>"#;

    #[test]
    fn the_cube_is_laid_out_as_mitsubas() {
        // Mitsuba 3.9.1's `cube` (`mi.traverse(mi.load_dict({'type':
        // 'cube'}))`): the first face's corners and texture coordinates,
        // the last face's first corner, its triangles.
        let c = cube();
        assert_eq!(
            &c.positions[..4],
            &[
                Vec3::new(1.0, -1.0, -1.0),
                Vec3::new(1.0, -1.0, 1.0),
                Vec3::new(-1.0, -1.0, 1.0),
                Vec3::new(-1.0, -1.0, -1.0)
            ]
        );
        assert_eq!(
            &c.uvs.as_ref().unwrap()[..4],
            &[
                Vec2::new(0.0, 1.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 0.0)
            ]
        );
        assert_eq!(c.positions[20], Vec3::new(1.0, 1.0, -1.0));
        assert_eq!(&c.indices[..6], &[0, 1, 2, 3, 0, 2]);
        assert_eq!(&c.indices[30..], &[20, 21, 22, 23, 20, 22]);
        // Every face winds counter-clockwise seen from outside.
        for t in c.indices.chunks(3) {
            let [a, b, d] = [0, 1, 2].map(|k| c.positions[t[k] as usize]);
            let n = c.normals.as_ref().unwrap()[t[0] as usize];
            assert!((b - a).cross(d - a).dot(n) > 0.0, "{t:?}");
        }
    }

    #[test]
    fn an_orthographic_sensor_has_mitsubas_window_at_its_near_clip_distance() {
        let s = scene(&format!(
            r#"<sensor type="orthographic"><float name="near_clip" value="0.5"/>
            <transform name="to_world"><scale x="3" y="3"/><lookat origin="0, 0, -4" target="0, 0, 0" up="0, 1, 0"/></transform>{FILM}</sensor>{SPHERE}"#
        ))
        .unwrap();
        let c = s.camera_settings();
        // 2 wide and 2 / aspect tall in the sensor's space, scaled by 3.
        assert_eq!(c.projection, Projection::Orthographic { height: 3.0 });
        // Mitsuba's +x is the image's left: the top-left corner's ray
        // starts at +x.
        let cam = Camera::new(&s.render_camera_settings(), 2.0);
        let r = cam.generate_ray(Vec2::ZERO, Vec2::ZERO);
        let world = r.origin + (c.look_from - s.render_camera_settings().look_from);
        assert!(
            (world - Vec3::new(3.0, 1.5, -3.5)).length() < 1e-5,
            "{world}"
        );
        assert_eq!(r.direction, Vec3::Z);
        // A stretched window is refused.
        let e = scene(&format!(
            r#"<sensor type="orthographic"><transform name="to_world"><scale x="3" y="2"/></transform>{FILM}</sensor>{SPHERE}"#
        ))
        .unwrap_err();
        assert!(e.to_string().contains("stretches"), "{e}");
        // So is a perspective sensor's.
        let e = scene(&format!(
            r#"<sensor type="perspective"><transform name="to_world"><scale x="1" y="2"/></transform>{FILM}</sensor>{SPHERE}"#
        ))
        .unwrap_err();
        assert!(e.to_string().contains("stretches"), "{e}");
    }

    #[test]
    fn a_checkerboard_reads_mitsubas_coordinates() {
        let s = scene(&format!(
            r#"<sensor type="perspective">{FILM}</sensor>
            <shape type="rectangle"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
            <rgb name="color0" value="1, 0, 0"/>
            <transform name="to_uv"><scale x="2" y="3"/><translate x="0.25"/></transform></texture></bsdf></shape>"#
        ))
        .unwrap();
        let t = s.textures();
        let Some(&Texture::UvChecker { sampler, even, odd }) = t.last() else {
            panic!("{t:?}")
        };
        assert_eq!(t[even as usize], Texture::Constant(Vec3::X));
        // Mitsuba's default color1.
        assert_eq!(t[odd as usize], Texture::Constant(Vec3::splat(0.2)));
        // Mitsuba's (u, v_m) = (u, 1 − v): at twintrace's (0.1, 0.9) it
        // reads (2·0.1 + 0.25, 3·0.1) = (0.45, 0.3).
        let at = sampler.transformed_uv(Vec2::new(0.1, 0.9));
        assert!((at - Vec2::new(0.45, 0.3)).length() < 1e-6, "{at}");
    }
}
