//! Scene input: JSON scene files, glTF 2.0, images, built-in scenes, and
//! view files (a scene from another camera: [`view`]).

pub mod gltf;
pub mod image;
pub mod json;
pub mod view;

use crate::error::SceneError;
use crate::scene::Scene;
use std::path::Path;

/// Loads a scene by built-in name (`rtow-final`, `cornell`, ...) or from a
/// file: `.json` scene files, `.gltf`/`.glb` documents.
pub fn load_scene(spec: &str) -> Result<Scene, SceneError> {
    let path = Path::new(spec);
    if !path.exists() && crate::builtin::NAMES.contains(&spec) {
        return crate::builtin::load(spec);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf") | Some("glb") => gltf::load_gltf_document(path),
        _ if !path.exists() && !spec.contains('/') && !spec.contains('.') => {
            Err(SceneError::UnknownBuiltin(spec.to_string()))
        }
        _ => json::load_json_scene(path),
    }
}
