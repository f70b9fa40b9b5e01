//! The GPU film's exact sums equal the reference's word for word
//! (`twintrace::twins::film`, also run by `twintrace selftest`), and a
//! kernel whose fixed-point conversion truncates instead of rounding
//! fails that comparison. A GPU render split into sample ranges merges
//! into the whole GPU render bit for bit, under every schedule.

use crate::common;
use reference::film::FilmSums;
use reference::integrator::Integrator;
use reference::RenderSettings;
use twintrace::twins::film;

#[test]
fn film_sums_are_the_references_word_for_word() {
    match film::sums(common::gpu()) {
        Ok(summary) => println!("film: {summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_truncating_fixed_point_fails_the_film_twin() {
    let library = gpu::shader::library_source();
    let rounding = "(m + (1u << (r - 1u))) >> r";
    assert_eq!(library.matches(rounding).count(), 1);
    let mutant = library.replace(rounding, "m >> r");
    let e = film::sums_with_library(common::gpu(), &mutant)
        .expect_err("a truncating fixed point passed the film twin");
    println!("truncation caught: {}", &e[..e.len().min(200)]);
}

#[test]
fn gpu_sample_ranges_merge_into_the_whole_gpu_render_bit_for_bit() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings {
        width: 10,
        height: 8,
        spp: 24,
        max_depth: 6,
        seed: 3,
        ..RenderSettings::default()
    };
    for schedule in gpu::Schedule::ALL {
        let variant = gpu::Variant {
            integrator: Integrator::Mis,
            kernel: gpu::Kernel::Specialized,
            schedule,
            traversal: gpu::Traversal::Binary,
            nodes: gpu::NodeLayout::Aos,
            leaves: gpu::LeafLayout::Indexed,
            dispatch: gpu::Dispatch::Switch,
        };
        let r = gpu::GpuRenderer::with_variant(ctx, &scene, variant).unwrap();
        let whole = r.render(&settings, &|_, _| {}).unwrap().sums;
        for cuts in [
            &[0u32, 17, 24][..],
            &[0, 1, 9, 24],
            &[0, 3, 4, 11, 12, 13, 20, 24],
        ] {
            let mut merged = FilmSums::new(settings.width, settings.height);
            for w in cuts.windows(2).rev() {
                let part = r.render_samples(&settings, w[0]..w[1], &|_, _| {}).unwrap();
                merged.merge(&part.sums).unwrap();
            }
            assert_eq!(merged, whole, "{schedule:?}, cuts {cuts:?}");
        }
    }
}
