//! Inputs the fuzz targets (docs/fuzzing.md) crashed the loaders with,
//! each now an error naming the file. The inputs are seeds of their
//! target too (fixtures/fuzz/<target>/regression-*).

use reference::loader::gltf::load_gltf_document_bytes;
use std::path::{Path, PathBuf};

fn seed(target: &str, name: &str) -> (PathBuf, Vec<u8>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/fuzz")
        .join(target)
        .join(name);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (path, bytes)
}

/// A GLB whose `accessors` key is misspelled while a primitive's
/// `POSITION` names accessor 1: the `gltf` crate's validation indexed the
/// accessors unchecked and panicked.
#[test]
fn a_position_naming_no_accessor_is_an_error() {
    let (path, bytes) = seed("glb", "regression-position-accessor.glb");
    let e = load_gltf_document_bytes(&path, &bytes)
        .unwrap_err()
        .to_string();
    assert!(e.contains("regression-position-accessor.glb"), "{e}");
    assert!(
        e.contains("POSITION names accessor 1, the file has 0"),
        "{e}"
    );
}
