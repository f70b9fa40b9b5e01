//! Scene errors: each names where the problem is (file, field, and for
//! JSON the line and column) so the CLI can print one clear line.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A value the scene model rejects; `field` is a path like
    /// `objects[3].radius` or `camera.vfov`.
    #[error("{field}: {message}")]
    Invalid { field: String, message: String },
    /// The document does not parse or does not match the format.
    #[error("{path}:{line}:{column}: {field}{sep}{message}", path = path.display(), sep = if field.is_empty() { "" } else { ": " })]
    Parse {
        path: PathBuf,
        line: usize,
        column: usize,
        field: String,
        message: String,
    },
    /// A file the scene refers to (or the scene itself) cannot be read.
    #[error("{path}: {message}", path = path.display())]
    Io { path: PathBuf, message: String },
    /// A problem inside a scene file, with the file named. The problem is
    /// part of this message and not an error source, so that a printer of
    /// the source chain (anyhow's `{:#}`) does not say it twice.
    #[error("{path}: {problem}", path = path.display())]
    InFile {
        path: PathBuf,
        problem: Box<SceneError>,
    },
    /// A built-in scene name that does not exist.
    #[error("unknown built-in scene `{0}` (known: {known})", known = crate::builtin_names::NAMES.join(", "))]
    UnknownBuiltin(String),
}

impl SceneError {
    pub fn invalid(field: &str, message: String) -> Self {
        SceneError::Invalid {
            field: field.to_string(),
            message,
        }
    }

    /// Prefixes the field path of an `Invalid` error (`radius` → `objects[3].radius`).
    pub fn within(self, prefix: &str) -> Self {
        match self {
            SceneError::Invalid { field, message } => SceneError::Invalid {
                field: if field.is_empty() {
                    prefix.to_string()
                } else {
                    format!("{prefix}.{field}")
                },
                message,
            },
            other => other,
        }
    }

    /// Attaches the file the error was found in.
    pub fn in_file(self, path: impl Into<PathBuf>) -> Self {
        match self {
            e @ (SceneError::Parse { .. } | SceneError::Io { .. } | SceneError::InFile { .. }) => e,
            e => SceneError::InFile {
                path: path.into(),
                problem: Box::new(e),
            },
        }
    }
}
