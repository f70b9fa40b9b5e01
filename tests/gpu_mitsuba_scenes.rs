//! The GPU twin on the Mitsuba gate scenes of fixtures/mitsuba, judged
//! as Mitsuba's render tests judge an image (tests/mitsuba_scenes.rs has
//! the CPU twin, the mutant and the false-alarm rate).

use twintrace::mitsuba_tests::{self, Budget};
use twintrace::render::Devices;

#[test]
fn gpu_the_gpu_twin_passes_mitsubas_render_test_protocol_on_the_gate_scenes() {
    let dir = twintrace::compare::gate::workspace_root().join("fixtures/mitsuba");
    let cases = mitsuba_tests::cases(&dir).unwrap();
    assert!(!cases.is_empty());
    for case in cases {
        let scene = mitsuba_tests::load(&case).unwrap().unwrap();
        let (verdict, spp) = mitsuba_tests::run_scene(
            &case,
            &scene,
            Devices::Gpu(crate::common::gpu()),
            Budget::default(),
        )
        .unwrap();
        println!("{}: gpu, {spp} spp: {}", case.name, verdict.figures());
        assert!(verdict.passes(), "{}: {}", case.name, verdict.figures());
    }
}
