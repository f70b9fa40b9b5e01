//! Resumable renders on the GPU (lavapipe in CI): interrupted at seeded
//! random points (before the first chunk: the device still opening; in
//! the middle; near the end), resumed by each run's own continue command,
//! the film equals the uninterrupted GPU render's bit for bit (the
//! resumed film's layers are computed on the host from the part's sums
//! and the device's, which equal the device's layers bit for bit,
//! `twins::film::layers`); so does a group of two devices, interrupted
//! within its one range. A device lost mid-render takes its film with
//! it: the chunks done cannot be read, and [`held_film`] says so.

use crate::resume::{cornell, interrupt_and_resume};
use std::time::Duration;
use twintrace::render::{
    add_chunked, held_film, Chunking, GpuProgressive, Progressive, RenderSpec,
};

/// A 16x16 Cornell box: on lavapipe 1024 samples a pixel, about 0.8 s of
/// tracing after about 1.5 s of opening the device and its kernels (at 256
/// the tracing took 0.2 s, and on CI's machine the start-up's jitter hid
/// it: every middle point landed before the first chunk or after the
/// end); on a
/// hardware GPU 2^22, so that the tracing (about 1.5 s on an H100) outlasts
/// the jitter of a process's start-up (at 256 samples the H100 traced in
/// about 10 ms, and the points meant for the middle of the tracing missed
/// it).
#[test]
fn interrupted_gpu_renders_resume_to_the_whole_render_bit_for_bit() {
    let spp = if crate::common::gpu().is_software {
        "1024"
    } else {
        "4194304"
    };
    interrupt_and_resume(&cornell("gpu", "16x16", spp, &[]), 0x5eed_6043, 1);
}

/// The same on two devices opened on the test adapter: a group is given
/// its range whole and asks for the signal before each device's unit, so
/// an interrupt in the middle saves the prefix of samples its devices
/// finished, and the resumed film is the whole two-device render's (the
/// one-device render's, tests/gpu/gpu_split_render.rs) bit for bit.
#[test]
fn interrupted_group_renders_resume_to_the_whole_render_bit_for_bit() {
    let i = crate::common::test_adapter_index();
    let pair = format!("{i},{i}");
    let spp = if crate::common::gpu().is_software {
        "1024"
    } else {
        "4194304"
    };
    let render = cornell("gpu", "16x16", spp, &["--devices", &pair]);
    interrupt_and_resume(&render, 0x5eed_6045, 1);
}

#[test]
fn a_device_lost_mid_render_takes_its_film_with_it() {
    let ctx = crate::common::own_gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let settings = reference::RenderSettings {
        width: 8,
        height: 8,
        spp: 16,
        max_depth: 4,
        ..scene.render_settings()
    };
    let mut p = GpuProgressive::new(&ctx, &scene, &RenderSpec::DEFAULT, settings).unwrap();
    let never = || false;
    let chunks = std::cell::Cell::new(0);
    let mut lose = |_: &mut dyn Progressive| {
        chunks.set(chunks.get() + 1);
        if chunks.get() == 2 {
            ctx.device.destroy();
        }
        Ok(())
    };
    let mut c = Chunking::new(Duration::ZERO, &never, &mut lose);
    let e = add_chunked(&mut p, 0..16, Some(&mut c), &|_| {}).unwrap_err();
    // Two one-sample chunks were done before the device went.
    assert_eq!(p.ranges(), std::slice::from_ref(&(0..2)), "{e}");
    let lost = held_film(&mut p, 0).unwrap_err();
    assert!(!lost.to_string().is_empty());
}
