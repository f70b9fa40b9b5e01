//! Tidy: rules of the source tree that keep the twins paired, checked on
//! the files themselves (rust-analyzer's tidy tests are the model). Each
//! rule says what it protects; each has a mutation test below showing it
//! fails on the defect it is for.
//!
//! - Every WGSL function of `shaders/<m>.wgsl` has its Rust twin in
//!   `reference/src/<m>.rs` (or `reference/src/<m>/`, a module split by
//!   concern) under the same name (a `snake_type_method`
//!   name twins `impl SnakeType { fn method }` or `mod snake_type { fn
//!   method }`), or is listed below as GPU-only or renamed, with why.
//! - Every `switch` on a tag lists every tag of its family as a `case`
//!   (the families are generated from Rust into shaders/generated.wgsl),
//!   and its `default` calls `poison()`: a tag added in Rust and not in
//!   WGSL fails here, and at run time is counted as non-finite, never
//!   absorbed or taken for another tag.
//! - WGSL bodies carry no magic numbers: a float literal other than a small
//!   integer or 0.5 is a named constant, generated from Rust or declared
//!   GPU-only at module scope.
//! - shaders/ mirrors reference/src file for file.
//! - Files the sources and docs name by path exist, and nothing cites a
//!   file outside the repository.
//! - No file of any crate's sources (gpu/src, readers/src, xtask/src,
//!   src, reference/src) uses another that uses it back (the crates are
//!   built in layers; test code left out).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The source of reference module `module`: `reference/src/<module>.rs`,
/// or, for a module split by concern, every file of `reference/src/<module>/`
/// (in name order). `None` if there is neither.
fn reference_module(module: &str) -> Option<String> {
    let file = root().join(format!("reference/src/{module}.rs"));
    if file.exists() {
        return Some(read(&format!("reference/src/{module}.rs")));
    }
    let mut files: Vec<PathBuf> = fs::read_dir(root().join(format!("reference/src/{module}")))
        .ok()?
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect();
    files.sort();
    Some(
        files
            .iter()
            .map(|p| fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
            .collect(),
    )
}

/// WGSL functions with no Rust function of the same name, and why.
const GPU_ONLY: &[(&str, &str)] = &[
    (
        "env_to_map",
        "Envmap::to_map applied to a direction from the per-dispatch parameters' rows (the reference multiplies by its Mat3)",
    ),
    (
        "env_from_map",
        "the transpose of env_to_map (the reference's EnvLight::sample multiplies by to_map's transpose)",
    ),
    (
        "safe_inv_dir",
        "WGSL min/max are undefined on NaN; the reference divides by zero",
    ),
    (
        "bvh_intersect_binary",
        "the walk of the binary node array (the reference walks its 8-wide collapse of the same tree in Bvh::intersect)",
    ),
    (
        "bvh_intersect_wide",
        "the GPU's four-wide walk (gpu::traversal; the reference's collapse is 8-wide, Bvh::intersect)",
    ),
    ("scatter_lambertian", "the Lambertian arm of material::scatter's match"),
    ("scatter_metal", "the metal arm of material::scatter's match"),
    ("scatter_conductor", "the conductor arm of material::scatter's match"),
    (
        "scatter_rough_conductor",
        "the rough conductor arm of material::scatter's match",
    ),
    (
        "scatter_smooth_dielectric",
        "the smooth dielectric arm of material::scatter's match",
    ),
    (
        "scatter_rough_dielectric",
        "the rough dielectric arm of material::scatter's match",
    ),
    (
        "rough_dielectric_eval",
        "the rough dielectric arm of material::bsdf_eval's match",
    ),
    ("scatter_plastic", "the plastic arm of material::scatter's match"),
    ("plastic_eval", "the plastic arm of material::bsdf_eval's match"),
    (
        "scatter_rough_plastic",
        "the rough plastic arm of material::scatter's match",
    ),
    (
        "scatter_thin_dielectric",
        "the thin dielectric arm of material::scatter's match",
    ),
    ("scatter_dielectric", "the dielectric arm of material::scatter's match"),
    ("scatter_ggx", "the GGX arm of material::scatter's match"),
    (
        "scatter_principled",
        "the principled arm of material::scatter's match",
    ),
    (
        "principled_texture",
        "the principled parameters' texture ids by slot, for material_textures' one lookup (the reference's Material::Principled names them)",
    ),
    (
        "intersect_sphere_record",
        "the sphere arm of the shape match in LeafPrim::intersect",
    ),
    (
        "intersect_quad_record",
        "the quad arm of the shape match in LeafPrim::intersect",
    ),
    (
        "intersect_triangle_record",
        "the triangle arm of the shape match in LeafPrim::intersect",
    ),
    (
        "intersect_quadric_record",
        "the quadric arm of the shape match in LeafPrim::intersect (Objects::intersect)",
    ),
    (
        "intersect_sdf_record",
        "the grid cell arm of the shape match in LeafPrim::intersect (Objects::intersect)",
    ),
    (
        "instance_node",
        "a group's node read from texels as reference::bvh::BvhNode holds it (the reference reads the node itself)",
    ),
    (
        "quadric_record",
        "a quadrics' record read into the maps reference::shapes::Quadric holds",
    ),
    (
        "sdf_grid_record",
        "a grid's record (a quadrics' record of kind QUADRIC_SDF) read into what reference::sdf::SdfGrid holds",
    ),
    (
        "sdf_cell_record",
        "a grid cell's record in texels read into what reference::sdf::SdfVoxel holds",
    ),
    (
        "intersect_inline",
        "intersect_primitive on a leaf-ordered copy of the records it reads (gpu::traversal::LeafLayout::Inline)",
    ),
    (
        "wide_lane",
        "one lane's box test of the GPU's four-wide walk",
    ),
    (
        "bvh_intersect_compressed",
        "the GPU's compressed eight-wide walk (gpu::compressed; the reference's collapse keeps exact boxes, Bvh::intersect)",
    ),
    (
        "cw_word",
        "reads a word of a compressed node from the nodes binding (gpu::traversal::compressed_words)",
    ),
    (
        "cw_node",
        "decodes a compressed node's words (gpu::compressed::CompressedNode::from_words, scale)",
    ),
    (
        "cw_byte",
        "one byte of a compressed node's eight (gpu::compressed::CompressedNode::words packs them)",
    ),
    (
        "cw_box_min",
        "a compressed node's slot's box minimum (gpu::compressed::CompressedNode::child_box)",
    ),
    (
        "cw_box_max",
        "a compressed node's slot's box maximum (gpu::compressed::CompressedNode::child_box)",
    ),
    (
        "cw_slot",
        "one slot's box test of the compressed walk",
    ),
    (
        "bvh_node",
        "reads a BvhNode record from the nodes binding's words (gpu::traversal::NodeLayout)",
    ),
    (
        "has_alpha",
        "an indexed leaf entry's TRIANGLE_HAS_ALPHA test (the reference keeps the bit in its LeafPrim copy)",
    ),
    (
        "material_textures",
        "the TextureContext lookups of emitted, bsdf_eval and scatter (and reference::Scene::added_emission, ggx_parameters, coat_parameters), made once a path vertex through one call of the texture lookup",
    ),
    (
        "is_blend",
        "whether a material's Wrappers::blend is set (the reference's material::Bsdf carries the second BSDF)",
    ),
    (
        "vertex_has_density",
        "reference::material::Bsdf::has_density (a method there)",
    ),
    (
        "vr_with",
        "the reference copies its array of vertex randoms and sets a slot (material::wrapped_scatter)",
    ),
    (
        "light_textures",
        "emitted's TextureContext lookup at a light's sampled point",
    ),
    ("node_min", "reads a packed BvhNode record"),
    ("node_max", "reads a packed BvhNode record"),
    ("f32_infinity", "WGSL const-expressions may not be infinite"),
    (
        "poison",
        "the default branch of a tag switch (Rust matches are exhaustive)",
    ),
    ("normalize_or", "glam's Vec3::normalize_or"),
    ("max3", "glam's Vec3::max_element"),
    ("v3", "glam's Vec3::new"),
    ("is_finite3", "glam's Vec3::is_finite"),
    (
        "render_main",
        "the kernel entry point: one pixel of integrator::render",
    ),
    (
        "aov_main",
        "the AOV kernel's entry point: one pixel of aov::render_aovs",
    ),
    (
        "aov_f32",
        "reads a word of the AOV sums (AovSums::words is a Vec on the host)",
    ),
    ("aov_v3", "reads three words of the AOV sums"),
    ("aov_put_v3", "writes three words of the AOV sums"),
    (
        "aov_sums_load",
        "reads a pixel's AOV sums into registers (the host's add_to works on the words)",
    ),
    ("aov_sums_store", "writes a pixel's AOV sums back"),
    ("absorbed", "the reference's `None` scatter"),
    (
        "trace",
        "the match on `Integrator` in integrator::render_with",
    ),
    (
        "next_event_ray",
        "integrator::next_event up to its shadow ray (trace_path_mis traces every ray through one call)",
    ),
    (
        "next_event_finish",
        "integrator::next_event after its shadow ray",
    ),
    ("no_shadow_query", "the reference's early returns from next_event"),
    (
        "light_table",
        "render_samples's LightSet::new or LightSet::punctual_only, by estimator (both sets are in `emitters`)",
    ),
    (
        "bsdf_samples_lights",
        "trace_path's next-event estimation of punctual lights: the GPU runs trace_path_mis's loop (one traversal call) without MIS weights",
    ),
    (
        "punctual_light_at",
        "reads a GpuPunctualLight record from `texels` (Scene::punctual_lights on the host)",
    ),
    ("to_unit4", "u32_to_unit_f32 on four words"),
    ("vr_get", "indexes VertexRandoms (a Rust array)"),
    (
        "cbrt_nonnegative",
        "WGSL has no cbrt (f32::cbrt in the reference)",
    ),
    ("vertex_position", "reads a packed GpuVertex record"),
    (
        "intersect_shape",
        "the shape match inside the reference's LeafPrim::intersect",
    ),
    ("no_hit", "the reference's `None` hit"),
    (
        "uses",
        "the kernel's specialization (gpu::features): the reference always holds every feature's code",
    ),
    ("mul_wide", "a u64 product (WGSL has no 64-bit integers)"),
    (
        "mul_words",
        "film.rs's u128 products and big::mul, on WGSL's 32-bit words",
    ),
    ("add_words", "film::add_limbs on 32-bit words"),
    ("channel_sums_add", "one channel of film::PixelSums::add"),
    (
        "mul_add",
        "one step of mul_words: w + a·b + c in two 32-bit words",
    ),
    ("add_carry", "one word of add_words with its carry"),
    (
        "channel_sums_words",
        "one channel of film::PixelSums::to_words",
    ),
    (
        "fixed_point_ok",
        "fixed_point's acceptance alone (film::fixed_point returns None)",
    ),
    (
        "sample_accepted",
        "the acceptance test of film::PixelSums::add, apart for the fold's one-channel invocations",
    ),
    (
        "film_at",
        "the word-major index of the device film (gpu::records::film_words on the host)",
    ),
    (
        "channel_sums_load",
        "reads one channel of a pixel from the device film (gpu::records::film_pixels on the host)",
    ),
    (
        "pixel_sums_load",
        "reads a pixel from the device film (gpu::records::film_pixels on the host)",
    ),
    ("channel_sums_store", "writes one channel of a pixel to the device film"),
    (
        "film_add_sample",
        "film::PixelSums::add on a pixel's words in the device film, in place",
    ),
    (
        "film_add_channel",
        "one channel of film_add_sample: the words an add below 1 reaches, else the channel's",
    ),
    (
        "small_powers",
        "q² and q³ of a one-word q in 32-bit words (film.rs's u128 products)",
    ),
    (
        "fract_euclid",
        "f32::rem_euclid in Wrap::wrap_coordinate",
    ),
    (
        "pixel_layers",
        "PixelSums::stats, then Film's mean, variance and skewness as f32 (film.wgsl's layers, held bit for bit by twins::film::layers)",
    ),
];

/// Prefixes of WGSL-only function families, and why.
const GPU_ONLY_PREFIXES: &[(&str, &str)] = &[
    (
        "soft_",
        "f64 arithmetic on words for pixel_layers (WGSL has no f64; the reference's PixelSums::stats uses the processor's)",
    ),
    (
        "moments_",
        "PixelSums::stats's big integers on 32-bit words for pixel_layers (the reference's are 64-bit limbs, film::big)",
    ),
];

/// WGSL name, Rust name, why they differ.
const RENAMED: &[(&str, &str, &str)] = &[
    (
        "intersect_instance_record",
        "instance_hit_by",
        "an instance's hit by its group's tree (the Rust walks the group's Accel, or scans it for the brute-force oracle)",
    ),
    (
        "camera_sample",
        "camera_ray",
        "the ray and its weight, as the Rust returns them; the WGSL's camera_ray is the ray alone",
    ),
    (
        "reflect_about",
        "reflect",
        "WGSL predeclares a built-in `reflect`",
    ),
    (
        "refract_through",
        "refract",
        "WGSL predeclares a built-in `refract`",
    ),
];

fn wgsl_functions(src: &str) -> Vec<String> {
    src.lines()
        .filter_map(|l| l.strip_prefix("fn "))
        .map(|l| l.split('(').next().unwrap().trim().to_string())
        .collect()
}

fn camel(snake: &str) -> String {
    snake
        .split('_')
        .map(|w| {
            let mut c = w.chars();
            c.next()
                .map(|f| f.to_ascii_uppercase().to_string() + c.as_str())
                .unwrap_or_default()
        })
        .collect()
}

fn has_fn(rust: &str, name: &str) -> bool {
    rust.contains(&format!("fn {name}(")) || rust.contains(&format!("fn {name}<"))
}

/// Whether WGSL function `name` has a twin in the Rust source `rust`.
fn has_twin(rust: &str, name: &str) -> bool {
    if has_fn(rust, name) {
        return true;
    }
    name.match_indices('_').any(|(i, _)| {
        let (owner, method) = (&name[..i], &name[i + 1..]);
        let ty = camel(owner);
        has_fn(rust, method)
            && (rust.contains(&format!("mod {owner} "))
                || rust.contains(&format!("impl {ty} "))
                || rust.contains(&format!("struct {ty} ")))
    })
}

/// The WGSL functions of `wgsl` without a twin in `rust` nor an entry in
/// the tables.
fn unpaired(wgsl: &str, rust: &str) -> Vec<String> {
    wgsl_functions(wgsl)
        .into_iter()
        .filter(|f| !has_twin(rust, f))
        .filter(|f| !GPU_ONLY.iter().any(|(g, _)| g == f))
        .filter(|f| !GPU_ONLY_PREFIXES.iter().any(|(p, _)| f.starts_with(p)))
        .filter(|f| !RENAMED.iter().any(|(w, r, _)| w == f && has_fn(rust, r)))
        .collect()
}

#[test]
fn every_wgsl_function_has_a_rust_twin() {
    let mut missing = Vec::new();
    for (module, src) in gpu::shader::LIBRARY_FILES.iter().copied().chain([
        ("integrator", gpu::shader::INTEGRATOR_WGSL),
        ("aov", gpu::aov::AOV_WGSL),
    ]) {
        let rust = reference_module(module)
            .unwrap_or_else(|| panic!("no reference/src/{module}.rs nor reference/src/{module}/"));
        missing.extend(
            unpaired(src, &rust)
                .into_iter()
                .map(|f| format!("{module}: {f}")),
        );
    }
    assert!(
        missing.is_empty(),
        "WGSL functions without a Rust twin of the same name (rename one side, or \
         list it in tidy's GPU_ONLY with why): {missing:?}"
    );
}

#[test]
fn the_tables_list_only_functions_that_exist() {
    let all: BTreeSet<String> = gpu::shader::LIBRARY_FILES
        .iter()
        .map(|(_, s)| *s)
        .chain([gpu::shader::INTEGRATOR_WGSL, gpu::aov::AOV_WGSL])
        .flat_map(wgsl_functions)
        .collect();
    for name in GPU_ONLY
        .iter()
        .map(|e| e.0)
        .chain(RENAMED.iter().map(|e| e.0))
    {
        assert!(
            all.contains(name),
            "tidy lists `{name}`, which no shader defines"
        );
    }
    for (prefix, _) in GPU_ONLY_PREFIXES {
        assert!(
            all.iter().any(|f| f.starts_with(prefix)),
            "tidy lists the prefix `{prefix}`, which no shader function has"
        );
    }
}

/// Tag families: `const FAMILY_NAME: u32` lines of the generated prelude.
fn tag_families() -> BTreeMap<String, BTreeSet<String>> {
    let mut families: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for family in ["PRIMITIVE", "MATERIAL", "TEXTURE", "BACKGROUND"] {
        for line in gpu::shader::GENERATED_WGSL.lines() {
            if let Some(rest) = line.strip_prefix(&format!("const {family}_")) {
                let name = rest.split(':').next().unwrap();
                families
                    .entry(family.into())
                    .or_default()
                    .insert(format!("{family}_{name}"));
            }
        }
    }
    families
}

/// A `switch` of a shader: its cases and its default block.
struct Switch {
    at: String,
    cases: BTreeSet<String>,
    default: Option<String>,
}

/// The text of the block opening at byte `open` (a `{`), without braces.
fn block(src: &str, open: usize) -> &str {
    let mut depth = 0;
    for (i, c) in src[open..].char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return &src[open + 1..open + i];
                }
            }
            _ => {}
        }
    }
    panic!("unbalanced braces after byte {open}")
}

