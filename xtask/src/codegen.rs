//! `cargo xtask codegen`: rewrites the generated, checked-in sources from
//! the Rust definitions they mirror (today shaders/generated.wgsl:
//! constants, tags, bindings and record structs). The generator lives in
//! the `gpu` crate next to what it reads; its freshness test rewrites a
//! stale file when `TWINTRACE_CODEGEN=write`, and fails without it (which
//! is how CI notices a file nobody regenerated).

use crate::util::run;

pub fn run_codegen() -> Result<(), String> {
    std::env::set_var("TWINTRACE_CODEGEN", "write");
    run(
        "cargo",
        &[
            "test",
            "-q",
            "-p",
            "gpu",
            "--lib",
            "generated_wgsl_is_current",
        ],
    )
}
