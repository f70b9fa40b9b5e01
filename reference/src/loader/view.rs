//! View files: a scene seen from another camera, with other render
//! settings. A JSON document whose `scene` key names another scene (a
//! file, relative to the view file, or a built-in name) and whose
//! `camera` and `render` objects, in the scene format's form, replace the
//! scene's (each `render` field given replaces that field alone):
//!
//! ```json
//! { "scene": "../fixtures/scenes/cornell-boxes.json",
//!   "camera": { "look_from": [0, 1, 4], "look_at": [0, 1, 0] },
//!   "render": { "width": 320, "height": 240, "spp": 64 },
//!   "comment": "what the view shows" }
//! ```
//!
//! The viewer's save writes one (`twintrace view`), so that a view that
//! shows something worth keeping is a scene `render`, `diff` and the
//! gates take as it is. The scene a view names may not be a view itself.

use super::json::{CameraJson, RenderJson};
use crate::error::SceneError;
use crate::scene::Scene;
use serde::Deserialize;
use std::path::Path;

/// A view document.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewJson {
    /// The scene seen: a file relative to the view file, or a built-in
    /// name.
    pub scene: String,
    pub camera: Option<CameraJson>,
    #[serde(default)]
    pub render: RenderJson,
    /// Free text (the viewer writes the settings a render of the view
    /// needs that the scene format does not hold).
    pub comment: Option<String>,
}

/// Whether a parsed JSON document is a view (an object with a `scene`
/// key and no `objects`).
pub fn is_view(doc: &serde_json::Value) -> bool {
    doc.get("scene").is_some() && doc.get("objects").is_none()
}

/// Loads the view file at `path` (its text `text`), the scene it names
/// read by `load` (the loader's `load_scene`).
pub fn load_view(
    path: &Path,
    text: &str,
    load: &dyn Fn(&str) -> Result<Scene, SceneError>,
) -> Result<Scene, SceneError> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let view: ViewJson = serde_path_to_error::deserialize(de).map_err(|e| {
        let inner = e.inner();
        SceneError::Parse {
            path: path.to_path_buf(),
            line: inner.line(),
            column: inner.column(),
            field: e.path().to_string(),
            message: inner
                .to_string()
                .rsplit_once(" at line ")
                .map_or(inner.to_string(), |(m, _)| m.to_string()),
        }
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let file = dir.join(&view.scene);
    let spec = if file.exists() {
        file.display().to_string()
    } else if crate::builtin::NAMES.contains(&view.scene.as_str()) {
        view.scene.clone()
    } else {
        return Err(SceneError::invalid(
            "scene",
            format!(
                "`{}` is neither a file beside the view nor a built-in scene",
                view.scene
            ),
        )
        .in_file(path));
    };
    if file.exists() {
        let text = std::fs::read_to_string(&file).map_err(|e| SceneError::Io {
            path: file.clone(),
            message: format!("cannot read the scene the view names: {e}"),
        })?;
        if serde_json::from_str::<serde_json::Value>(&text).is_ok_and(|d| is_view(&d)) {
            return Err(SceneError::invalid(
                "scene",
                format!("`{}` is a view itself; a view names a scene", view.scene),
            )
            .in_file(path));
        }
    }
    if let Some(c) = &view.camera {
        c.check().map_err(|e| e.in_file(path))?;
    }
    let scene = load(&spec)?;
    let sampler = view
        .render
        .sampler_or(scene.render_settings().sampler)
        .map_err(|e| e.in_file(path))?;
    scene
        .edited(|look| {
            if let Some(c) = &view.camera {
                look.camera = c.settings();
            }
            let r = &view.render;
            let s = &mut look.render;
            s.width = r.width.unwrap_or(s.width);
            s.height = r.height.unwrap_or(s.height);
            s.spp = r.spp.unwrap_or(s.spp);
            s.max_depth = r.max_depth.unwrap_or(s.max_depth);
            s.seed = r.seed.unwrap_or(s.seed);
            s.roulette_depth = r.roulette_depth.unwrap_or(s.roulette_depth);
            s.sampler = sampler;
        })
        .map_err(|e| e.in_file(path))
}
