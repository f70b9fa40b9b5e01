//! What the glTF 2.0 specification and the extensions the importer reads
//! allow of a document's values: the range of every number a material, a
//! light or a camera gives (each check cites its bound), the accessor
//! types of the vertex attributes, and the names errors give a document's
//! elements. A message here is `field value problem`, the field spelled as
//! the file spells it (`pbrMetallicRoughness.roughnessFactor`,
//! `extensions.KHR_materials_volume.attenuationDistance`); the caller puts
//! the file and the element (`named`) in front.
//!
//! JSON cannot hold NaN or an infinity, and serde_json refuses a number
//! beyond f64's range; but the `gltf` crate reads its numbers as f32, so a
//! number above f32's largest (about 3.4e38) reads as an infinity. Such a
//! number is refused like any other out of range, with one exception:
//! `attenuationDistance`, whose default is an infinite distance.

use super::uv_transform::{uv_matrix, UvTransform};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Semantic;

/// How errors and warnings name an element of one of the document's
/// arrays: its path (`materials[2]`), after its name where it has one
/// (`material "Brass", materials[2]`; escaped, so that it stays one line).
pub(super) fn named(what: &str, path: &str, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("{what} {name:?}, {path}"),
        None => path.to_string(),
    }
}

/// A number as messages show it: as JSON would write it, in exponent
/// form where it is very small or very large (`1e-38`, not 38 zeros).
pub(super) fn show(x: f32) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e16).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Numbers as messages show them: `[0, 3e38]`.
pub(super) fn show_all(xs: &[f32]) -> String {
    let shown: Vec<String> = xs.iter().map(|&x| show(x)).collect();
    format!("[{}]", shown.join(", "))
}

/// A range the specification gives a number.
#[derive(Clone, Copy, Debug)]
pub(super) enum Range {
    /// [0, 1].
    Unit,
    /// ≥ 0.
    NonNegative,
    /// > 0.
    Positive,
    /// Any (finite) number.
    Any,
}

/// `x`, read as `field`, in `range` and finite.
pub(super) fn number(field: &str, x: f32, range: Range) -> Result<(), String> {
    if !x.is_finite() {
        return Err(format!(
            "{field} is beyond the range of a 32-bit float (it reads as {x})"
        ));
    }
    let problem = match range {
        Range::Unit if !(0.0..=1.0).contains(&x) => "is outside [0, 1]",
        Range::NonNegative if x < 0.0 => "is negative (the minimum is 0)",
        Range::Positive if x <= 0.0 => "must be above 0",
        _ => return Ok(()),
    };
    Err(format!("{field} {} {problem}", show(x)))
}

/// Each of `xs`, read as `field[i]`, in `range` and finite.
fn numbers(field: &str, xs: &[f32], range: Range) -> Result<(), String> {
    for (i, &x) in xs.iter().enumerate() {
        number(&format!("{field}[{i}]"), x, range)?;
    }
    Ok(())
}

/// The material's numbers that the `gltf` crate reads as typed values
/// (`KHR_materials_clearcoat`, which it does not type, is checked where
/// the importer reads it, and the textures' `KHR_texture_transform`s by
/// [`transform`] where their textures are added). The bounds are those of
/// the glTF 2.0 schema (material.schema.json,
/// material.pbrMetallicRoughness.schema.json,
/// material.normalTextureInfo.schema.json,
/// material.occlusionTextureInfo.schema.json) and of each extension's
/// schema.
pub(super) fn material(m: &gltf::Material) -> Result<(), String> {
    let pbr = m.pbr_metallic_roughness();
    // Each component in [0, 1].
    numbers(
        "pbrMetallicRoughness.baseColorFactor",
        &pbr.base_color_factor(),
        Range::Unit,
    )?;
    // Both in [0, 1].
    number(
        "pbrMetallicRoughness.metallicFactor",
        pbr.metallic_factor(),
        Range::Unit,
    )?;
    number(
        "pbrMetallicRoughness.roughnessFactor",
        pbr.roughness_factor(),
        Range::Unit,
    )?;
    // Each component in [0, 1].
    numbers("emissiveFactor", &m.emissive_factor(), Range::Unit)?;
    // Minimum 0 (no maximum); read only by MASK, checked in every mode.
    if let Some(cutoff) = m.alpha_cutoff() {
        number("alphaCutoff", cutoff, Range::NonNegative)?;
    }
    // Any number (a negative scale turns the normal map's X and Y).
    if let Some(normal) = m.normal_texture() {
        number("normalTexture.scale", normal.scale(), Range::Any)?;
    }
    // In [0, 1]; the occlusion texture is not used, its strength is
    // checked all the same (the document is wrong).
    if let Some(occlusion) = m.occlusion_texture() {
        number(
            "occlusionTexture.strength",
            occlusion.strength(),
            Range::Unit,
        )?;
    }
    // KHR_materials_emissive_strength: minimum 0. With every component of
    // emissiveFactor at most 1, the emission (their product) is at most
    // the strength: finite.
    if let Some(strength) = m.emissive_strength() {
        number(
            "extensions.KHR_materials_emissive_strength.emissiveStrength",
            strength,
            Range::NonNegative,
        )?;
    }
    // KHR_materials_transmission: in [0, 1].
    if let Some(t) = m.transmission() {
        number(
            "extensions.KHR_materials_transmission.transmissionFactor",
            t.transmission_factor(),
            Range::Unit,
        )?;
    }
    // KHR_materials_ior: 1 or above, or exactly 0 (the extension's value
    // for an infinite index; `Importer::dielectric` refuses it on glass).
    if let Some(ior) = m.ior() {
        number("extensions.KHR_materials_ior.ior", ior, Range::Any)?;
        if !(ior >= 1.0 || ior == 0.0) {
            return Err(format!(
                "extensions.KHR_materials_ior.ior {} must be at least 1 (or exactly 0)",
                show(ior)
            ));
        }
    }
    if let Some(v) = m.volume() {
        // KHR_materials_volume: thicknessFactor minimum 0;
        // attenuationDistance above 0 (exclusive minimum), infinite when
        // absent, so an infinity is its default and not refused;
        // attenuationColor each component in [0, 1].
        number(
            "extensions.KHR_materials_volume.thicknessFactor",
            v.thickness_factor(),
            Range::NonNegative,
        )?;
        let distance = v.attenuation_distance();
        if distance != f32::INFINITY {
            number(
                "extensions.KHR_materials_volume.attenuationDistance",
                distance,
                Range::Positive,
            )?;
        }
        numbers(
            "extensions.KHR_materials_volume.attenuationColor",
            &v.attenuation_color(),
            Range::Unit,
        )?;
    }
    Ok(())
}

