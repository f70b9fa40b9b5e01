//! The integration tests of the workspace: one crate of modules (one test
//! binary, so wgpu is linked once), each module named for the property it
//! checks. Modules whose name starts with `gpu_` need an adapter: in CI the
//! README's test command installs Mesa lavapipe; on real hardware the same
//! binary runs as `cargo xtask gpu-suite` packs it (fixtures are found
//! through `TWINTRACE_ROOT` when set, else through the source tree the
//! binary was built from).
//!
//! The files are in folders by what they test: reference/ (the CPU
//! reference, its loaders and its statistical gates against stored
//! references), gpu/ (the GPU twin: every `gpu_` module), cli/ (the
//! command line and the render job: outputs, resume, split renders),
//! view/ (the viewer) and tools/ (tidy, the gates' own mutants, perf's
//! regression rule). Each module keeps its name (`#[path]`), so test
//! names and filters (`gpu_`, `resume::`) do not depend on the folders.

mod common;

#[path = "cli/aov.rs"]
mod aov;
#[path = "reference/bvh_matches_brute_force.rs"]
mod bvh_matches_brute_force;
#[path = "cli/cli_errors.rs"]
mod cli_errors;
#[path = "cli/diff_command.rs"]
mod diff_command;
#[path = "reference/fixtures_render.rs"]
mod fixtures_render;
#[path = "reference/furnace.rs"]
mod furnace;
#[path = "tools/gates_catch_mutants.rs"]
mod gates_catch_mutants;
#[path = "reference/gltf_bounds.rs"]
mod gltf_bounds;
#[path = "reference/gltf_equivalence.rs"]
mod gltf_equivalence;
#[path = "reference/gltf_import.rs"]
mod gltf_import;
#[path = "cli/image_io.rs"]
mod image_io;
#[path = "reference/khronos_assets.rs"]
mod khronos_assets;
#[path = "reference/known_answers.rs"]
mod known_answers;
#[path = "reference/light_sampling.rs"]
mod light_sampling;
#[path = "reference/mis_matches_bsdf.rs"]
mod mis_matches_bsdf;
#[path = "reference/mitsuba_bsdfs.rs"]
mod mitsuba_bsdfs;
#[path = "reference/mitsuba_scenes.rs"]
mod mitsuba_scenes;
#[path = "reference/mitsuba_shapes.rs"]
mod mitsuba_shapes;
#[path = "cli/partial_film_roundtrip.rs"]
mod partial_film_roundtrip;
#[path = "tools/perf_regression.rs"]
mod perf_regression;
#[path = "cli/progressive_render.rs"]
mod progressive_render;
#[path = "reference/punctual_lights.rs"]
mod punctual_lights;
#[path = "reference/reference_images.rs"]
mod reference_images;
#[path = "cli/render_determinism.rs"]
mod render_determinism;
#[path = "reference/render_space.rs"]
mod render_space;
#[cfg(target_os = "linux")] // signals through libc
#[path = "cli/resume.rs"]
mod resume;
#[path = "cli/safe_outputs.rs"]
mod safe_outputs;
#[path = "reference/sampling_chi2.rs"]
mod sampling_chi2;
#[path = "reference/scale_invariance.rs"]
mod scale_invariance;
#[path = "reference/scene_loading_errors.rs"]
mod scene_loading_errors;
#[cfg(target_os = "linux")]
#[path = "cli/slurm.rs"]
mod slurm;
#[path = "reference/sobol_sampler.rs"]
mod sobol_sampler;
#[path = "cli/split_render.rs"]
mod split_render;
#[path = "tools/tidy.rs"]
mod tidy;

#[path = "gpu/gpu_aov.rs"]
mod gpu_aov;
#[path = "gpu/gpu_buffer_layout.rs"]
mod gpu_buffer_layout;
#[path = "gpu/gpu_coverage.rs"]
mod gpu_coverage;
#[path = "gpu/gpu_display.rs"]
mod gpu_display;
#[path = "gpu/gpu_errors.rs"]
mod gpu_errors;
#[path = "gpu/gpu_film_bands.rs"]
mod gpu_film_bands;
#[path = "gpu/gpu_furnace.rs"]
mod gpu_furnace;
#[path = "gpu/gpu_hits_match_reference.rs"]
mod gpu_hits_match_reference;
#[path = "gpu/gpu_kernel_inspection.rs"]
mod gpu_kernel_inspection;
#[path = "gpu/gpu_light_sampling.rs"]
mod gpu_light_sampling;
#[path = "gpu/gpu_matches_reference.rs"]
mod gpu_matches_reference;
#[path = "gpu/gpu_mitsuba_scenes.rs"]
mod gpu_mitsuba_scenes;
#[path = "gpu/gpu_numerics_match_reference.rs"]
mod gpu_numerics_match_reference;
#[path = "gpu/gpu_pipeline_cache.rs"]
mod gpu_pipeline_cache;
#[path = "gpu/gpu_progressive_render.rs"]
mod gpu_progressive_render;
#[path = "gpu/gpu_punctual_lights.rs"]
mod gpu_punctual_lights;
#[path = "gpu/gpu_render_space.rs"]
mod gpu_render_space;
#[path = "gpu/gpu_renders_fixtures.rs"]
mod gpu_renders_fixtures;
#[cfg(target_os = "linux")]
#[path = "gpu/gpu_resume.rs"]
mod gpu_resume;
#[path = "gpu/gpu_rng_matches_cpu.rs"]
mod gpu_rng_matches_cpu;
#[path = "gpu/gpu_sampling_chi2.rs"]
mod gpu_sampling_chi2;
#[path = "gpu/gpu_specialization.rs"]
mod gpu_specialization;
#[path = "gpu/gpu_split_render.rs"]
mod gpu_split_render;
#[path = "gpu/gpu_surface_match_reference.rs"]
mod gpu_surface_match_reference;
#[path = "gpu/gpu_traversal.rs"]
mod gpu_traversal;
#[path = "gpu/gpu_wavefront.rs"]
mod gpu_wavefront;
#[path = "view/view.rs"]
mod view;
