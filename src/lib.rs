//! `twintrace`: the differential-testing framework of the two renderers.
//!
//! The scene model and the scalar reference renderer live in the
//! `reference` crate, the wgpu kernels in `gpu`. This library holds what
//! the tests, the `twintrace` binary (`twintrace diff`) and later tools
//! share; it never imports the command line, which is the binary's alone
//! (`src/main.rs`, `src/cli/`):
//!
//! - [`image_io`]: the render EXR (linear mean, variance and skewness of the mean, its
//!   exact layout documented there), the tone-mapped PNG, reading an EXR
//!   back, and all-or-nothing file writes;
//! - [`host_memory`]: the host memory a render needs against what the
//!   machine has;
//! - [`tonemap`]: ACES filmic (Narkowicz's fit) and the sRGB OETF;
//! - [`compare`]: the statistical and exact gates (z/Welch image tests with
//!   aggregate tests, chi-square for sampling, bitwise comparison, stored
//!   references), with [`stats`] for the distribution functions;
//! - [`report`]: the self-contained HTML report of a comparison;
//! - [`selftest`]: the gates a user runs on their own GPU (`twintrace
//!   selftest`) and their calibration (false alarms and power);
//! - [`perf`]: the performance instrument (`twintrace perf`, `cargo xtask
//!   perf`): error against time, throughput, baselines and plots;
//! - [`twins`]: the kernel-level twin checks (random numbers, float steps,
//!   hit records, surface interactions), run by the GPU tests and by
//!   `twintrace selftest`;
//! - [`view`]: the interactive viewer's state (camera controls, events,
//!   paced frames of a progressive render), apart from any window.

pub mod aov;
pub mod compare;
pub mod exr_write;
pub mod host_memory;
pub mod image_io;
pub mod mitsuba_tests;
pub mod partial;
pub mod perf;
pub mod render;
pub mod report;
pub mod selftest;
pub mod stats;
pub mod tonemap;
pub mod twins;
pub mod view;

pub use image_io::{read_exr, write_exr, write_png, OutputPaths, RenderImage, RenderMetadata};
pub use tonemap::Tonemap;
