//! The render boundary on GPUs (`twintrace::render`): a progressive
//! render on one device takes a thousand one-sample ranges into the film
//! in the device's memory, compiling no pipeline after it is opened, and
//! holds the film of one thousand-sample render bit for bit; so does
//! every schedule over uneven ranges, and a group of two devices opened
//! on the test adapter, whose ranges are dealt out in units (and stopped
//! part way, a prefix of the range held whole). A reset
//! with new settings starts a new film on the same kernels.

use crate::common;
use reference::integrator::Integrator;
use reference::RenderSettings;
use twintrace::render::{GpuProgressive, GroupProgressive, Layers, Progressive, RenderSpec};

fn tiny() -> RenderSettings {
    RenderSettings {
        width: 4,
        height: 3,
        spp: 1000,
        max_depth: 5,
        seed: 9,
        ..RenderSettings::default()
    }
}

#[test]
fn a_thousand_single_sample_ranges_stay_on_the_device_and_are_one_render() {
    let ctx = &common::own_gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = tiny();
    let spec = RenderSpec::DEFAULT;
    let mut p = GpuProgressive::new(ctx, &scene, &spec, settings).unwrap();
    let whole = p.renderer().render(&settings, &|_, _| {}).unwrap().sums;
    let built = ctx.pipelines_built();
    for i in (0..1000u32).rev() {
        p.add(i..i + 1, &|_| {}).unwrap();
    }
    assert_eq!(ctx.pipelines_built(), built, "a range compiled a pipeline");
    assert_eq!(format!("{:?}", p.ranges()), "[0..1000]");
    assert_eq!(p.sums().unwrap(), whole);
    assert_eq!(p.layers().unwrap(), Layers::from_sums(&whole));
}

#[test]
fn ranges_that_trace_the_same_samples_again_are_not_the_whole_film() {
    // The mutant: every range traces samples 0..1 (keyed by its length,
    // not its indices). Every pixel still counts 20 samples, so only the
    // comparison of the sums can tell.
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings { spp: 20, ..tiny() };
    let spec = RenderSpec::DEFAULT;
    let p = GpuProgressive::new(ctx, &scene, &spec, settings).unwrap();
    let r = p.renderer();
    let whole = r.render(&settings, &|_, _| {}).unwrap().sums;
    for i in 0..20 {
        r.accumulate(&settings, 0..1, &|_, _| {}, i == 0).unwrap();
    }
    let repeated = r.read_film(&settings, 20).unwrap();
    assert!(repeated.pixels.iter().all(|p| p.count + p.rejected == 20));
    assert_ne!(
        repeated, whole,
        "twenty copies of sample 0 passed for samples 0..20"
    );
}

#[test]
fn every_schedule_takes_uneven_ranges_into_one_render_and_resets() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings { spp: 40, ..tiny() };
    for schedule in common::gate_schedules(ctx) {
        let spec = RenderSpec {
            variant: gpu::Variant {
                schedule,
                ..RenderSpec::DEFAULT.variant
            },
            ..RenderSpec::DEFAULT
        };
        let mut p = GpuProgressive::new(ctx, &scene, &spec, settings).unwrap();
        let whole = p.renderer().render(&settings, &|_, _| {}).unwrap().sums;
        for r in [17..40, 0..1, 3..17, 1..3] {
            p.add(r, &|_| {}).unwrap();
        }
        assert_eq!(p.sums().unwrap(), whole, "{schedule:?}");
        assert!(
            p.add(5..6, &|_| {}).is_err(),
            "{schedule:?}: an overlap was taken"
        );
        let other = RenderSettings {
            width: 6,
            seed: 2,
            spp: 9,
            ..settings
        };
        p.reset(other).unwrap();
        p.add(0..9, &|_| {}).unwrap();
        let fresh = p.renderer().render(&other, &|_, _| {}).unwrap().sums;
        assert_eq!(p.sums().unwrap(), fresh, "{schedule:?} after a reset");
    }
}