/// A texture's `KHR_texture_transform` (in the texture reference `slot`,
/// such as `normalTexture`): its offset, rotation and scale finite (the
/// extension gives them no other bound), and the renderer's uv map that
/// they compose ([`uv_matrix`]) finite in f32, which large offsets
/// and scales together can overflow.
pub(super) fn transform(slot: &str, t: &UvTransform) -> Result<(), String> {
    let field = format!("{slot}.extensions.KHR_texture_transform");
    numbers(&format!("{field}.offset"), &t.offset, Range::Any)?;
    number(&format!("{field}.rotation"), t.rotation, Range::Any)?;
    numbers(&format!("{field}.scale"), &t.scale, Range::Any)?;
    let map = uv_matrix(t);
    if map.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "{field}: offset {}, rotation {} and scale {} compose a uv map beyond the range of a 32-bit float",
            show_all(&t.offset),
            show(t.rotation),
            show_all(&t.scale)
        ));
    }
    Ok(())
}

/// The accessor types glTF 2.0 allows a vertex attribute the importer
/// reads (the specification's "Meshes" section, table "Attributes"; the
/// extension that widens them, KHR_mesh_quantization, is not supported):
/// POSITION and NORMAL VEC3 of FLOAT, TANGENT VEC4 of FLOAT, TEXCOORD_n
/// VEC2 and COLOR_n VEC3 or VEC4 of FLOAT or of normalized UNSIGNED_BYTE
/// or UNSIGNED_SHORT. A FLOAT accessor must not be `normalized` (the
/// specification's "Accessors" section). JOINTS_n, WEIGHTS_n and
/// application-specific attributes are not read and not checked.
pub(super) fn attribute(semantic: &Semantic, accessor: &gltf::Accessor) -> Result<(), String> {
    use DataType::{F32, U16, U8};
    use Dimensions::{Vec2, Vec3, Vec4};
    let (shapes, quantized): (&[Dimensions], bool) = match semantic {
        Semantic::Positions | Semantic::Normals => (&[Vec3], false),
        Semantic::Tangents => (&[Vec4], false),
        Semantic::TexCoords(_) => (&[Vec2], true),
        Semantic::Colors(_) => (&[Vec3, Vec4], true),
        _ => return Ok(()),
    };
    let (shape, component, normalized) = (
        accessor.dimensions(),
        accessor.data_type(),
        accessor.normalized(),
    );
    let allowed_component = match component {
        F32 => !normalized,
        U8 | U16 => quantized && normalized,
        _ => false,
    };
    if shapes.contains(&shape) && allowed_component {
        return Ok(());
    }
    let names = |shapes: &[Dimensions]| {
        shapes
            .iter()
            .map(|&s| shape_name(s))
            .collect::<Vec<_>>()
            .join(" or ")
    };
    let components = if quantized {
        "FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT"
    } else {
        "FLOAT"
    };
    Err(format!(
        "attributes.{}: accessor {} is {} of {}{}; glTF 2.0 allows {} of {components}",
        semantic.to_string(),
        accessor.index(),
        shape_name(shape),
        if normalized { "normalized " } else { "" },
        component_name(component),
        names(shapes),
    ))
}

