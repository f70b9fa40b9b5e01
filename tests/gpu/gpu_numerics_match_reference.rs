//! The float-stepping routines, GGX Λ and the sphere's roots at their
//! limits, and the cube root, GPU vs reference
//! ([`twintrace::twins::numerics`]).

use crate::common;
use twintrace::twins::{self, numerics};

fn pass(what: &str, outcome: twins::Outcome) {
    match outcome {
        Ok(summary) => println!("{what}: {summary}"),
        Err(e) => panic!("{what}: {e}"),
    }
}

#[test]
fn float_steps_are_bit_identical_on_the_gpu() {
    pass("float steps", numerics::float_steps(common::gpu()));
}

#[test]
fn ggx_lambda_and_sphere_roots_at_their_limits() {
    pass("limits", numerics::limits(common::gpu()));
}

#[test]
fn cube_root_matches_the_reference() {
    pass("cbrt", numerics::cube_root(common::gpu()));
}