fn switches(file: &str, src: &str) -> Vec<Switch> {
    let mut out = Vec::new();
    for (at, _) in src.match_indices("switch ") {
        let open = at + src[at..].find('{').unwrap();
        let body = block(src, open);
        let line = src[..at].lines().count() + 1;
        let mut cases = BTreeSet::new();
        let mut default = None;
        let mut depth = 0;
        for (i, c) in body.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                _ if depth == 0 => {
                    let rest = &body[i..];
                    if let Some(r) = rest.strip_prefix("case ") {
                        let label = r.split([':', '{']).next().unwrap();
                        cases.extend(label.split(',').map(|s| s.trim().to_string()));
                    } else if rest.starts_with("default") {
                        default = Some(block(body, i + rest.find('{').unwrap()).to_string());
                    }
                }
                _ => {}
            }
        }
        out.push(Switch {
            at: format!("{file}:{line}"),
            cases,
            default,
        });
    }
    out
}

/// Problems with the tag switches of `files`.
fn switch_problems(files: &[(&str, &str)]) -> Vec<String> {
    let families = tag_families();
    let mut problems = Vec::new();
    for (file, src) in files {
        for s in switches(file, src) {
            let Some((family, tags)) = families
                .iter()
                .find(|(f, _)| s.cases.iter().any(|c| c.starts_with(&format!("{f}_"))))
            else {
                continue;
            };
            let missing: Vec<_> = tags.difference(&s.cases).collect();
            if !missing.is_empty() {
                problems.push(format!("{}: switch on {family} lacks {missing:?}", s.at));
            }
            if !s.default.as_deref().is_some_and(|d| d.contains("poison()")) {
                problems.push(format!("{}: default branch does not call poison()", s.at));
            }
        }
    }
    problems
}

