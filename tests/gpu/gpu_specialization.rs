//! The specialized render kernel (built without the code of the features a
//! scene does not use, `gpu::features`) renders every fixture and built-in
//! scene as the general kernel does (`twintrace::twins::film_words`'s
//! rule), with either estimator
//! (`twintrace::twins::specialization`, also run by `twintrace selftest`).
//! A kernel built without a feature its scene uses must fail that
//! comparison (its samples are poisoned), so the gate can fail.

use crate::common;
use gpu::features::{feature, Features};
use reference::integrator::Integrator;
use twintrace::twins::film_words::counts;
use twintrace::twins::specialization::{all_scenes, film_bits, gate_specs, scene_specs};

/// On a software adapter (CI) the scenes that each bring a feature the
/// earlier ones lack (`gate_specs`), against the kernel of every gate
/// scene's features (`gate_oracle_features`); every scene against the
/// general kernel on hardware (the H100 suite) and in `selftest` there.
#[test]
fn specialized_kernels_render_every_scene_as_the_general_kernel() {
    let specs = scene_specs().unwrap();
    assert!(specs.len() >= 16, "found only {} scenes", specs.len());
    // The judged scenes use every feature any scene uses.
    let ctx = common::gpu();
    let used = |scenes: &mut dyn Iterator<Item = reference::Scene>| {
        scenes.fold(0, |bits, s| bits | Features::of(&s).0)
    };
    let all = used(&mut specs.iter().map(|s| reference::load_scene(s).unwrap()));
    let judged = gate_specs(ctx).unwrap();
    assert_eq!(
        used(&mut judged.iter().map(|(_, s)| s.clone())),
        all,
        "a feature no judged scene uses"
    );
    match all_scenes(ctx) {
        Ok(summary) => println!("{summary}"),
        Err(e) => panic!("{e}"),
    }
}

/// The gate's mutants, and its coverage: the kernel built without a
/// feature its scene uses renders differently from the scene's own
/// kernel, which the gate above holds to the general one (the samples
/// that reach that feature's code are poisoned). So the
/// comparison can fail, and its small renders reach the features each
/// scene has: on hardware every feature of every scene; on a software
/// adapter, where each mutant is a compile, every feature on the scene
/// with the fewest features that uses it (`full_gates`: the same
/// renders reach the same code on any adapter, and the H100 suite runs
/// every scene).
#[test]
fn a_kernel_without_a_feature_its_scene_uses_is_caught() {
    let ctx = common::gpu();
    let every_scene = twintrace::twins::full_gates(ctx);
    let (mut mutants, mut caught, mut used) = (0, 0u64, 0u64);
    let mut scenes: Vec<_> = scene_specs()
        .unwrap()
        .into_iter()
        .map(|spec| {
            let scene = reference::load_scene(&spec).unwrap();
            (spec, scene)
        })
        .collect();
    if !every_scene {
        // Each feature left out of the scene with the fewest features that
        // uses it: the smallest kernels (a compile each) that reach it.
        scenes.sort_by_key(|(_, scene)| Features::of(scene).0.count_ones());
    }
    for (spec, scene) in scenes {
        let features = Features::of(&scene);
        used |= features.0;
        let mut own = None;
        for &(name, bit) in feature::NAMED {
            if !features.contains(bit) || (!every_scene && caught & bit != 0) {
                continue;
            }
            let own = own
                .get_or_insert_with(|| film_bits(ctx, &scene, Integrator::Mis, features).unwrap());
            let without =
                film_bits(ctx, &scene, Integrator::Mis, Features(features.0 & !bit)).unwrap();
            let (_, rejected) = counts(&without);
            assert!(
                *own != without && rejected > 0,
                "{spec}: the kernel without {name} rendered as the scene's own"
            );
            caught |= bit;
            mutants += 1;
        }
    }
    // Every feature some scene uses is left out somewhere; on hardware,
    // each of the 16 scenes has a primitive kind, a surface material and
    // a background: at least 3 features, 48 mutants.
    assert_eq!(
        caught,
        used,
        "features never left out: {:#x}",
        used & !caught
    );
    if every_scene {
        assert!(mutants >= 48, "only {mutants} mutants");
    }
    println!(
        "{mutants} mutants, {} features left out",
        caught.count_ones()
    );
}

/// The kernel selecting code by chains of tag tests renders every scene as
/// the switch does (`twintrace::twins::dispatch`); chains that send a kind
/// to another's code, or lose one, are caught as film differences.
#[test]
fn branch_dispatch_renders_every_scene_as_the_switch() {
    match twintrace::twins::dispatch::all_scenes(common::gpu()) {
        Ok(summary) => println!("{summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn branch_dispatch_mutants_are_caught() {
    use twintrace::twins::dispatch::compare_scene;
    let ctx = common::gpu();
    let program = gpu::shader::render_source();
    // (slip, WGSL replaced, its replacement, scene)
    let mutants = [
        (
            "metal sent to the dielectric's code",
            "if m.tag == MATERIAL_METAL {\n            return scatter_metal(m, ray_dir, tx, n, ng, u);",
            "if m.tag == MATERIAL_METAL {\n            return scatter_dielectric(m, ray_dir, si, n, u);",
            "rtow-final",
        ),
        (
            "quads fall through to the end of the chain",
            "if p.tag == PRIMITIVE_QUAD {\n            return intersect_quad_record(p.index, ray, t_min, t_max);\n        }",
            "",
            "cornell",
        ),
    ];
    for (slip, from, to, spec) in mutants {
        assert_eq!(
            program.matches(from).count(),
            1,
            "{slip}: `{from}` not found once"
        );
        let scene = reference::load_scene(spec).unwrap();
        let mutant = program.replace(from, to);
        let e = compare_scene(ctx, spec, &scene, Integrator::Bsdf, &mutant).expect_err(slip);
        assert!(e.contains(": pixel "), "{slip}: not a film difference: {e}");
        println!("{slip}: {e}");
    }
}

/// The trusted kernels (wgpu's loop bounding left out, the default) render
/// word for word as the checked ones (`twintrace::twins::checks`) on scenes
/// that run every loop of the kernel: the walk and the path (all), the
/// light table's bisection (cornell's lamp, MIS), the environment's CDF
/// bisections (skybox). Every scene is compared by `selftest` and the
/// twin checks (`checks::all_scenes`: 142 s on lavapipe, too long for CI).
#[test]
fn trusted_kernel_renders_as_the_checked() {
    let skybox = twintrace::compare::gate::fixture_scene("skybox.json");
    let specs = ["cornell", "rtow-final", &skybox];
    match twintrace::twins::checks::some_scenes(common::gpu(), &specs) {
        Ok(summary) => println!("{summary}"),
        Err(e) => panic!("{e}"),
    }
}

/// The trusted twin sees a walk that ends early: the binary walk dropping
/// the far child it should stack.
#[test]
fn trusted_kernel_mutant_is_caught() {
    let ctx = common::gpu();
    let program = gpu::shader::render_source();
    let from = "                stack[sp] = far;\n                sp += 1u;\n";
    assert_eq!(program.matches(from).count(), 1, "`{from}` not found once");
    let mutant = program.replace(from, "");
    let scene = reference::load_scene("cornell").unwrap();
    let e =
        twintrace::twins::checks::compare_scene(ctx, "cornell", &scene, Integrator::Bsdf, &mutant)
            .expect_err("the walk without its far children rendered as the checked kernel");
    assert!(
        e.contains("differs from the checked"),
        "not a film difference: {e}"
    );
    println!("{e}");
}
