//! Bad scene input gives one clear error naming the file and the field,
//! never a panic.

use std::path::{Path, PathBuf};

fn write_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const HEADER: &str = r#""camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "materials": { "m": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] } }"#;

fn scene_with(objects: &str) -> String {
    format!("{{ {HEADER},\n  \"objects\": [ {objects} ] }}")
}

/// Loads `text` as a scene file and returns the error message.
fn error_of(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(dir.path(), "scene.json", text);
    match reference::load_scene(p.to_str().unwrap()) {
        Ok(_) => panic!("scene loaded but should have failed:\n{text}"),
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.contains("scene.json"),
                "error does not name the file: {msg}"
            );
            assert!(!msg.contains('\n'), "error is not one line: {msg}");
            msg
        }
    }
}

fn check(text: &str, expected: &[&str]) {
    let msg = error_of(text);
    for e in expected {
        assert!(msg.contains(e), "error `{msg}` lacks `{e}`");
    }
}

#[test]
fn valid_minimal_scene_loads() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(
        dir.path(),
        "ok.json",
        &scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" }"#),
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    assert_eq!(scene.spheres().len(), 1);
}

#[test]
fn malformed_json_reports_line_and_column() {
    check("{\n  \"objects\": [\n  }", &["scene.json:3:3"]);
}

#[test]
fn unknown_types_and_fields_are_named() {
    check(
        &scene_with(r#"{ "type": "cone", "material": "m" }"#),
        &["objects[0]", "unknown variant `cone`"],
    );
    check(
        &scene_with(
            r#"{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m", "colour": 1 }"#,
        ),
        &["objects[0]", "unknown field `colour`"],
    );
    check(
        &format!(
            "{{ {HEADER}, \"textures\": {{ \"t\": {{ \"type\": \"noise\" }} }}, \"objects\": [] }}"
        ),
        &["textures.t", "unknown variant `noise`"],
    );
    check(
        r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0] }, "materials": { "m": { "type": "hair" } }, "objects": [] }"#,
        &["materials.m", "unknown variant `hair`"],
    );
    check(
        r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0], "fov": 30 }, "objects": [] }"#,
        &["camera", "unknown field `fov`"],
    );
    check(
        r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0] }, "render": { "sampler": "halton" }, "objects": [] }"#,
        &["render.sampler", "unknown sampler \"halton\""],
    );
}

#[test]
fn wrong_value_types_are_named() {
    check(
        &scene_with(r#"{ "type": "sphere", "center": [0,0], "radius": 1, "material": "m" }"#),
        &["objects[0].center"],
    );
    check(
        &scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": "big", "material": "m" }"#),
        &["objects[0].radius"],
    );
    check(
        &scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": 1 }"#),
        &["missing field `material`"],
    );
}

#[test]
fn invalid_values_are_named() {
    check(
        &scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": 0, "material": "m" }"#),
        &["objects[0].radius"],
    );
    check(
        &scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": 1e39, "material": "m" }"#),
        &["objects[0]"],
    );
    check(
        &scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "nope" }"#),
        &["objects[0].material", "unknown material `nope`"],
    );
    check(
        &scene_with(
            r#"{ "type": "quad", "corner": [0,0,0], "u": [1,0,0], "v": [2,0,0], "material": "m" }"#,
        ),
        &["objects[0]", "degenerate"],
    );
    check(
        &scene_with(r#"{ "type": "box", "min": [0,0,0], "max": [1,0,1], "material": "m" }"#),
        &["objects[0].min/max"],
    );
    check(
        &scene_with(
            r#"{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m", "transform": { "scale": [1, 2, 1] } }"#,
        ),
        &["objects[0].transform", "uniform scale"],
    );
    check(
        &scene_with(
            r#"{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m", "transform": { "rotate_x": 10, "rotate": { "axis": [0,1,0], "angle": 5 } } }"#,
        ),
        &["objects[0].transform.rotate"],
    );
    check(
        r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0] }, "materials": { "m": { "type": "metal", "albedo": [1,1,1], "fuzz": 2 } },
            "objects": [ { "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" } ] }"#,
        &["materials.m.fuzz"],
    );
    check(
        r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0] }, "materials": { "m": { "type": "lambertian", "albedo": [-1,1,1] } },
            "objects": [ { "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" } ] }"#,
        &["materials.m.albedo", "negative"],
    );
    check(
        r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0] }, "materials": { "m": { "type": "lambertian", "albedo": "missing" } },
            "objects": [ { "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" } ] }"#,
        &["materials.m.albedo", "unknown texture `missing`"],
    );
}