fn shader_files() -> Vec<(&'static str, &'static str)> {
    gpu::shader::LIBRARY_FILES
        .iter()
        .copied()
        .chain([
            ("integrator", gpu::shader::INTEGRATOR_WGSL),
            ("aov", gpu::aov::AOV_WGSL),
        ])
        .collect()
}

#[test]
fn every_tag_has_its_case_and_every_default_poisons() {
    let families = tag_families();
    assert_eq!(
        families.len(),
        4,
        "tag families in the prelude: {families:?}"
    );
    let problems = switch_problems(&shader_files());
    assert!(problems.is_empty(), "{problems:#?}");
    // Each family is dispatched somewhere.
    let all: BTreeSet<String> = shader_files()
        .iter()
        .flat_map(|(f, s)| switches(f, s))
        .flat_map(|s| s.cases)
        .collect();
    for (family, tags) in &families {
        assert!(
            tags.iter().any(|t| all.contains(t)),
            "no switch on {family}"
        );
    }
}

/// Float literals outside module-scope `const` declarations and comments
/// that are not small integers or 0.5.
fn magic_numbers(file: &str, src: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, line) in src.lines().enumerate() {
        let code = line.split("//").next().unwrap();
        if code.starts_with("const ") {
            continue;
        }
        let bytes = code.as_bytes();
        let mut k = 0;
        while k < bytes.len() {
            let starts = bytes[k].is_ascii_digit()
                && (k == 0 || !(bytes[k - 1].is_ascii_alphanumeric() || bytes[k - 1] == b'_'));
            if !starts {
                k += 1;
                continue;
            }
            let end = code[k..]
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '_'))
                .map_or(code.len(), |e| k + e);
            let tok = &code[k..end];
            let is_float = !tok.starts_with("0x")
                && (tok.contains('.') || tok.contains('e'))
                && !tok.ends_with('u')
                && !tok.ends_with('i');
            if is_float {
                let v: f64 = tok.trim_end_matches('f').parse().unwrap_or(f64::NAN);
                let small_integer = v.fract() == 0.0 && v.abs() <= 8.0;
                if !(small_integer || v == 0.5) {
                    out.push(format!("{file}:{}: {tok}", i + 1));
                }
            }
            k = end;
        }
    }
    out
}

