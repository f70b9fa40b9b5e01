//! The surface interaction and the spawn point, GPU vs reference
//! ([`twintrace::twins::surface`], which says what is exact and what is
//! bounded, and why).

use crate::common;
use twintrace::twins::{self, surface};

fn pass(what: &str, outcome: twins::Outcome) {
    match outcome {
        Ok(summary) => println!("{what}: {summary}"),
        Err(e) => panic!("{what}: {e}"),
    }
}

/// Spheres (rtow-final), quads (cornell), triangles with shading normals
/// and uv (the glTF fixture).
#[test]
fn surface_interactions_match_the_reference() {
    pass("surface interactions", surface::all_scenes(common::gpu()));
}

#[test]
fn spawn_points_match_the_reference() {
    pass("spawn points", surface::spawn_points(common::gpu()));
}