#[test]
fn camera_and_render_errors_are_named() {
    let objects = r#""materials": { "m": { "type": "lambertian", "albedo": [0.5,0.5,0.5] } }, "objects": [ { "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" } ]"#;
    check(
        &format!(r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,5] }}, {objects} }}"#),
        &["camera.look_at"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0], "up": [0,0,1] }}, {objects} }}"#
        ),
        &["camera.up"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0], "vfov": 180 }}, {objects} }}"#
        ),
        &["camera.vfov"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0] }}, "render": {{ "width": 0 }}, {objects} }}"#
        ),
        &["render.width"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0] }}, "render": {{ "spp": 0 }}, {objects} }}"#
        ),
        &["render.spp"],
    );
    check(&format!(r#"{{ {objects} }}"#), &["camera"]);
    // An orthographic camera needs its window's height, and only it has one.
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0], "projection": "orthographic" }}, {objects} }}"#
        ),
        &["camera.height", "orthographic"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0], "height": 2 }}, {objects} }}"#
        ),
        &["camera.height", "perspective"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0], "projection": "orthographic", "height": -1 }}, {objects} }}"#
        ),
        &["camera.height", "positive"],
    );
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0], "projection": "fisheye" }}, {objects} }}"#
        ),
        &["fisheye"],
    );
}

/// A quad under an orthographic camera; `FILTER` is replaced.
const ORTHO_QUAD: &str = r#"{ FILTER "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0], "projection": "orthographic", "height": 3 },
  "materials": { "m": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] } },
  "objects": [ { "type": "quad", "corner": [-1, -1, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "m" } ] }"#;

#[test]
fn an_orthographic_camera_and_a_uv_checker_load_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(
        dir.path(),
        "ortho.json",
        r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0], "projection": "orthographic", "height": 3 },
  "textures": { "squares": { "type": "uv_checker", "scale": [4, 2], "even": [1, 1, 1], "odd": [0, 0, 0] } },
  "materials": { "m": { "type": "lambertian", "albedo": "squares" } },
  "objects": [ { "type": "quad", "corner": [-1, -1, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "m" } ] }"#,
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    assert_eq!(
        scene.camera_settings().projection,
        reference::camera::Projection::Orthographic { height: 3.0 }
    );
    let checker = scene
        .textures()
        .iter()
        .find_map(|t| match t {
            reference::texture::Texture::UvChecker { sampler, .. } => Some(sampler.transform),
            _ => None,
        })
        .expect("a uv checker");
    assert_eq!(checker, Some([4.0, 0.0, 0.0, 0.0, 2.0, 0.0]));
    // A pixel filter: Mitsuba's Gaussian, its width checked.
    let filtered = ORTHO_QUAD.replace(
        "FILTER",
        r#""filter": { "type": "gaussian", "stddev": 0.5 },"#,
    );
    let p = write_scene(dir.path(), "filtered.json", &filtered);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    assert_eq!(
        scene.filter(),
        reference::filter::PixelFilter::Gaussian { stddev: 0.5 }
    );
    assert!(scene.filter_table().is_some());
    check(
        &ORTHO_QUAD.replace(
            "FILTER",
            r#""filter": { "type": "gaussian", "stddev": 0 },"#,
        ),
        &["filter.stddev"],
    );
    check(
        &ORTHO_QUAD.replace("FILTER", r#""filter": { "type": "tent" },"#),
        &["tent"],
    );
    let nested = r#""textures": { "a": { "type": "uv_checker", "even": [1,1,1], "odd": [0,0,0] }, "b": { "type": "uv_checker", "even": "a", "odd": [0,0,0] } },
  "materials": { "m": { "type": "lambertian", "albedo": "b" } }"#;
    check(
        &format!(
            r#"{{ "camera": {{ "look_from": [0,0,5], "look_at": [0,0,0] }}, {nested}, "objects": [ {{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" }} ] }}"#
        ),
        &["checker"],
    );
}