#[test]
fn wgsl_bodies_carry_no_magic_numbers() {
    let found: Vec<String> = shader_files()
        .iter()
        .flat_map(|(f, s)| magic_numbers(f, s))
        .collect();
    assert!(
        found.is_empty(),
        "name these (generate them from Rust in gpu::shader::generate, or a GPU-only \
         module-scope const with why): {found:?}"
    );
}

#[test]
fn shaders_mirror_reference_modules() {
    let listed: BTreeSet<String> = gpu::shader::LIBRARY_FILES
        .iter()
        .map(|(m, _)| format!("{m}.wgsl"))
        .collect();
    for (module, _) in gpu::shader::LIBRARY_FILES {
        assert!(
            reference_module(module).is_some(),
            "shaders/{module}.wgsl has no reference/src/{module}.rs nor reference/src/{module}/"
        );
    }
    for entry in fs::read_dir(root().join("shaders")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        // wavefront.wgsl: GPU only, the wave schedules of integrator.wgsl's
        // path loop (gpu::wavefront), gated against the megakernel (bit for
        // bit, or means within a few ulp) rather than twinned.
        assert!(
            listed.contains(&name)
                || [
                    "integrator.wgsl",
                    "generated.wgsl",
                    "wavefront.wgsl",
                    "aov.wgsl"
                ]
                .contains(&name.as_str()),
            "shaders/{name} is not part of the program (gpu::shader::LIBRARY_FILES)"
        );
    }
}

