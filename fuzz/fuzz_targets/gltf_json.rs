//! The glTF importer (`reference::loader::gltf`) on a `.gltf` (JSON)
//! document: buffers and images as `data:` URIs are decoded, files it
//! names are missing (its folder does not exist).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // A GLB container is the `glb` target's.
    if data.starts_with(b"glTF") {
        return;
    }
    let path = Path::new("/nonexistent-twintrace-fuzz/scene.gltf");
    let _ = reference::loader::gltf::load_gltf_document_bytes(path, data);
});
