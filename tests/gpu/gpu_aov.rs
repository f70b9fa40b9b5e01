//! First-hit layers (AOVs) on the GPU: `aov_main` is the reference's twin
//! (`twintrace::twins::aov`, also run by `twintrace selftest`), kernels
//! with plausible defects fail that twin, and `render --aov` on the GPU
//! writes the layers.

use crate::common;
use twintrace::twins::aov as twin;

#[test]
fn the_aov_kernel_is_the_references_twin() {
    match twin::all_scenes(common::gpu()) {
        Ok(summary) => println!("{summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn an_aov_kernel_with_a_defect_fails_the_twin() {
    let program = gpu::aov::aov_source();
    let scenes = twin::scenes().unwrap();
    let scene = |name: &str| &scenes.iter().find(|(n, _)| n == name).unwrap().1;
    for (what, from, to, on) in [
        (
            "the vertex colour left out of the albedo",
            "        base *= si.color;\n",
            "",
            "gltf-materials",
        ),
        (
            "the normal not turned toward the ray on back faces",
            "select(-si.shading_normal, si.shading_normal, si.front_face)",
            "si.shading_normal",
            "cornell",
        ),
        (
            "the geometric normal for the shading normal",
            "select(-si.shading_normal, si.shading_normal, si.front_face)",
            "select(-si.geometric_normal, si.geometric_normal, si.front_face)",
            "gltf-materials",
        ),
        (
            "the range's first sample ignored",
            "camera_ray(gid.x, y, params.sample_start + i)",
            "camera_ray(gid.x, y, i)",
            "cornell",
        ),
        (
            "the hit's depth taken as the point's distance from the origin",
            "n, hit.t, si.p);",
            "n, length(si.p), si.p);",
            "rtow-final",
        ),
    ] {
        assert_eq!(program.matches(from).count(), 1, "{what}");
        let mutant = program.replace(from, to);
        let e = twin::scene_with_program(common::gpu(), on, scene(on), &mutant)
            .expect_err(&format!("{what} passed the AOV twin"));
        println!("{what} caught: {}", &e[..e.len().min(300)]);
    }
}

#[test]
fn render_on_the_gpu_writes_the_layers() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g");
    let o = std::process::Command::new(common::twintrace_bin())
        .args([
            "render",
            "cornell",
            "--backend",
            "gpu",
            "--size",
            "12x9",
            "--spp",
            "3",
        ])
        .args(["--aov", "all", "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (image, extras) =
        twintrace::image_io::read_exr_with_extras(&out.with_extension("exr")).unwrap();
    for name in ["albedo.R", "normal.X", "depth.Z", "position.Y"] {
        let c = extras
            .f32_channel(name)
            .unwrap_or_else(|| panic!("no {name}"));
        assert_eq!(c.len(), image.mean.len());
    }
    // The box fills the middle of the view; the corners look past it.
    let depth = extras.f32_channel("depth.Z").unwrap();
    assert!(depth.iter().all(|d| *d > 0.0), "{depth:?}");
    assert!(depth[4 * 12 + 6].is_finite(), "{depth:?}");
    assert!(extras
        .channel("samples.count")
        .unwrap()
        .iter()
        .all(|&n| n == 3));
}