/// The project's text files: sources, shaders, docs, manifests.
fn text_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') || name == "target" {
                continue;
            }
            if p.is_dir() {
                walk(&p, out);
            } else if ["rs", "wgsl", "md", "toml", "sh", "py"]
                .iter()
                .any(|x| name.ends_with(&format!(".{x}")))
            {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    for dir in [
        "src",
        "tests",
        "reference",
        "readers",
        "fuzz",
        "gpu",
        "shaders",
        "docs",
        "xtask",
        "examples",
        ".ci",
    ] {
        walk(&root().join(dir), &mut out);
    }
    for f in ["README.md", "ARCHITECTURE.md", "Cargo.toml"] {
        out.push(root().join(f));
    }
    out
}

/// Paths like `reference/src/x.rs` or `docs/gates.md` named in `text`
/// that exist neither under `root` nor under `base` (the crate of the file
/// that names them; placeholders in capitals or with `<`, `*` or `{` are
/// skipped).
fn dangling_paths(text: &str, root: &Path, base: &Path) -> Vec<String> {
    const TOPS: [&str; 11] = [
        "reference/",
        "readers/",
        "fuzz/",
        "gpu/",
        "src/",
        "tests/",
        "shaders/",
        "docs/",
        "xtask/",
        "fixtures/",
        "examples/",
    ];
    const EXTS: [&str; 7] = [".rs", ".wgsl", ".md", ".json", ".exr", ".txt", ".toml"];
    let mut out = Vec::new();
    for (i, _) in text.char_indices() {
        let rest = &text[i..];
        if !TOPS.iter().any(|t| rest.starts_with(t)) {
            continue;
        }
        let prev = text[..i].chars().next_back();
        if prev.is_some_and(|c| c.is_alphanumeric() || "_-./".contains(c)) {
            continue;
        }
        let end = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || "_-./".contains(c)))
            .unwrap_or(rest.len());
        let path = rest[..end].trim_end_matches('.');
        let placeholder = path.chars().any(|c| c.is_ascii_uppercase())
            || rest[end..].starts_with(['<', '*', '{']);
        if placeholder || !EXTS.iter().any(|x| path.ends_with(x)) {
            continue;
        }
        if !root.join(path).exists() && !base.join(path).exists() {
            out.push(path.to_string());
        }
    }
    out
}

