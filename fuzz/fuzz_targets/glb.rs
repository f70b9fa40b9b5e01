//! The glTF importer (`reference::loader::gltf`) on a GLB container: the
//! header, the JSON chunk and the binary chunk. Every input is made a
//! container (the magic prepended where missing), so the fuzzer spends
//! its time on the chunks.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("/nonexistent-twintrace-fuzz/scene.glb");
    if data.starts_with(b"glTF") {
        let _ = reference::loader::gltf::load_gltf_document_bytes(path, data);
    } else {
        let bytes = [b"glTF".as_slice(), data].concat();
        let _ = reference::loader::gltf::load_gltf_document_bytes(path, &bytes);
    }
});