#[test]
fn a_group_of_three_devices_is_the_one_device_film_bit_for_bit() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings { spp: 50, ..tiny() };
    let spec = RenderSpec::DEFAULT.with_integrator(Integrator::Mis);
    let one = GpuProgressive::new(ctx, &scene, &spec, settings)
        .unwrap()
        .renderer()
        .render(&settings, &|_, _| {})
        .unwrap()
        .sums;
    let i = common::test_adapter_index();
    // Three: the films are added as a tree, a pair and then the odd one.
    let contexts = gpu::devices::DeviceSelection::Indices(vec![i, i, i])
        .open()
        .unwrap();
    let mut group = GroupProgressive::new(&contexts, &scene, &spec, settings).unwrap();
    group.set_chunk(Some(2));
    // Bands of 5 of the 12 pixels: the films are added in three bands,
    // the last a short one.
    group.set_merge_band(Some(5));
    let mut part = GpuProgressive::new(ctx, &scene, &spec, settings).unwrap();
    for r in [0..7, 30..50, 7..30] {
        let added = group.add(r.clone(), &|_| {}).unwrap();
        let shared: u64 = added.shares.iter().map(|s| s.samples).sum();
        assert_eq!(shared, (r.end - r.start) as u64);
        // Read between ranges: the films added on a device are not added
        // again by the next read.
        part.add(r.clone(), &|_| {}).unwrap();
        assert_eq!(
            group.layers().unwrap(),
            part.layers().unwrap(),
            "after {r:?}"
        );
    }
    assert_eq!(group.sums().unwrap(), one);
    assert_eq!(group.layers().unwrap(), Layers::from_sums(&one));
    assert!(group.device().starts_with("3 gpus"), "{}", group.device());
}

/// A group asks the stop before each device's unit, not only between
/// ranges: a stop that turns true once a few units are done ends the
/// range part way, every unit dealt finished, so the films hold a prefix
/// of the range, which [`add_chunked`] says it added and whose sums are
/// the one-device render of those samples bit for bit; the read is left
/// to go on, and the rest of the range then makes the whole film. With
/// no stop, the whole range is given to the group at once.
#[test]
fn a_group_stopped_mid_range_holds_the_prefix_its_devices_finished() {
    use std::sync::atomic::{AtomicU64, Ordering};
    use twintrace::render::{add_chunked, held_film, Chunking};
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings { spp: 60, ..tiny() };
    let spec = RenderSpec::DEFAULT;
    let i = common::test_adapter_index();
    let contexts = gpu::devices::DeviceSelection::Indices(vec![i, i])
        .open()
        .unwrap();
    let mut group = GroupProgressive::new(&contexts, &scene, &spec, settings).unwrap();
    group.set_chunk(Some(3));
    let one = |samples: std::ops::Range<u32>| {
        let mut p = GpuProgressive::new(ctx, &scene, &spec, settings).unwrap();
        p.add(samples, &|_| {}).unwrap();
        p.sums().unwrap()
    };
    let pixels = (settings.width * settings.height) as u64;
    // Stops once five units (of 3 samples) are done.
    let done = AtomicU64::new(0);
    let progress = |n: u64| {
        done.fetch_add(n, Ordering::SeqCst);
    };
    let stop = || done.load(Ordering::SeqCst) >= 5 * 3 * pixels;
    let mut nothing = |_: &mut dyn Progressive| Ok(());
    let mut c = Chunking::new(std::time::Duration::from_secs(3600), &stop, &mut nothing);
    let added = add_chunked(&mut group, 0..60, Some(&mut c), &progress).unwrap();
    assert!(added.stopped, "the stop was not seen within the range");
    // Five units, and at most one more a device dealt before the stop.
    assert!(
        (15..=21).contains(&added.end) && added.end % 3 == 0,
        "stopped at {}",
        added.end
    );
    let shared: u64 = added.shares.iter().map(|s| s.samples).sum();
    assert_eq!(shared, added.end as u64);
    assert_eq!(group.ranges(), std::slice::from_ref(&(0..added.end)));
    let (end, sums) = held_film(&mut group, 0).unwrap();
    assert_eq!(end, added.end);
    assert_eq!(sums, one(0..end));
    assert_eq!(group.layers().unwrap(), Layers::from_sums(&sums));

    // The rest, never stopped: one range given whole.
    let never = || false;
    let mut chunks = 0;
    let mut count = |_: &mut dyn Progressive| {
        chunks += 1;
        Ok(())
    };
    let mut c = Chunking::new(std::time::Duration::ZERO, &never, &mut count);
    let rest = add_chunked(&mut group, end..60, Some(&mut c), &|_| {}).unwrap();
    assert_eq!((rest.end, rest.stopped), (60, false));
    assert_eq!(chunks, 1, "the range was cut into chunks");
    assert_eq!(group.sums().unwrap(), one(0..60));
}