#[test]
fn named_paths_exist_and_nothing_cites_outside_the_repository() {
    let mut problems = Vec::new();
    for file in text_files() {
        let Ok(text) = fs::read_to_string(&file) else {
            continue;
        };
        let rel = file.strip_prefix(root()).unwrap().display().to_string();
        if rel == "tests/tools/tidy.rs" {
            continue;
        }
        // The crate the file belongs to: its nearest folder with a Cargo.toml.
        let base = file
            .ancestors()
            .find(|d| d.join("Cargo.toml").exists())
            .unwrap_or(&root())
            .to_path_buf();
        // Or relative to the file's own folder (a `#[path]` attribute).
        let dir = file.parent().unwrap_or(&base);
        for p in dangling_paths(&text, &root(), &base) {
            if !dir.join(&p).exists() {
                problems.push(format!("{rel}: names {p}, which does not exist"));
            }
        }
        for outside in [
            "../shared",
            "DESIGN.md",
            "GPU.md",
            "STYLE.md",
            "SCENE-FORMAT.md",
        ] {
            if text.contains(outside) {
                problems.push(format!("{rel}: cites {outside}, outside the repository"));
            }
        }
    }
    assert!(problems.is_empty(), "{problems:#?}");
}

/// Each rule fails on the defect it is for.
mod mutations {
    use super::*;

    #[test]
    fn a_function_renamed_on_one_side_is_unpaired() {
        let rust = read("reference/src/geometry.rs");
        let wgsl = gpu::shader::LIBRARY_FILES[2].1;
        assert_eq!(gpu::shader::LIBRARY_FILES[2].0, "geometry");
        assert!(unpaired(wgsl, &rust).is_empty());
        let renamed = wgsl.replace("fn spawn_origin(", "fn spawn_point(");
        assert_eq!(unpaired(&renamed, &rust), ["spawn_point"]);
        // A method of a Rust type twins `snake_type_method`.
        assert!(has_twin(&rust, "onb_from_normal"));
        assert!(!has_twin(&rust, "onb_from_tangent"));
    }

    #[test]
    fn a_missing_case_or_an_unpoisoned_default_is_caught() {
        let (name, material) = shader_files()
            .into_iter()
            .find(|(f, _)| *f == "material")
            .unwrap();
        assert!(switch_problems(&[(name, material)]).is_empty());
        let no_case = material.replace("case MATERIAL_DIFFUSE_LIGHT:", "case 1000u:");
        let p = switch_problems(&[(name, &no_case)]);
        assert!(
            p.len() == 1 && p[0].contains("MATERIAL_DIFFUSE_LIGHT"),
            "{p:?}"
        );
        let default = "default: {\n            poison();";
        assert!(material.contains(default));
        let absorbing = material.replacen(default, "default: {\n", 1);
        let p = switch_problems(&[(name, &absorbing)]);
        assert!(p.len() == 1 && p[0].contains("poison"), "{p:?}");
    }

    #[test]
    fn a_literal_constant_is_caught() {
        let src = "fn f(x: f32) -> f32 {\n    return x * 3.4028235e38 + 2.0 * 0.5;\n}\n";
        assert_eq!(magic_numbers("t", src), ["t:2: 3.4028235e38"]);
        assert!(magic_numbers("t", "const TINY: f32 = 1.0e-30;\nlet i = 7u; // 0.25\n").is_empty());
    }

    #[test]
    fn a_dangling_path_is_caught() {
        let r = root();
        assert!(dangling_paths("see docs/gates.md and shaders/bvh.wgsl.", &r, &r).is_empty());
        let nothing = dangling_paths("(reference/src/nothing.rs)", &r, &r);
        assert_eq!(nothing, ["reference/src/nothing.rs"]);
        assert!(dangling_paths("fixtures/refs/NAME.exr, tests/<name>.rs", &r, &r).is_empty());
        // Relative to the naming file's crate.
        let in_reference = dangling_paths("tests/embree_agreement.rs", &r, &r.join("reference"));
        assert!(in_reference.is_empty());
        assert_eq!(dangling_paths("tests/embree_agreement.rs", &r, &r).len(), 1);
    }
}

