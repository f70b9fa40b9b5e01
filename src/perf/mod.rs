//! The performance instrument: run time against error (`twintrace perf`,
//! `cargo xtask perf`).
//!
//! Speed counts only at equal error. For every case of a suite and every
//! renderer, [`measure`] renders at doubling sample counts and records the
//! wall time (and the GPU time from timestamp queries), the error against
//! the case's stored high-spp reference (relMSE, RMSE, FLIP), and derives
//! the efficiency `1 / (relMSE × time)` and the time to reach fixed relMSE
//! targets. Throughput rows (paths/s of large renders, incoherent
//! closest-hit rays/s on 10^4- and 10^6-triangle meshes) are diagnostics
//! beside them.
//!
//! - [`suite`]: the cases of the quick and full suites;
//! - [`measure`]: the measurements, one `METRIC` line each on stdout;
//! - [`error`]: relMSE with the reference's own noise taken out;
//! - [`regress`]: the comparison with a saved run and its regression rule;
//! - [`plot`]: the markdown table and the error-vs-time SVG plots;
//! - `run`: what a run records ([`PerfRun`] and its parts) and the
//!   helpers the others share, re-exported here.
//!
//! A run is one [`PerfRun`], written as JSON; a saved run is a baseline.

pub mod error;
pub mod measure;
pub mod plot;
pub mod regress;
mod run;
pub mod suite;

pub use run::*;
