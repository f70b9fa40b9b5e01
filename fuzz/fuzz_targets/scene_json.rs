//! The JSON scene loader (`reference::loader::load_scene_text`: a scene
//! file or a view file, `reference::loader::json` and `::view`) on any text: a
//! scene, an error naming the field, never a panic or a hang. The scene
//! is named as if in a folder that does not exist, so the files it
//! refers to (meshes, textures, another scene of a view file) are
//! missing files, never read.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("/nonexistent-twintrace-fuzz/scene.json");
    let _ = reference::loader::load_scene_text(path, text);
});
