//! The integration tests of the workspace: one crate of modules (one test
//! binary, so wgpu is linked once), each module named for the property it
//! checks. Modules whose name starts with `gpu_` need an adapter: in CI the
//! README's test command installs Mesa lavapipe; on real hardware the same
//! binary runs as `cargo xtask gpu-suite` packs it (fixtures are found
//! through `TWINTRACE_ROOT` when set, else through the source tree the
//! binary was built from).

mod common;

mod aov;
mod bvh_matches_brute_force;
mod cli_errors;
mod diff_command;
mod fixtures_render;
mod furnace;
mod gates_catch_mutants;
mod gltf_bounds;
mod gltf_equivalence;
mod gltf_import;
mod image_io;
mod khronos_assets;
mod known_answers;
mod light_sampling;
mod mis_matches_bsdf;
mod mitsuba_bsdfs;
mod mitsuba_scenes;
mod mitsuba_shapes;
mod partial_film_roundtrip;
mod perf_regression;
mod progressive_render;
mod punctual_lights;
mod reference_images;
mod render_determinism;
mod render_space;
#[cfg(target_os = "linux")] // signals through libc
mod resume;
mod safe_outputs;
mod sampling_chi2;
mod scale_invariance;
mod scene_loading_errors;
mod sobol_sampler;
mod split_render;
mod tidy;

mod gpu_aov;
mod gpu_buffer_layout;
mod gpu_coverage;
mod gpu_display;
mod gpu_errors;
mod gpu_film_bands;
mod gpu_furnace;
mod gpu_hits_match_reference;
mod gpu_light_sampling;
mod gpu_matches_reference;
mod gpu_mitsuba_scenes;
mod gpu_numerics_match_reference;
mod gpu_pipeline_cache;
mod gpu_progressive_render;
mod gpu_punctual_lights;
mod gpu_render_space;
mod gpu_renders_fixtures;
#[cfg(target_os = "linux")]
mod gpu_resume;
mod gpu_rng_matches_cpu;
mod gpu_sampling_chi2;
mod gpu_specialization;
mod gpu_split_render;
mod gpu_surface_match_reference;
mod gpu_traversal;
mod gpu_wavefront;
mod view;
