//! Renders that outlive one process. A render's state is saved in film-state
//! files (`film::write_film_state`) with a header naming whose film it is
//! (`snapshot.rs`): checkpoints (`--checkpoint-every`, SIGINT/SIGTERM) that
//! `--resume` continues bit-identically, and parts of one frame (`--tile`,
//! `--crop`, `--sample-range`, `part.rs`) that `cirrus merge` adds into the
//! frame after checking they fit (`merge.rs`). The files a render writes and
//! the refusal to overwrite them (`files.rs`); frame ranges split over a Slurm
//! cluster as job arrays (`slurm.rs`).

mod files;
mod merge;
mod part;
mod slurm;
mod snapshot;

use thiserror::Error;

use crate::file_error::FileError;
use crate::film::FilmStateError;
use crate::image::ImageError;
use crate::scene::{ExportError, SceneError};

pub use files::{is_film_output, OutputFiles};
pub use merge::{merge, Merged};
pub use part::{PartInfo, PartRequest};
pub use slurm::{submit, SlurmJob, SplitBy, Submitted};
pub use snapshot::{
    read_snapshot, resume, write_snapshot, Fingerprint, RenderIdentity, SnapshotHeader,
};

/// Why a checkpoint, a part, a merge or a farm submission failed.
#[derive(Debug, Error)]
pub enum FarmError {
    /// What was asked cannot be done as asked; the message says how to fix it.
    #[error("{0}")]
    Refused(String),
    /// A file or folder operation failed.
    #[error(transparent)]
    File(#[from] FileError),
    /// A film-state file (checkpoint or part).
    #[error(transparent)]
    FilmState(#[from] FilmStateError),
    /// An image that could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A scene that could not be read.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A USD stage that could not be exported.
    #[error(transparent)]
    Export(#[from] ExportError),
}
