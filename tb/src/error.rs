//! One error type for everything the testbench reads or builds, so a caller (and the CLI) can print
//! which file, which line or element, and what is wrong, without ever panicking on bad input.

use std::path::PathBuf;

/// Errors from loading scenes and building workloads.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its content is wrong; `at` names the line or element.
    #[error("{}: {at}: {what}", path.display())]
    Format { path: PathBuf, at: String, what: String },
    /// A mesh (or a whole scene) has no usable primitive.
    #[error("{}: no triangles left ({dropped} degenerate dropped)", path.display())]
    EmptyMesh { path: PathBuf, dropped: usize },
    /// `load_scene` was given a name that is neither built in nor described in the scenes folder.
    #[error("unknown scene '{name}'; known scenes: {}", known.join(", "))]
    UnknownScene { name: String, known: Vec<String> },
    /// An option combination that cannot produce a workload.
    #[error("invalid option: {0}")]
    Invalid(String),
}

impl Error {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }

    pub(crate) fn format(path: impl Into<PathBuf>, at: impl Into<String>, what: impl Into<String>) -> Self {
        Error::Format { path: path.into(), at: at.into(), what: what.into() }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