/// An accessor `type` as the file spells it.
fn shape_name(shape: Dimensions) -> &'static str {
    match shape {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

/// An accessor `componentType` by the specification's name.
fn component_name(component: DataType) -> &'static str {
    match component {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

/// How far from 1 a node's rotation may be in length: 0.00769, the
/// Khronos glTF-Validator's bound (`unitLengthThresholdVec4` in its
/// lib/src/errors.dart, "slightly greater than the maximum error from
/// signed 8-bit quantization"; lib/src/base/node.dart reports
/// NODE_ROTATION_NON_UNIT, an error, beyond it). Within it the rotation is
/// normalized. What other importers do: Blender normalizes any quaternion
/// before use (`BKE_object_rot_to_mat3`, "quats are normalized before use
/// to eliminate scaling issues"), so it takes every non-zero length;
/// three.js's GLTFLoader composes the node's matrix from the quaternion
/// as written (`Matrix4.compose` does not normalize), so a non-unit
/// rotation also scales and shears the mesh. The importer takes the
/// validator's bound: as forgiving as a valid file needs (a quaternion
/// written with two decimals, such as [0, 0, 0.29, 0.96] of length
/// 1.0028, loads), and a quaternion further off is not a rounded rotation
/// but a mistake, refused rather than guessed at.
pub(super) const ROTATION_UNIT_TOLERANCE: f64 = 0.00769;

/// Up to this far from unit length a rotation is normalized silently:
/// 10^-3. A unit quaternion written with three decimals or more is off by
/// at most that (each of its four components rounded by at most
/// 5·10^-4, an error of length at most √4 · 5·10^-4 = 10^-3; with f32's
/// 24 bits, about 10^-7), so such a deviation is only the writer's
/// rounding. Beyond it (two decimals allow up to 10^-2) the rotation
/// itself is known only to about that precision (a quaternion off by δ
/// turns by up to about 2δ radians more or less than meant: about 1° at
/// 10^-2), which a warning line says.
pub(super) const ROTATION_QUIET: f64 = 1e-3;

/// A node's transform as glTF 2.0 requires it (the specification's
/// "Transformations" section and node.schema.json): `rotation` a unit
/// quaternion (within [`ROTATION_UNIT_TOLERANCE`]), every number finite,
/// and `matrix` affine (its last row 0, 0, 0, 1: the specification asks
/// for a matrix that decomposes into translation, rotation and scale, and
/// the importer keeps only the affine part). The message starts with the
/// field as the file spells it; the caller puts the node in front. `Ok`
/// holds a warning of the same form where the rotation is accepted but
/// further than [`ROTATION_QUIET`] from unit length.
pub(super) fn node_transform(t: &gltf::scene::Transform) -> Result<Option<String>, String> {
    match t {
        gltf::scene::Transform::Matrix { matrix } => {
            let flat: Vec<f32> = matrix.iter().flatten().copied().collect();
            numbers("matrix", &flat, Range::Any)?;
            // Column-major: the last row is elements 3, 7, 11 and 15.
            let last_row = [matrix[0][3], matrix[1][3], matrix[2][3], matrix[3][3]];
            if last_row != [0.0, 0.0, 0.0, 1.0] {
                return Err(format!(
                    "matrix has the last row {} (elements 3, 7, 11 and 15); glTF 2.0 allows only an affine matrix, whose last row is [0, 0, 0, 1]",
                    show_all(&last_row)
                ));
            }
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            numbers("translation", translation, Range::Any)?;
            numbers("rotation", rotation, Range::Any)?;
            numbers("scale", scale, Range::Any)?;
            let length = rotation
                .iter()
                .map(|&x| f64::from(x) * f64::from(x))
                .sum::<f64>()
                .sqrt();
            let off = (length - 1.0).abs();
            if off > ROTATION_UNIT_TOLERANCE {
                return Err(format!(
                    "rotation {} is not a unit quaternion (its length is {length:.6}); glTF 2.0 requires unit length (the importer normalizes one within {ROTATION_UNIT_TOLERANCE} of it, glTF-Validator's bound)",
                    show_all(rotation)
                ));
            }
            if off > ROTATION_QUIET {
                return Ok(Some(format!(
                    "rotation {} has length {length:.6}, not the unit length glTF 2.0 requires: normalized (the rotation is as precise as the digits it was written with)",
                    show_all(rotation)
                )));
            }
        }
    }
    Ok(None)
}

/// A perspective camera's numbers that the importer reads (the glTF 2.0
/// schema, camera.perspective.schema.json): `yfov` above 0 (exclusive
/// minimum) and, as the specification says it should be, below π (no
/// pinhole sees half the sphere), in the degrees the renderer's camera
/// takes: the f32 just below π is 180° once converted; `aspectRatio`
/// above 0 (exclusive minimum). `znear` and `zfar` are not read: nothing
/// is clipped.
pub(super) fn perspective(p: &gltf::json::camera::Perspective) -> Result<(), String> {
    number("perspective.yfov", p.yfov, Range::Positive)?;
    let degrees = p.yfov.to_degrees();
    if degrees >= 180.0 {
        return Err(format!(
            "perspective.yfov {} must be below π (it is {}° as a 32-bit float; the field of view must be under 180°)",
            show(p.yfov),
            show(degrees)
        ));
    }
    if let Some(aspect) = p.aspect_ratio {
        number("perspective.aspectRatio", aspect, Range::Positive)?;
    }
    Ok(())
}