#[test]
fn empty_scene_is_an_error() {
    check(
        &format!("{{ {HEADER}, \"objects\": [] }}"),
        &["objects", "no objects"],
    );
}

#[test]
fn missing_and_unreadable_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.json");
    let e = reference::load_scene(missing.to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nope.json") && e.contains("cannot read scene"),
        "{e}"
    );

    let bad_texture = r#"{ "camera": { "look_from": [0,0,5], "look_at": [0,0,0] }, "textures": { "t": { "type": "image", "path": "gone.png" } },
            "materials": { "m": { "type": "lambertian", "albedo": "t" } }, "objects": [ { "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" } ] }"#;
    let p = write_scene(dir.path(), "tex.json", bad_texture);
    let e = reference::load_scene(p.to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("gone.png") && e.contains("cannot read image"),
        "{e}"
    );

    // A file that is not an image.
    std::fs::write(dir.path().join("gone.png"), b"this is not a png").unwrap();
    let e = reference::load_scene(p.to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("gone.png"), "{e}");

    let mesh = scene_with(r#"{ "type": "mesh", "path": "nothing.glb", "material": "m" }"#);
    let p = write_scene(dir.path(), "mesh.json", &mesh);
    let e = reference::load_scene(p.to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("nothing.glb"), "{e}");
}

#[test]
fn unknown_builtin_is_reported() {
    let e = reference::load_scene("no-such-scene")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown built-in scene `no-such-scene`") && e.contains("cornell"),
        "{e}"
    );
}

