//! Renders that outlive one process. A render's state is saved in film-state
//! files (`film::write_film_state`) with a header naming whose film it is
//! (`snapshot.rs`): checkpoints (`--checkpoint-every`, SIGINT/SIGTERM) that
//! `--resume` continues bit-identically, and parts of one frame (`--tile`,
//! `--crop`, `--sample-range`, `part.rs`) that `cirrus merge` adds into the
//! frame after checking they fit (`merge.rs`). The files a render writes,
//! checked writable before it starts (`files.rs`), and written or, when that
//! fails, rescued as a film state with the command that writes them
//! (`rescue.rs`), as `-o` or the stage's USD render products say
//! (`products.rs`); frame sequences and their file names (`frames.rs`), split over a Slurm cluster as job arrays
//! (`slurm.rs`).

mod files;
mod frames;
mod merge;
mod part;
mod products;
mod rescue;
mod slurm;
mod snapshot;

use thiserror::Error;

use crate::file_error::FileError;
use crate::film::FilmStateError;
use crate::image::ImageError;
use crate::scene::{ExportError, SceneError};

pub use files::{is_film_output, prepare_folder, Claim, OutputFiles};
pub use frames::{frame_output, has_frame_number, FrameRange};
pub use merge::{merge, Merged};
pub use part::{PartInfo, PartRequest};
pub use products::{plan_outputs, OutputFlags, OutputPlan, ProductOutput};
pub use rescue::{save_interrupted, write_finished, ImageFormat};
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
    /// A finished render's outputs could not be written; its film state was
    /// saved at `state`, and `command` writes them from it.
    #[error("{error}\nthe render is not lost: its film state is saved in {}; once the problem is fixed, write the image with:\n  {command}", state.display())]
    Rescued {
        /// Why the outputs could not be written, with its causes.
        error: String,
        /// The film state saved instead.
        state: std::path::PathBuf,
        /// The shell command that writes the outputs from `state`.
        command: String,
    },
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
