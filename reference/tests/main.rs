//! The reference crate's integration tests: one crate of modules (one test
//! binary). `embree_agreement` needs the cargo feature `embree` (the Intel
//! Embree 4 oracle, which `cargo xtask test` installs and switches on).

mod common;

mod bvh_property;
#[cfg(feature = "embree")]
mod embree_agreement;
mod fuzz_regressions;
mod numerical_stability;
