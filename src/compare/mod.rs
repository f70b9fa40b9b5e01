//! Are two renders the same? The statistical and exact gates.
//!
//! docs/gates.md lists the gates and what each catches; this module holds
//! one implementation of each, with its formulas in the doc comments:
//!
//! - [`image`]: two images with variances — per-pixel z-test against a
//!   reference (Mitsuba 3's scheme) or Welch's t-test between two noisy
//!   renders (Jung et al. 2020), Šidák-corrected, the pixels with a failing
//!   test at most 0.25 % of the tests (heavy-tailed pixels left to the sums), plus z-tests
//!   on the image sum and on tile sums, which catch small global biases and
//!   correlated pixels; the three families share α = 0.01;
//! - [`metrics`]: RMSE, relMSE, FLIP and NaN/Inf counts (reported, not gated);
//! - [`chi2`]: chi-square goodness of fit of sampling routines to their
//!   densities, and the two-sample test for lobes without a density;
//! - [`lobes`]: scatter-direction samples of one material for the
//!   two-sample tests (the CPU half of CPU vs GPU);
//! - [`exact`]: bitwise comparison with ulp distances;
//! - [`furnace`]: scenes with known answers and their check;
//!   [`model_furnaces`]: the known answers of Mitsuba's models (a white
//!   rough conductor's albedo, a dielectric slab's and a thin sheet's
//!   transmission);
//! - [`gate`]: stored references under `fixtures/refs/`, rendering a scene
//!   with any renderer (a function that renders a `Film`) at a test budget,
//!   and the evidence a failing gate writes under `target/diff/<test>/`.
//!
//! Renderers plug in as a [`gate::RenderFn`], a function that renders a
//! `Film` for a scene and settings: [`gate::cpu_reference`], or any backend
//! as a progressive render opened once a scene
//! (`crate::render::Renderer::prepare`, as `selftest` does).
//! The lobe cases of [`lobes`] and the furnace cases of [`furnace`] are the
//! CPU halves of the CPU-vs-GPU sampling and furnace gates.
//!
//! The special functions behind the p-values live in [`crate::stats`].

pub mod chi2;
pub mod exact;
pub mod furnace;
pub mod gate;
pub mod image;
pub mod lobes;
pub mod metrics;
pub mod mitsuba;
pub mod model_furnaces;

pub use image::{compare, Method, NoisyImage, TestSettings, Verdict};
pub use metrics::Metrics;
