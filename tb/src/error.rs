//! One error type for everything the testbench reads or builds, so a caller (and the CLI) can print
//! which file, which line or element, and what is wrong, without ever panicking on bad input.

use std::path::PathBuf;

/// Errors from loading scenes and building workloads.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened or read. The cause is in the message, not chained as a
    /// source, so `{:#}` does not print it twice.
    #[error("{}: {error}", path.display())]
    Io { path: PathBuf, error: std::io::Error },
    /// A file was read but its content is wrong; `at` names the line or element.
    #[error("{}: {at}: {what}", path.display())]
    Format { path: PathBuf, at: String, what: String },
    /// A mesh (or a whole scene) has no usable primitive; `why` says what the file held instead.
    #[error("{}: no triangles: {why}", path.display())]
    EmptyMesh { path: PathBuf, why: String },
    /// `load_scene` was given a name that is neither built in nor described, nor a scene file.
    #[error(
        "unknown scene '{name}': not a scene name ({}), nor a path to a mesh (.obj, .ply, .glb, .gltf, optionally .gz) or a .toml description",
        known.join(", ")
    )]
    UnknownScene { name: String, known: Vec<String> },
    /// A scene was given as a folder, not as a name or a file.
    #[error(
        "{}: is a directory; a scene is a name, a mesh file (.obj, .ply, .glb, .gltf, optionally .gz) or a .toml description",
        path.display()
    )]
    SceneIsDirectory { path: PathBuf },
    /// A shipped description's mesh is not in the shared scene folder.
    #[error(
        "{}: no such mesh file; the {scene} reads it from {origin}. Point sms at the folder holding it with --scenes-dir DIR or the SMS_SCENES_DIR environment variable",
        file.display()
    )]
    MissingData { file: PathBuf, scene: String, origin: String },
    /// An option combination that cannot produce a workload.
    #[error("invalid option: {0}")]
    Invalid(String),
    /// The model failed one of its own checks while running (a pop the reference stack
    /// disagrees with, a warp leaving stack state behind, a stall): a bug of the design, not of
    /// the input.
    #[error("design check failed: {0}")]
    DesignCheck(String),
}

impl Error {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), error: source }
    }

    pub(crate) fn format(path: impl Into<PathBuf>, at: impl Into<String>, what: impl Into<String>) -> Self {
        Error::Format { path: path.into(), at: at.into(), what: what.into() }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
