//! glTF coverage on the GPU: `alpha_covers` decides as the reference does
//! on the same triangles, points and rays (`twintrace::twins::coverage`,
//! also in `twintrace selftest`), and a kernel that leaves the vertex
//! colour's alpha out (an audit's planted defect, caught before only by a
//! stored reference) fails it.

use crate::common;
use twintrace::twins::coverage as twin;

#[test]
fn coverage_decides_as_the_reference_does() {
    match twin::all(common::gpu()) {
        Ok(s) => println!("{s}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_coverage_without_the_vertex_alpha_fails_the_twin() {
    let library = gpu::shader::library_source();
    let from = "vertex_alpha = b0 * ea.a + b1 * eb.a + b2 * ec.a;";
    assert_eq!(library.matches(from).count(), 1);
    let mutant = library.replace(from, "vertex_alpha = 1.0;");
    let e = twin::with_library(common::gpu(), &mutant)
        .expect_err("coverage without the vertex alpha passed the twin");
    println!("caught: {e}");
    // BLEND's hash of another ray's bits, too.
    let from = "return alpha_hash(ray, prim) < alpha;";
    assert_eq!(library.matches(from).count(), 1);
    let mutant = library.replace(from, "return alpha_hash(ray, prim + 1u) < alpha;");
    let e = twin::with_library(common::gpu(), &mutant)
        .expect_err("BLEND with another hash passed the twin");
    println!("caught: {e}");
}
