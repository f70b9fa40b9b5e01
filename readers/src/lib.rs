//! What twintrace reads from its users, as pure functions: bytes or text
//! in, values or an error out, nothing read from or written to disk.
//!
//! - [`exr`]: the render EXR that `diff` and `merge` read
//!   (`twintrace::image_io`'s layout), from any `Read + Seek`.
//! - [`partial`]: a partial film's exact sums and key from a decoded EXR
//!   (`twintrace::partial`'s channels and attributes).
//! - [`text`]: the command line's counts, `--samples A..B`, `--size
//!   WxH` and `--time` durations.
//!
//! The root crate calls these; `fuzz/` fuzzes them (docs/fuzzing.md), so
//! this crate has no GPU or window dependency.

pub mod exr;
pub mod partial;
pub mod text;
