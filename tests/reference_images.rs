//! Every fixture scene, rendered by the reference at a test budget with a
//! seed other than the reference's, matches its stored reference
//! (`fixtures/refs/`, made by `cargo xtask bless`): the per-pixel z-test
//! against the reference (Mitsuba 3's scheme, Šidák over all pixel
//! channels at α = 0.01, 99.75 % must pass) and the z-tests on the image
//! sum and 8x8 tile sums all pass. A failure writes the render, the
//! reference and an HTML report under `target/diff/reference_images_<scene>/`.

use crate::common::gates::gate_fixture;
use twintrace::compare::gate::{cpu_reference, read_manifest};

/// The seed of every test render; the references use seed 1.
const TEST_SEED: u32 = 7;

/// One test per reference, with its budget in samples per pixel: 1024
/// everywhere (the measurement behind the aggregate tests: a 64x64 Cornell box at 1024 spp
/// against 16384); about 10 s for all eight on two cores at the test
/// profile's opt-level 1.
macro_rules! gates {
    ($($test:ident: $name:literal, $spp:expr;)*) => {
        $(
            #[test]
            fn $test() {
                gate_fixture("reference_images", $name, $spp, TEST_SEED, &cpu_reference);
            }
        )*
        const CASES: &[&str] = &[$($name),*];
    };
}

gates! {
    cornell_boxes: "cornell-boxes", 1024;
    cornell_spheres: "cornell-spheres", 1024;
    depth_of_field: "depth-of-field", 1024;
    four_materials: "four-materials", 1024;
    ggx_roughness: "ggx-roughness", 1024;
    gltf_mesh: "gltf-mesh", 1024;
    skybox: "skybox", 1024;
    textures: "textures", 1024;
}

#[test]
fn every_fixture_scene_has_a_reference_and_a_gate() {
    let manifest = read_manifest().unwrap();
    let mut listed: Vec<&str> = manifest.iter().map(|s| s.name.as_str()).collect();
    listed.sort();
    let mut tested = CASES.to_vec();
    tested.sort();
    assert_eq!(
        listed, tested,
        "every reference in the manifest has exactly one gate above"
    );
    let dir = twintrace::compare::gate::workspace_root().join("fixtures/scenes");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "json") {
            let rel = format!(
                "fixtures/scenes/{}",
                path.file_name().unwrap().to_string_lossy()
            );
            assert!(
                manifest.iter().any(|s| s.scene == rel),
                "{rel} has no reference in fixtures/refs/manifest.txt"
            );
        }
    }
    for spec in &manifest {
        assert_ne!(
            spec.seed, TEST_SEED,
            "{}: the test seed must differ from the reference's",
            spec.name
        );
    }
}
