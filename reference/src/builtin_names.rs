//! The built-in scenes' names, apart from the scenes (reference/src/builtin.rs)
//! so that the error for an unknown one can list them without using the
//! scene model ([`crate::error::SceneError::UnknownBuiltin`]).

/// Names [`load`](crate::builtin::load) accepts.
pub const NAMES: &[&str] = &["rtow-final", "cornell", "cornell-spheres", "spheres-10k"];
