//! `twintrace`: the command line and the tools around the renderers.
//!
//! The scene model and the scalar reference renderer live in the
//! `reference` crate, the wgpu kernels in `gpu`. This crate holds what
//! users and later tools (`twintrace diff`, `cargo xtask bless`) share:
//!
//! - [`image_io`]: the render EXR (linear mean + variance of the mean, its
//!   exact layout documented there), the tone-mapped PNG, reading an EXR
//!   back, and all-or-nothing file writes;
//! - [`tonemap`]: ACES filmic (Narkowicz's fit) and the sRGB OETF;
//! - [`cli`]: the `twintrace` commands (`render`, `info`, `diff`);
//! - [`compare`]: the statistical and exact gates (z/Welch image tests with
//!   aggregate tests, chi-square for sampling, bitwise comparison, stored
//!   references), with [`stats`] for the distribution functions;
//! - [`diff`] and [`report`]: `twintrace diff` and its HTML report.

pub mod cli;
pub mod compare;
pub mod diff;
pub mod image_io;
pub mod report;
pub mod stats;
pub mod tonemap;

pub use image_io::{read_exr, write_exr, write_png, OutputPaths, RenderImage, RenderMetadata};
pub use tonemap::Tonemap;