/// The leaf paths of a `use`/path tree starting at `text` (after
/// `crate::` or `super::`): `a::b`, `a::{b, c::{D, e}}`, `A`.
fn path_tree(text: &str) -> Vec<Vec<String>> {
    fn ident(s: &[u8], i: &mut usize) -> String {
        let start = *i;
        while *i < s.len() && (s[*i].is_ascii_alphanumeric() || s[*i] == b'_') {
            *i += 1;
        }
        String::from_utf8_lossy(&s[start..*i]).into_owned()
    }
    fn skip_ws(s: &[u8], i: &mut usize) {
        while *i < s.len() && s[*i].is_ascii_whitespace() {
            *i += 1;
        }
    }
    fn tree(s: &[u8], i: &mut usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) {
        skip_ws(s, i);
        if *i < s.len() && s[*i] == b'{' {
            *i += 1;
            loop {
                skip_ws(s, i);
                if *i >= s.len() || s[*i] == b'}' {
                    *i += 1;
                    return;
                }
                tree(s, i, prefix.clone(), out);
                skip_ws(s, i);
                if *i < s.len() && s[*i] == b',' {
                    *i += 1;
                }
            }
        }
        let name = ident(s, i);
        if name.is_empty() {
            if !prefix.is_empty() {
                out.push(prefix);
            }
            return;
        }
        let mut path = prefix;
        path.push(name);
        if s[*i..].starts_with(b"::") {
            *i += 2;
            tree(s, i, path, out);
        } else {
            out.push(path);
        }
    }
    let mut out = Vec::new();
    tree(text.as_bytes(), &mut 0, Vec::new(), &mut out);
    out
}

/// `text` without its test code: each `#[cfg(test)]` item (a `mod tests
/// { … }` block, to its closing brace, or a `mod tests;` declaration).
/// A module's tests may use what its users do; the layers are the
/// production code's.
fn without_tests(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at..];
        let end = match (item.find(';'), item.find('{')) {
            (Some(semi), Some(open)) if semi < open => semi + 1,
            (_, Some(open)) => {
                let mut depth = 0usize;
                let mut close = item.len();
                for (i, c) in item[open..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                close = open + i + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                close
            }
            (Some(semi), None) => semi + 1,
            (None, None) => item.len(),
        };
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

/// The graph of which file of the crate in `dir` (its root `root_file`,
/// `lib.rs` or `main.rs`) uses which (comments and test code left out; a
/// name the crate root re-exports counts as a use of the module it comes
/// from; a folder's `mod.rs` uses the files it declares).
fn imports(dir: &str, root_file: &str) -> BTreeMap<String, BTreeSet<String>> {
    let src = root().join(dir);
    let mut files = Vec::new();
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for e in fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                files.push(p.strip_prefix(&src).unwrap().to_string_lossy().into_owned());
            }
        }
    }
    let code = |rel: &str| -> String {
        without_tests(
            &fs::read_to_string(src.join(rel))
                .unwrap()
                .lines()
                .map(|l| l.split("//").next().unwrap_or(""))
                .collect::<Vec<_>>()
                .join("\n"),
        )
    };
    // Files that are a module's tests (`#[cfg(test)] mod tests;`): test
    // code, left out as the `#[cfg(test)]` blocks are.
    let test_files: BTreeSet<String> = files
        .iter()
        .filter(|f| f.ends_with("mod.rs") || f.as_str() == root_file)
        .flat_map(|f| {
            let dir = f
                .rsplit_once('/')
                .map_or(String::new(), |(d, _)| format!("{d}/"));
            let text = fs::read_to_string(src.join(f)).unwrap();
            let lines: Vec<&str> = text.lines().map(str::trim).collect();
            lines
                .windows(2)
                .filter(|w| w[0] == "#[cfg(test)]")
                .filter_map(|w| w[1].strip_prefix("mod ")?.strip_suffix(';'))
                .map(|name| format!("{dir}{name}.rs"))
                .collect::<Vec<_>>()
        })
        .collect();
    files.retain(|f| !test_files.contains(f));
    // The file of module `name` in folder `dir` (`dir/name.rs`, or a
    // folder module's `dir/name/mod.rs`), if there is one.
    let file_of = |dir: &str, name: &str| -> Option<String> {
        [format!("{dir}{name}.rs"), format!("{dir}{name}/mod.rs")]
            .into_iter()
            .find(|f| files.contains(f))
    };
    // The module file of `a` or `a::b`, as far as files go.
    let module = |parts: &[String]| -> Option<String> {
        let first = parts.first()?;
        parts
            .get(1)
            .and_then(|second| file_of(&format!("{first}/"), second))
            .or_else(|| file_of("", first))
    };
    // Root re-exports: item -> the module path it comes from.
    let mut reexports: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let lib = code(root_file);
    for (at, _) in lib.match_indices("pub use ") {
        for path in path_tree(&lib[at + "pub use ".len()..]) {
            if let Some((item, from)) = path.split_last() {
                reexports.insert(item.clone(), from.to_vec());
            }
        }
    }
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files.iter().filter(|f| *f != root_file) {
        let text = code(f);
        let mut uses = BTreeSet::new();
        let dir = f.rsplit_once('/').map(|(d, _)| d.to_string());
        for (at, _) in text.match_indices("crate::") {
            for path in path_tree(&text[at + "crate::".len()..]) {
                let target = match reexports.get(&path[0]) {
                    Some(from) => module(from),
                    None => module(&path),
                };
                uses.extend(target);
            }
        }
        if let Some(dir) = &dir {
            let parent = format!("{dir}/mod.rs");
            for (at, _) in text.match_indices("super::") {
                for path in path_tree(&text[at + "super::".len()..]) {
                    // A sibling file or folder module, else the parent.
                    uses.insert(file_of(&format!("{dir}/"), &path[0]).unwrap_or(parent.clone()));
                }
            }
            if f.ends_with("mod.rs") {
                for line in text.lines() {
                    let decl = line
                        .trim()
                        .trim_start_matches("pub ")
                        .trim_start_matches("pub(crate) ");
                    if let Some(name) = decl.strip_prefix("mod ").and_then(|n| n.strip_suffix(';'))
                    {
                        uses.insert(
                            file_of(&format!("{dir}/"), name)
                                .unwrap_or_else(|| format!("{dir}/{name}.rs")),
                        );
                    }
                }
            }
        }
        uses.remove(f);
        graph.insert(f.clone(), uses);
    }
    graph
}

