//! One frame over many processes and machines: a frame rendered in parts
//! (`cirrus render --tile/--crop/--sample-range -o PART.film`, a job's
//! `PartRequest`) is joined by `cirrus merge`, which checks that the parts'
//! film states fit together and adds them into the frame (`merge.rs`); a
//! frame range is split into such parts over a Slurm cluster as job arrays
//! (`slurm.rs`). What each part renders, checkpoints and writes is the
//! render job's (`crate::job`).

mod merge;
mod slurm;

use thiserror::Error;

use crate::file_error::FileError;
use crate::image::ImageError;
use crate::job::JobError;
use crate::scene::ExportError;

pub use merge::{merge, Merged};
pub use slurm::{submit, SlurmJob, SplitBy, Submitted};

/// Why a merge or a farm submission failed.
#[derive(Debug, Error)]
pub enum FarmError {
    /// What was asked cannot be done as asked; the message says how to fix it.
    #[error("{0}")]
    Refused(String),
    /// A part's film state, or the files of the merged frame.
    #[error(transparent)]
    Job(#[from] JobError),
    /// A file or folder operation failed.
    #[error(transparent)]
    File(#[from] FileError),
    /// An image that could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A USD stage that could not be exported.
    #[error(transparent)]
    Export(#[from] ExportError),
}
