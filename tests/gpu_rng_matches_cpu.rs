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
