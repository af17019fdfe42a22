//! A file or folder operation that failed, named so the message says what
//! was being done to what: `cannot create out/bench: No space left on
//! device (os error 28)` (the OS error is the source, printed by the CLI's
//! cause chain). Modules whose work touches files wrap it in their own error.

use std::path::PathBuf;

use thiserror::Error;

/// A failed file or folder operation.
#[derive(Debug, Error)]
#[error("cannot {action} {}", path.display())]
pub struct FileError {
    /// What was being done: `create`, `write`, `remove`, `run`, ...
    pub action: &'static str,
    /// The file, folder or program.
    pub path: PathBuf,
    /// What the OS said.
    #[source]
    pub source: std::io::Error,
}

impl FileError {
    /// `action` on `path` failed with `source`.
    pub fn new(action: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self {
            action,
            path: path.into(),
            source,
        }
    }
}
