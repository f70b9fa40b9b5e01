//! The GPU's counter-based RNG is bit-identical to the CPU's over a large
//! grid of keys ([`twintrace::twins::rng`]).

use crate::common;
use twintrace::twins;

#[test]
fn rng_streams_are_bit_identical() {
    match twins::rng::streams(common::gpu()) {
        Ok(summary) => println!("rng: {summary}"),
        Err(e) => panic!("{e}"),
    }
}

/// The twin fails a library whose streams differ in one constant: the
/// independent stream's hash (pcg4d's multiplier) or the Sobol' sampler's
/// (the key remix's shift, which moves only the scrambles of the first
/// coordinates).
#[test]
fn an_rng_with_a_defect_fails_the_twin() {
    let library = gpu::shader::library_source();
    for (from, to) in [
        ("v_in * 1664525u", "v_in * 1664527u"),
        ("x ^= x >> 15u;", "x ^= x >> 14u;"),
    ] {
        assert!(library.contains(from), "the WGSL changed: update {from:?}");
        let mutant = library.replacen(from, to, 1);
        let outcome = twins::rng::streams_with_library(common::gpu(), &mutant);
        assert!(outcome.is_err(), "{from:?} -> {to:?} passed the twin");
    }
}
