//! Scene input: JSON scene files, glTF 2.0, Mitsuba 3 XML, images,
//! built-in scenes, and view files (a scene from another camera:
//! [`view`]).

pub mod gltf;
pub mod image;
pub mod json;
pub mod mitsuba;
pub mod view;

use crate::error::SceneError;
use crate::scene::Scene;
use std::path::Path;

/// How files are read where their format leaves a choice to the user.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Mitsuba scenes' parameters, as Mitsuba's `-D name=value`: they
    /// override the file's `<default>`s.
    pub defines: Vec<(String, String)>,
    /// glTF documents' light units ([`gltf::GltfOptions`]).
    pub gltf: gltf::GltfOptions,
}

/// Loads a scene by built-in name (`rtow-final`, `cornell`, ...) or from a
/// file: `.json` scene files, `.gltf`/`.glb` documents, `.xml` Mitsuba 3
/// scenes.
pub fn load_scene(spec: &str) -> Result<Scene, SceneError> {
    load_scene_with(spec, &LoadOptions::default())
}

/// [`load_scene`] with the user's [`LoadOptions`].
pub fn load_scene_with(spec: &str, options: &LoadOptions) -> Result<Scene, SceneError> {
    let path = Path::new(spec);
    if !path.exists() && crate::builtin::NAMES.contains(&spec) {
        return crate::builtin::load(spec);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf") | Some("glb") => gltf::load_gltf_document_with(path, &options.gltf),
        Some("xml") => mitsuba::load(path, &options.defines),
        _ if !path.exists() && !spec.contains('/') && !spec.contains('.') => {
            Err(SceneError::UnknownBuiltin(spec.to_string()))
        }
        _ => {
            let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
                path: path.to_path_buf(),
                message: format!("cannot read scene: {e}"),
            })?;
            load_scene_text_with(path, &text, &options.gltf)
        }
    }
}

/// A JSON scene file or a view file ([`view`]) already in memory (`text`,
/// named `path`): nothing is read from disk but the files it refers to,
/// relative to `path`'s folder (the fuzz targets' entry).
pub fn load_scene_text(path: &Path, text: &str) -> Result<Scene, SceneError> {
    load_scene_text_with(path, text, &gltf::GltfOptions::default())
}

/// [`load_scene_text`] with the loader's glTF options.
pub fn load_scene_text_with(
    path: &Path,
    text: &str,
    gltf: &gltf::GltfOptions,
) -> Result<Scene, SceneError> {
    if serde_json::from_str::<serde_json::Value>(text).is_ok_and(|d| view::is_view(&d)) {
        return view::load_view(path, text, &load_scene);
    }
    json::load_json_scene_text_with(path, text, gltf)
}
