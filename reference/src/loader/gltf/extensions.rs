//! The glTF extensions the importer implements, and the check of a
//! document's `extensionsRequired` against them.

/// The punctual lights extension.
pub(super) const LIGHTS: &str = "KHR_lights_punctual";

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
pub(super) fn check_required(required: &[String]) -> Result<(), String> {
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

/// The name of the clear coat extension.
pub(super) const CLEARCOAT: &str = "KHR_materials_clearcoat";
