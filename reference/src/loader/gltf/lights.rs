//! `KHR_lights_punctual`: the document's lights, their units and bounds,
//! placed by their nodes.

use super::bounds;
use super::document::GltfFile;
use super::extensions::LIGHTS;
use crate::error::SceneError;
use crate::scene::{LightInput, SceneBuilder};
use glam::{DAffine3, DVec3, Vec3};

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

/// A `KHR_lights_punctual` light as the document defines it, in the
/// light's own frame (at the origin, pointing down −Z).
#[derive(Clone, Debug)]
pub(super) struct GltfLight {
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
    pub(super) fn placed(&self, world: &DAffine3) -> LightInput {
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
    pub(super) fn rename(&self, e: SceneError, node: usize) -> SceneError {
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
pub(super) fn read_lights(
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