/// A cycle of `graph`, if it has one.
fn a_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let from = path.iter().position(|p| p == n).unwrap_or(0);
                let mut cycle = path[from..].to_vec();
                cycle.push(n.to_string());
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for m in graph.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, graph, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    graph
        .keys()
        .find_map(|n| visit(n, graph, &mut state, &mut Vec::new()))
}

/// The crates are built in layers: no file of a crate's sources uses
/// another that uses it back, however indirectly (ARCHITECTURE.md's map
/// relies on it; a cycle is how the four render abstractions grew into one
/// another). Held for every crate: gpu/, readers/, xtask/, the twintrace
/// crate (src/) and reference/. Its name stays clear of `gpu_`: the H100 suite's package
/// runs the tests so named, and has no source tree.
#[test]
fn the_crates_modules_import_each_other_in_no_cycle() {
    let [gpu, readers, xtask, twintrace, reference] = [
        ("gpu/src", "lib.rs"),
        ("readers/src", "lib.rs"),
        ("xtask/src", "main.rs"),
        ("src", "lib.rs"),
        ("reference/src", "lib.rs"),
    ]
    .map(|(dir, root_file)| {
        let graph = imports(dir, root_file);
        if let Some(cycle) = a_cycle(&graph) {
            panic!("{dir} imports in a cycle: {}", cycle.join(" -> "));
        }
        graph
    });
    assert!(gpu.len() > 10, "too few files found: {gpu:?}");
    assert!(readers.len() > 2, "too few files found: {readers:?}");
    assert!(
        gpu["film.rs"].contains("context.rs") && gpu["renderer.rs"].contains("film.rs"),
        "the import graph misses plain uses: {gpu:?}"
    );
    assert!(
        xtask["fuzz.rs"].contains("util.rs") && xtask["test.rs"].contains("fuzz.rs"),
        "the import graph misses plain uses: {xtask:?}"
    );
    assert!(
        twintrace["perf/measure.rs"].contains("perf/run.rs")
            && twintrace["view/window.rs"].contains("view/session.rs")
            && twintrace["compare/metrics.rs"].contains("compare/image/mod.rs"),
        "the import graph misses uses of a sibling: {twintrace:?}"
    );
    assert!(
        reference["scene/builder.rs"].contains("scene/world.rs")
            && reference["scene/world.rs"].contains("scene/leaf.rs"),
        "the import graph misses uses of a sibling: {reference:?}"
    );
    assert!(
        reference["loader/json.rs"].contains("loader/gltf/mod.rs")
            && reference["loader/mod.rs"].contains("loader/gltf/mod.rs"),
        "the import graph misses uses of a folder module: {reference:?}"
    );
    // Test code is left out: a module's tests may use anything.
    assert!(
        !gpu["pipeline/cache.rs"].contains("pipeline/mod.rs")
            && !twintrace["perf/regress.rs"].contains("perf/mod.rs"),
        "a test module's `use super::*` counted: {gpu:?} {twintrace:?}"
    );
    // The rule's own mutants: the graph with a use back added has a cycle.
    for (graph, from, to) in [
        (&gpu, "film.rs", "renderer.rs"),
        (&gpu, "pipeline/cache.rs", "context.rs"),
        (&xtask, "fuzz.rs", "test.rs"),
        (&twintrace, "perf/run.rs", "perf/measure.rs"),
        (&twintrace, "view/session.rs", "view/save.rs"),
        (&reference, "scene/leaf.rs", "scene/world.rs"),
        (&reference, "loader/gltf/meshes.rs", "loader/gltf/mod.rs"),
    ] {
        let mut g = graph.clone();
        g.get_mut(from).unwrap().insert(to.to_string());
        assert!(
            a_cycle(&g).is_some(),
            "{from} -> {to} was not seen as a cycle"
        );
    }
    assert_eq!(
        path_tree("{a::{B, c}, D};"),
        [vec!["a", "B"], vec!["a", "c"], vec!["D"]]
            .map(|v| v.into_iter().map(String::from).collect::<Vec<_>>())
    );
}