/// Nothing but whitespace may follow the scene's JSON object; the error
/// gives the line and column of the first stray character.
#[test]
fn trailing_content_after_the_scene_is_an_error() {
    let ok = scene_with(r#"{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" }"#);
    let msg = error_of(&format!("{ok}\n }}}}}}"));
    assert!(
        msg.contains("scene.json:4:2") && msg.contains("trailing characters"),
        "{msg}"
    );
    // Trailing whitespace is fine.
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(dir.path(), "ok.json", &format!("{ok}\n \n"));
    assert!(reference::load_scene(p.to_str().unwrap()).is_ok());
}

/// Every image a document names is read at load time, used or not.
#[test]
fn an_image_texture_no_material_uses_must_still_exist() {
    let text = format!(
        r#"{{ {HEADER},
  "textures": {{ "wood": {{ "type": "image", "path": "no-such-wood.png" }} }},
  "objects": [ {{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" }} ] }}"#
    );
    check(
        &text,
        &["textures.wood.path", "no material uses", "no-such-wood.png"],
    );
}

/// `emission` on a material: its texture must exist and its colour be
/// non-negative; a `diffuse_light` has its own and takes no other field.
#[test]
fn a_bad_added_emission_names_the_material_and_field() {
    let with = |material: &str| {
        format!(
            r#"{{ "camera": {{ "look_from": [0, 0, 5], "look_at": [0, 0, 0] }},
  "materials": {{ "m": {material} }},
  "objects": [ {{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "m" }} ] }}"#
        )
    };
    check(
        &with(r#"{ "type": "ggx", "base_color": [0.5, 0.5, 0.5], "emission": "glow" }"#),
        &["materials.m.emission", "unknown texture `glow`"],
    );
    check(
        &with(r#"{ "type": "lambertian", "albedo": [0.5, 0.5, 0.5], "emission": [1, -1, 1] }"#),
        &["materials.m.emission", "negative"],
    );
    check(
        &with(r#"{ "type": "diffuse_light", "emission": [1, 1, 1], "albedo": [1, 1, 1] }"#),
        &["albedo"],
    );
}

/// Emission on any material is added to its BSDF, and its primitives are
/// lights; black emission is none.
#[test]
fn an_added_emission_loads_and_makes_its_primitives_lights() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "materials": {
    "glow": { "type": "ggx", "base_color": [0.8, 0.1, 0.1], "emission": [2, 1.5, 1] },
    "dark": { "type": "metal", "albedo": [0.5, 0.5, 0.5], "emission": [0, 0, 0] }
  },
  "objects": [
    { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "glow" },
    { "type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "dark" } ] }"#;
    let p = write_scene(dir.path(), "glow.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let m = |i: usize| scene.spheres()[i].material;
    assert!(matches!(
        scene.materials()[m(0) as usize],
        reference::material::Material::Ggx { .. }
    ));
    let e = scene.emission(m(0)).expect("the ggx emits");
    assert_eq!(
        scene.textures()[e as usize],
        reference::texture::Texture::Constant(glam::Vec3::new(2.0, 1.5, 1.0))
    );
    assert_eq!(scene.emission(m(1)), None);
    let lights = reference::light::LightSet::new(&scene);
    assert_eq!(lights.len(), 1);
    assert!(lights.pmf(0) > 0.0 && lights.pmf(1) == 0.0);
}

#[test]
fn a_conductor_loads_with_mitsubas_defaults_and_its_values_are_checked() {
    use glam::Vec3;
    use reference::material::Material;
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "materials": {
    "mirror": { "type": "conductor" },
    "gold": { "type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "specular": [0.9, 0.8, 0.7] } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "mirror" },
               { "type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "gold" } ] }"#;
    let p = write_scene(dir.path(), "scene.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let conductors: Vec<_> = scene
        .materials()
        .iter()
        .filter_map(|m| match *m {
            Material::Conductor { specular, eta, k } => Some((specular, eta, k)),
            _ => None,
        })
        .collect();
    assert_eq!(conductors.len(), 2, "{:?}", scene.materials());
    // Mitsuba's `material` "none": eta 0, k 1, a white tint.
    assert_eq!((conductors[0].1, conductors[0].2), (Vec3::ZERO, Vec3::ONE));
    assert_eq!(
        scene.textures()[conductors[0].0 as usize],
        reference::texture::Texture::Constant(Vec3::ONE)
    );
    assert_eq!(conductors[1].1, Vec3::new(0.143, 0.374, 1.442));
    check(
        &text.replace("[3.983, 2.385, 1.603]", "[3.983, -2.385, 1.603]"),
        &["materials.gold", "k"],
    );
}

#[test]
fn a_rough_conductor_loads_with_mitsubas_defaults_and_a_textured_roughness() {
    use glam::Vec3;
    use reference::material::Material;
    use reference::microfacet::distribution;
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "textures": { "bumps": { "type": "checker", "even": [0.05, 0.05, 0.05], "odd": [0.4, 0.4, 0.4] } },
  "materials": {
    "brushed": { "type": "rough_conductor" },
    "gold": { "type": "rough_conductor", "distribution": "ggx", "alpha": "bumps", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603] } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "brushed" },
               { "type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "gold" } ] }"#;
    let p = write_scene(dir.path(), "scene.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let rough: Vec<_> = scene
        .materials()
        .iter()
        .filter_map(|m| match *m {
            Material::RoughConductor {
                distribution,
                alpha,
                eta,
                k,
                ..
            } => Some((distribution, alpha, eta, k)),
            _ => None,
        })
        .collect();
    assert_eq!(rough.len(), 2, "{:?}", scene.materials());
    // Mitsuba's defaults: Beckmann, alpha 0.1, eta 0, k 1.
    assert_eq!(rough[0].0, distribution::BECKMANN);
    assert_eq!(
        scene.textures()[rough[0].1 as usize],
        reference::texture::Texture::Constant(Vec3::splat(0.1))
    );
    assert_eq!((rough[0].2, rough[0].3), (Vec3::ZERO, Vec3::ONE));
    assert_eq!(rough[1].0, distribution::GGX);
    assert!(matches!(
        scene.textures()[rough[1].1 as usize],
        reference::texture::Texture::Checker { .. }
    ));
    check(
        &text.replace(r#""distribution": "ggx""#, r#""distribution": "phong""#),
        &["materials.gold", "phong", "ggx", "beckmann"],
    );
    check(
        &text.replace(r#""alpha": "bumps""#, r#""alpha": "nowhere""#),
        &["nowhere"],
    );
}

#[test]
fn a_smooth_dielectric_loads_with_white_tints_and_its_index_is_checked() {
    use glam::Vec3;
    use reference::material::Material;
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "materials": { "glass": { "type": "smooth_dielectric", "eta": 1.5, "transmittance": [0.9, 0.95, 1.0] } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "glass" } ] }"#;
    let p = write_scene(dir.path(), "scene.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let Material::SmoothDielectric {
        eta,
        reflectance,
        transmittance,
    } = scene.materials()[0]
    else {
        panic!("{:?}", scene.materials())
    };
    assert_eq!(eta, 1.5);
    let constant = |t: u32| scene.textures()[t as usize];
    assert_eq!(
        constant(reflectance),
        reference::texture::Texture::Constant(Vec3::ONE)
    );
    assert_eq!(
        constant(transmittance),
        reference::texture::Texture::Constant(Vec3::new(0.9, 0.95, 1.0))
    );
    check(&text.replace("1.5", "-1.5"), &["materials.glass", "eta"]);
    // The thin sheet takes the same fields.
    let thin = text.replace("smooth_dielectric", "thin_dielectric");
    let p = write_scene(dir.path(), "thin.json", &thin);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    assert!(
        matches!(scene.materials()[0], Material::ThinDielectric { eta, .. } if eta == 1.5),
        "{:?}",
        scene.materials()
    );
}

#[test]
fn a_rough_dielectric_loads_with_mitsubas_defaults_and_a_textured_roughness() {
    use glam::Vec3;
    use reference::material::Material;
    use reference::microfacet::distribution;
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "textures": { "bumps": { "type": "checker", "even": [0.05, 0.05, 0.05], "odd": [0.4, 0.4, 0.4] } },
  "materials": {
    "frosted": { "type": "rough_dielectric", "eta": 1.5 },
    "tinted": { "type": "rough_dielectric", "distribution": "ggx", "alpha": "bumps", "eta": 1.33, "transmittance": [0.9, 0.8, 0.7] } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "frosted" },
               { "type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "tinted" } ] }"#;
    let p = write_scene(dir.path(), "scene.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let rough: Vec<_> = scene
        .materials()
        .iter()
        .filter_map(|m| match *m {
            Material::RoughDielectric {
                distribution,
                alpha,
                eta,
                reflectance,
                transmittance,
                ..
            } => Some((distribution, alpha, eta, reflectance, transmittance)),
            _ => None,
        })
        .collect();
    assert_eq!(rough.len(), 2, "{:?}", scene.materials());
    let texture = |i: u32| scene.textures()[i as usize];
    // Mitsuba's defaults: Beckmann, alpha 0.1, white tints.
    assert_eq!(rough[0].0, distribution::BECKMANN);
    assert_eq!(
        texture(rough[0].1),
        reference::texture::Texture::Constant(Vec3::splat(0.1))
    );
    assert_eq!(rough[0].2, 1.5);
    assert_eq!(
        texture(rough[0].3),
        reference::texture::Texture::Constant(Vec3::ONE)
    );
    assert_eq!(rough[1].0, distribution::GGX);
    assert!(matches!(
        texture(rough[1].1),
        reference::texture::Texture::Checker { .. }
    ));
    assert_eq!(
        texture(rough[1].4),
        reference::texture::Texture::Constant(Vec3::new(0.9, 0.8, 0.7))
    );
    check(
        &text.replace(r#""eta": 1.33"#, r#""eta": -1.33"#),
        &["materials.tinted", "eta", "-1.33"],
    );
    check(
        &text.replace(
            r#""type": "rough_dielectric", "eta": 1.5"#,
            r#""type": "rough_dielectric""#,
        ),
        &["materials.frosted", "eta"],
    );
}

#[test]
fn a_plastic_loads_with_its_sampling_weight_and_refuses_a_coat_its_model_cannot_hold() {
    use glam::Vec3;
    use reference::material::Material;
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "textures": { "tiles": { "type": "checker", "even": [0.1, 0.2, 0.3], "odd": [0.5, 0.6, 0.7] } },
  "materials": {
    "shiny": { "type": "plastic", "diffuse": [0.1, 0.27, 0.36], "eta": 1.49 },
    "tiled": { "type": "plastic", "diffuse": "tiles", "specular": [0.9, 0.8, 0.7], "eta": 1.9, "nonlinear": true } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "shiny" },
               { "type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "tiled" } ] }"#;
    let p = write_scene(dir.path(), "scene.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let plastics: Vec<_> = scene
        .materials()
        .iter()
        .filter_map(|m| match *m {
            Material::Plastic {
                specular,
                eta,
                nonlinear,
                specular_weight,
                ..
            } => Some((specular, eta, nonlinear, specular_weight)),
            _ => None,
        })
        .collect();
    assert_eq!(plastics.len(), 2, "{:?}", scene.materials());
    // Mitsuba's weight s / (d + s) of the textures' means: a white coat
    // over a mean diffuse of 0.73 / 3; a tint of mean 0.8 over the
    // checker's mean 0.4.
    let d = (0.1f32 + 0.27 + 0.36) / 3.0;
    assert!(
        (plastics[0].3 - 1.0 / (d + 1.0)).abs() < 1e-6,
        "{plastics:?}"
    );
    assert!((plastics[1].3 - 0.8 / 1.2).abs() < 1e-6, "{plastics:?}");
    assert_eq!(
        scene.textures()[plastics[0].0 as usize],
        reference::texture::Texture::Constant(Vec3::ONE)
    );
    assert_eq!((plastics[0].1, plastics[0].2), (1.49, false));
    assert_eq!((plastics[1].1, plastics[1].2), (1.9, true));
    check(
        &text.replace(r#""eta": 1.9"#, r#""eta": 4.5"#),
        &["materials.tiled", "eta", "4.5", "3.9"],
    );
    check(
        &text.replace(r#""eta": 1.49"#, r#""eta": 0"#),
        &["materials.shiny", "eta"],
    );
    check(
        &text.replace(r#""diffuse": [0.1, 0.27, 0.36], "#, ""),
        &["materials.shiny", "diffuse"],
    );
}

#[test]
fn a_rough_plastic_loads_its_coats_tables_once_and_refuses_a_coat_that_is_no_interface() {
    use reference::material::Material;
    use reference::microfacet::distribution;
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "materials": {
    "satin": { "type": "rough_plastic", "diffuse": [0.1, 0.27, 0.36], "eta": 1.49 },
    "same_coat": { "type": "rough_plastic", "diffuse": [0.5, 0.5, 0.5], "eta": 1.49, "nonlinear": true },
    "glossy": { "type": "rough_plastic", "distribution": "ggx", "alpha": 0.05, "diffuse": [0.8, 0.3, 0.2], "specular": [0.9, 0.8, 0.7], "eta": 1.9 } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "satin" },
               { "type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "same_coat" },
               { "type": "sphere", "center": [6, 0, 0], "radius": 1, "material": "glossy" } ] }"#;
    let p = write_scene(dir.path(), "scene.json", text);
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let rough: Vec<_> = scene
        .materials()
        .iter()
        .filter_map(|m| match *m {
            Material::RoughPlastic {
                distribution,
                alpha,
                transmittance,
                internal,
                ..
            } => Some((distribution, alpha, transmittance, internal)),
            _ => None,
        })
        .collect();
    assert_eq!(rough.len(), 3, "{:?}", scene.materials());
    // Mitsuba's defaults: Beckmann, alpha 0.1; one table for one coat.
    assert_eq!((rough[0].0, rough[0].1), (distribution::BECKMANN, 0.1));
    assert_eq!(rough[0].2, rough[1].2);
    assert_eq!(rough[0].3, rough[1].3);
    assert_ne!(rough[0].2, rough[2].2);
    assert_eq!((rough[2].0, rough[2].1), (distribution::GGX, 0.05));
    assert_eq!(scene.images().len(), 2);
    check(
        &text.replace(r#""eta": 1.9"#, r#""eta": 1.0"#),
        &["materials.glossy", "eta", "differ"],
    );
    check(
        &text.replace(r#""alpha": 0.05"#, r#""alpha": -0.05"#),
        &["materials.glossy", "alpha"],
    );
}

/// A scene whose sphere uses material `a` of `materials` (JSON members).
fn wrapped_scene(materials: &str) -> String {
    format!(
        r#"{{ "camera": {{ "look_from": [0, 0, 5], "look_at": [0, 0, 0] }},
  "materials": {{ {materials} }},
  "objects": [ {{ "type": "sphere", "center": [0,0,0], "radius": 1, "material": "a" }} ] }}"#
    )
}

#[test]
fn principled_materials_that_cannot_be_are_named() {
    for (material, says) in [
        (
            r#""a": { "type": "principled", "eta": 1.5, "specular": 0.5 }"#,
            &["materials.a", "eta or specular, not both"][..],
        ),
        (
            r#""a": { "type": "principled", "specular": -1 }"#,
            &["materials.a", "specular"],
        ),
        (
            r#""a": { "type": "principled", "metallic": "nope" }"#,
            &["materials.a", "metallic", "nope"],
        ),
        (
            r#""a": { "type": "principled", "eta": 0 }"#,
            &["materials.a", "eta"],
        ),
        (
            r#""a": { "type": "principled", "shine": 1 }"#,
            &["materials", "shine"],
        ),
        (
            r#""a": { "type": "principled", "diff_trans": 1 }"#,
            &[
                "materials.a",
                "diff_trans",
                "a principled material has no diff_trans",
            ],
        ),
        (
            r#""a": { "type": "principled_thin", "clearcoat": 0.5 }"#,
            &[
                "materials.a",
                "clearcoat",
                "a principled_thin material has no clearcoat",
            ],
        ),
        (
            r#""a": { "type": "principled_thin", "specular": 0.5 }"#,
            &["materials.a", "specular"],
        ),
        (
            r#""a": { "type": "principled_thin", "eta": -1 }"#,
            &["materials.a", "eta"],
        ),
    ] {
        check(&wrapped_scene(material), says);
    }
    // Given, a principled material loads with its lobes; 0 turns one off.
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(
        dir.path(),
        "p.json",
        &wrapped_scene(
            r#""a": { "type": "principled", "base_color": [0.2, 0.4, 0.6], "metallic": 0.5, "spec_trans": 0, "clearcoat": 0.3, "eta": 1.33 }"#,
        ),
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let m = scene.spheres()[0].material as usize;
    let reference::material::Material::Principled { lobes, eta, .. } = scene.materials()[m] else {
        panic!("{:?}", scene.materials()[m]);
    };
    assert!(lobes.metallic.is_some() && lobes.clearcoat.is_some());
    assert!(lobes.clearcoat_gloss.is_some());
    assert_eq!(lobes.spec_trans, None);
    assert_eq!(eta, 1.33);
    // A thin sheet: its diffuse transmission, its index 1.5 by default.
    let p = write_scene(
        dir.path(),
        "t.json",
        &wrapped_scene(
            r#""a": { "type": "principled_thin", "base_color": [0.2, 0.4, 0.6], "diff_trans": 0.8, "sheen": 0 }"#,
        ),
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let m = scene.spheres()[0].material as usize;
    let reference::material::Material::Principled {
        lobes, eta, thin, ..
    } = scene.materials()[m]
    else {
        panic!("{:?}", scene.materials()[m]);
    };
    assert!(thin && lobes.diff_trans.is_some() && lobes.sheen.is_none());
    assert_eq!(eta, 1.5);
}

#[test]
fn blends_that_cannot_be_are_named() {
    let lambertian = r#""c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#;
    for (materials, says) in [
        (
            format!(r#""a": {{ "type": "blend", "materials": ["a", "c"] }}, {lambertian}"#),
            &["materials.a", "loop: a -> a"][..],
        ),
        (
            format!(
                r#""a": {{ "type": "blend", "materials": ["c", "m"] }}, "m": {{ "type": "mask", "material": "c" }}, {lambertian}"#
            ),
            &["materials.a", "materials[1]", "`m` has a mask"],
        ),
        (
            format!(
                r#""a": {{ "type": "blend", "materials": ["l", "c"] }}, "l": {{ "type": "diffuse_light", "emission": [1, 1, 1] }}, {lambertian}"#
            ),
            &["materials.a", "materials[0]", "light"],
        ),
        (
            format!(
                r#""a": {{ "type": "blend", "materials": ["c", "e"] }}, "e": {{ "type": "lambertian", "albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1] }}, {lambertian}"#
            ),
            &["materials.a", "materials[1]", "emits"],
        ),
        (
            format!(r#""a": {{ "type": "blend", "materials": ["c"] }}, {lambertian}"#),
            &["materials"],
        ),
        (
            format!(
                r#""a": {{ "type": "one_sided", "material": "b" }}, "b": {{ "type": "blend", "materials": ["c", "c"] }}, {lambertian}"#
            ),
            &["materials.a", "is a blend"],
        ),
        (
            format!(
                r#""a": {{ "type": "blend", "materials": ["c", "c"], "weight": "t" }}, {lambertian}"#
            ),
            &["materials.a.weight"],
        ),
    ] {
        check(&wrapped_scene(&materials), says);
    }
}

#[test]
fn masks_and_one_sided_materials_that_cannot_be_are_named() {
    // Wrappers that name each other: a loop, not a stack overflow.
    check(
        &wrapped_scene(
            r#""a": { "type": "mask", "material": "b" }, "b": { "type": "one_sided", "material": "a" }"#,
        ),
        &["materials.a", "loop: a -> b -> a"],
    );
    check(
        &wrapped_scene(
            r#""a": { "type": "mask", "material": "b" }, "b": { "type": "mask", "material": "c" },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
        &["materials.a", "one mask"],
    );
    check(
        &wrapped_scene(
            r#""a": { "type": "one_sided", "material": "l" }, "l": { "type": "diffuse_light", "emission": [1, 1, 1] }"#,
        ),
        &["materials.a", "light"],
    );
    check(
        &wrapped_scene(r#""a": { "type": "mask", "material": "nope" }"#),
        &["materials.a.material", "unknown material `nope`"],
    );
    check(
        &wrapped_scene(
            r#""a": { "type": "mask", "material": "c", "opacity": "t" },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
        &["materials.a.opacity"],
    );
    // A normal map goes inside a mask, as Mitsuba's normalmap holds the
    // BSDF a mask wraps.
    check(
        &wrapped_scene(
            r#""a": { "type": "normal_mapped", "material": "b", "normal_map": [0.5, 0.5, 1] },
            "b": { "type": "mask", "material": "c" }, "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
        &["materials.a", "put the normal map inside the mask"],
    );
    check(
        &wrapped_scene(
            r#""a": { "type": "normal_mapped", "material": "c", "normal_map": "t" },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
        &["materials.a.normal_map"],
    );
}

#[test]
fn a_bump_map_reads_its_height_times_its_scale_and_refuses_what_has_no_gradient() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(
        dir.path(),
        "scene.json",
        &wrapped_scene(
            r#""a": { "type": "bump_mapped", "material": "c", "bump_map": [0.25, 0.25, 0.25], "scale": 2 },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let w = scene.wrappers(scene.spheres()[0].material);
    assert!(
        w.bump_map && !w.normal_map_mirrored && !w.one_sided,
        "{w:?}"
    );
    assert_eq!(
        w.normal_map.map(|t| scene.textures()[t as usize]),
        Some(reference::texture::Texture::Constant(glam::Vec3::splat(
            0.5
        )))
    );
    let with_checker = |materials: &str| {
        wrapped_scene(materials).replacen(
            r#""materials""#,
            r#""textures": { "t": { "type": "checker", "scale": 4.0, "even": [0.2, 0.2, 0.2], "odd": [0.9, 0.9, 0.9] } }, "materials""#,
            1,
        )
    };
    check(
        &with_checker(
            r#""a": { "type": "bump_mapped", "material": "c", "bump_map": "t" },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
        &[
            "materials.a.bump_map",
            "an image read through the first uv set, or a constant",
        ],
    );
    check(
        &wrapped_scene(
            r#""a": { "type": "bump_mapped", "material": "c", "bump_map": [0.5, 0.5, 0.5], "scale": -1 },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }"#,
        ),
        &[
            "materials.a.bump_map",
            "-1 is not a finite number of at least 0",
        ],
    );
}

#[test]
fn a_mask_copies_the_material_it_wraps_with_its_emission() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_scene(
        dir.path(),
        "scene.json",
        &wrapped_scene(
            r#""a": { "type": "mask", "material": "c", "opacity": 0.25 },
            "c": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5], "emission": [2, 2, 2] }"#,
        ),
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let m = scene.spheres()[0].material;
    let w = scene.wrappers(m);
    assert!(!w.one_sided);
    let opacity = w.opacity.map(|t| scene.textures()[t as usize]);
    assert_eq!(
        opacity,
        Some(reference::texture::Texture::Constant(glam::Vec3::splat(
            0.25
        )))
    );
    assert!(matches!(
        scene.materials()[m as usize],
        reference::material::Material::Lambertian { .. }
    ));
    assert!(scene.added_emission(m).is_some());
}
