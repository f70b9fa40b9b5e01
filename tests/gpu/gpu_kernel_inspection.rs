//! What the driver made of each kernel (`gpu::pipeline::inspect`): every
//! kernel a device built is found, its SPIR-V is a module the driver
//! compiles, the SPIR-V follows the kernel's runtime checks, and where the
//! driver has `VK_KHR_pipeline_executable_properties` each kernel has an
//! executable with the same statistics each time it is inspected.
//! `render --dump-kernels` writes the SPIR-V and the report, and
//! `--timings` prints a line a kernel; on the CPU reference the flag is
//! refused in one line.

use crate::common;
use gpu::pipeline::inspect;
use std::process::{Command, Stdio};

/// The SPIR-V magic number (the SPIR-V specification, 2.3).
const SPIRV_MAGIC: u32 = 0x0723_0203;

fn settings() -> reference::RenderSettings {
    reference::RenderSettings {
        width: 4,
        height: 4,
        spp: 1,
        max_depth: 3,
        ..reference::RenderSettings::default()
    }
}

#[test]
fn gpu_every_kernel_built_is_inspected_with_its_spirv_and_statistics() {
    let ctx = common::own_gpu();
    let empty = inspect::kernels(&ctx, false).unwrap();
    assert!(empty.kernels.is_empty(), "a new device has built nothing");
    let scene = reference::load_scene("cornell").unwrap();
    let renderer =
        gpu::GpuRenderer::new(&ctx, &scene, gpu::RendererBuild::of(gpu::Variant::DEFAULT)).unwrap();
    renderer.render(&settings(), &|_, _| {}).unwrap();
    let built = ctx.pipelines_built();
    let first = inspect::kernels(&ctx, true).unwrap();
    // Inspecting builds nothing on the device that renders.
    assert_eq!(ctx.pipelines_built(), built);
    assert_eq!(
        first.kernels.len() as u64,
        built,
        "a kernel built and not inspected"
    );
    for k in &first.kernels {
        assert_eq!(k.spirv.first(), Some(&SPIRV_MAGIC), "{}", k.entry);
        println!("{}", k.line());
    }
    match &first.unavailable {
        Some(why) => println!("no statistics: {why}"),
        None => {
            let again = inspect::kernels(&ctx, false).unwrap();
            for (a, b) in first.kernels.iter().zip(&again.kernels) {
                assert!(!a.executables.is_empty(), "{}: no executable", a.entry);
                let stats = |k: &inspect::KernelReport| -> Vec<Vec<inspect::Statistic>> {
                    k.executables.iter().map(|e| e.statistics.clone()).collect()
                };
                assert_eq!(a.entry, b.entry);
                assert_eq!(stats(a), stats(b), "{}: statistics differ", a.entry);
                assert_eq!(a.spirv, b.spirv);
            }
        }
    }
}

/// The SPIR-V follows the kernel's runtime checks: wgpu's loop bounding
/// is in the checked kernel's and not in the trusted one's, and the
/// constants are applied (another value, other words).
#[test]
fn gpu_the_spirv_follows_the_checks_and_the_constants() {
    let source = "override SCALE: f32 = 1.0;\n\
        @group(0) @binding(0) var<storage, read_write> out: array<f32>;\n\
        @compute @workgroup_size(1)\n\
        fn main() {\n    var i = 0u;\n    loop {\n        if i >= 4u { break; }\n        out[i] = f32(i) * SCALE;\n        i = i + 1u;\n    }\n}\n";
    let words = |checks, scale: f64| {
        inspect::spirv(
            source,
            false,
            checks,
            "main",
            &[("SCALE".to_string(), scale.to_bits())],
            ash_api_1_3(),
            true,
        )
        .unwrap()
        .0
    };
    let trusted = words(gpu::Checks::Trusted, 1.0);
    let checked = words(gpu::Checks::Checked, 1.0);
    assert_eq!(trusted[0], SPIRV_MAGIC);
    assert_ne!(trusted, checked, "the loop bounding left no trace");
    assert!(checked.len() > trusted.len());
    assert_ne!(
        words(gpu::Checks::Trusted, 2.0),
        trusted,
        "the constant is not applied"
    );
    assert_eq!(words(gpu::Checks::Trusted, 1.0), trusted);
}

/// Vulkan 1.3's version number (`VK_MAKE_API_VERSION(0, 1, 3, 0)`).
fn ash_api_1_3() -> u32 {
    (1 << 22) | (3 << 12)
}

/// `twintrace render cornell` at 4x4, 1 spp on `backend`, with the
/// kernels dumped into `dir/kernels` and the image in `dir/img`.
fn render_dumping(dir: &std::path::Path, backend: &str, timings: bool) -> std::process::Output {
    let mut c = Command::new(common::twintrace_bin());
    c.args(["render", "cornell", "--backend", backend])
        .args(["--spp", "1", "--size", "4x4", "--dump-kernels"])
        .arg(dir.join("kernels"))
        .arg("-o")
        .arg(dir.join("img"))
        .stdin(Stdio::null());
    if timings {
        c.arg("--timings");
    }
    c.output().unwrap()
}

#[test]
fn gpu_render_dump_kernels_writes_each_kernel_and_timings_prints_it() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dir.path().join("kernels");
    let out = render_dumping(dir.path(), "gpu", true);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let mut files: Vec<_> = std::fs::read_dir(&dump)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let spv: Vec<_> = files
        .iter()
        .filter(|p| p.extension().unwrap() == "spv")
        .collect();
    let txt: Vec<_> = files
        .iter()
        .filter(|p| p.extension().unwrap() == "txt")
        .collect();
    assert!(!spv.is_empty(), "no kernel written: {files:?}");
    assert_eq!(spv.len(), txt.len(), "{files:?}");
    for p in &spv {
        let bytes = std::fs::read(p).unwrap();
        assert_eq!(&bytes[..4], &SPIRV_MAGIC.to_le_bytes(), "{}", p.display());
        assert_eq!(bytes.len() % 4, 0);
    }
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("timings: device 0: "))
        .collect();
    let kernels = lines.iter().filter(|l| l.contains(": kernel ")).count();
    let unavailable = lines.iter().any(|l| l.contains("cannot report"));
    assert!(
        kernels == spv.len() || (unavailable && kernels == 0),
        "{kernels} kernel lines for {} kernels:\n{stderr}",
        spv.len()
    );
}

#[test]
fn dump_kernels_on_the_cpu_reference_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = render_dumping(dir.path(), "cpu", false);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--dump-kernels"), "{stderr}");
    assert!(!dir.path().join("img.exr").exists());
}
