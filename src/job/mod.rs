//! The render job (`cirrus render`): a [`RenderJob`] describes it, plain
//! data with one field per flag, and [`render`] runs it, as pbrt-v4's
//! `RenderCPU` runs what `cmd/pbrt.cpp` parsed.
//!
//! A job renders one frame, or each frame of a range in turn (`sequence.rs`;
//! the frame numbers in file names, `frame_range.rs`). A frame
//! (`frame.rs`) opens its scene with the memory preflight (`open.rs`, which
//! every command that reads a scene uses), plans the files the stage's USD
//! render products or `-o` name (`products.rs`) and claims them before
//! anything is loaded (`files.rs`), takes its part of the frame (`--tile`,
//! `--crop`, `--sample-range`, `part.rs`), and renders with checkpoints:
//! film-state files with a header naming whose film it is (`snapshot.rs`),
//! which `--resume` continues bit-identically. A finished frame is written,
//! or, when that fails, rescued as a film state with the command that
//! writes it; a frame stopped by its caller saves its checkpoint and
//! partial image (`rescue.rs`); SIGINT and SIGTERM can be that caller
//! (`signal.rs`).
//!
//! The job sits above the pipeline (scene, render state, integrator, film,
//! output) and the memory estimate, and below the command line and `farm`,
//! which splits frames over a cluster and merges their parts.

mod files;
mod frame;
mod frame_range;
mod open;
mod parse;
mod part;
mod products;
mod rescue;
mod sequence;
mod signal;
mod snapshot;

use std::path::PathBuf;
use std::time::Duration;

use glam::UVec2;
use thiserror::Error;

use crate::file_error::FileError;
use crate::film::{AdaptiveSampling, AovSet, FilmStateError, FilterKind};
use crate::image::{Compression, ImageError};
use crate::integrator::PathSettings;
use crate::memory::MemoryError;
use crate::motion::Shutter;
use crate::output::AovFiles;
use crate::render_state::RenderStateError;
use crate::sampling::SamplerKind;
use crate::scene::{OpenError, SceneError};
use crate::volumes::majorant::MajorantKind;

pub use files::{is_film_output, prepare_folder, Claim, OutputFiles};
pub use frame_range::{frame_output, has_frame_number, FrameRange};
pub use open::{export, open};
pub use parse::{
    parse_crop, parse_noise_threshold, parse_on_off, parse_resolution, parse_sample_range,
    parse_seconds, parse_tile,
};
pub use part::{PartInfo, PartRequest};
pub use products::{plan_outputs, OutputFlags, OutputPlan, ProductOutput};
pub use rescue::{save_interrupted, shell_quote, write_finished, ImageFormat};
pub use sequence::render;
pub use signal::StopSignal;
pub use snapshot::{
    read_snapshot, resume, write_snapshot, Fingerprint, RenderIdentity, SnapshotHeader,
};

/// Samples per pixel when a job gives neither `spp` nor `time`.
pub const DEFAULT_SPP: u32 = 64;

/// A render of one scene: what to open, how to sample it, where to write
/// it. Each field is a `cirrus render` flag's value (named in its doc);
/// `None` takes the scene's or the machine's own.
#[derive(Clone, Debug)]
pub struct RenderJob {
    /// A USD file (exported through the cache first), a scene folder, or its scene.json.
    pub scene: PathBuf,
    /// `-o`: the EXR (or a part's film state, `.film`) to write; `None`: the
    /// render settings' first product's `productName`. With `frames`, a
    /// frame token in it becomes each frame's number.
    pub output: Option<PathBuf>,
    /// `--spp`: samples per pixel (default [`DEFAULT_SPP`]).
    pub spp: Option<u32>,
    /// `--time`: render whole passes for about this long instead.
    pub time: Option<Duration>,
    /// `--res`: image size, pixels (default: the stage's render settings).
    pub resolution: Option<UVec2>,
    /// `--seed`: seed of every sample sequence.
    pub seed: u64,
    /// `--threads`: worker threads (default: all cores).
    pub threads: Option<u16>,
    /// `--sampler`: the sample sequence.
    pub sampler: SamplerKind,
    /// `--filter`: the pixel filter.
    pub filter: FilterKind,
    /// The path tracer's flags (`--strategy`, `--max-depth`, `--clamp`,
    /// `--volume-estimator`, `--no-equiangular`, `--camera-ray-transmittance`).
    pub path: PathSettings,
    /// `--noise-threshold` and `--min-spp`: adaptive sampling, when on.
    pub adaptive: Option<AdaptiveSampling>,
    /// `--majorant`: majorants of volume extinction.
    pub majorant: MajorantKind,
    /// `--volume-light-sampling`: emitting volumes are sampled as lights.
    pub volume_light_sampling: bool,
    /// `--aovs` (default: the render products' vars, else the default set).
    pub aovs: Option<AovSet>,
    /// `--aov-files`: one multi-channel EXR, or one per AOV.
    pub aov_files: AovFiles,
    /// `--compression`: EXR compression.
    pub compression: Compression,
    /// `--shutter`: interval in frames (default: the camera's).
    pub shutter: Option<Shutter>,
    /// `--frame`: USD time code to export (USD input only).
    pub frame: Option<f64>,
    /// `--frames`: render these USD time codes one after the other.
    pub frames: Option<FrameRange>,
    /// `--camera`: camera prim to render (USD input only).
    pub camera: Option<String>,
    /// `--settings`: `UsdRender.Settings` prim to render (USD input only).
    pub settings: Option<String>,
    /// `--subdiv-level`: level of meshes that author none.
    pub subdiv_level: u32,
    /// `--tile`, `--crop`, `--sample-range`: the part of the frame to take.
    pub part: PartRequest,
    /// `--skip-existing`: render nothing when the output is complete.
    pub skip_existing: bool,
    /// `--checkpoint-every`: save the film state this often.
    pub checkpoint_every: Option<Duration>,
    /// `--preview-every`: rewrite the PNG preview this often.
    pub preview_every: Option<Duration>,
    /// `--resume`: continue the render saved in the output's checkpoint.
    pub resume: bool,
    /// `--memory-limit`: refuse to start above this estimated peak, bytes
    /// (default: what the process may still allocate).
    pub memory_limit: Option<u64>,
}

/// What a running job asks of its caller, and tells it.
pub struct JobControl<'a> {
    /// Polled while rendering: true stops the frame after the tiles in
    /// flight, saves its checkpoint and ends the job with
    /// [`JobError::Interrupted`] (a signal, say).
    pub stop: &'a (dyn Fn() -> bool + Sync),
    /// Called as each frame is done.
    pub done: &'a dyn Fn(&FrameOutcome),
}

/// What a frame of a job did.
#[derive(Debug)]
pub enum FrameOutcome {
    /// `--skip-existing` found this output complete: nothing rendered.
    Complete(PathBuf),
    /// Rendered and written: these files.
    Written(Vec<PathBuf>),
}

/// Why a job, a checkpoint or a part failed.
#[derive(Debug, Error)]
pub enum JobError {
    /// What was asked cannot be done as asked; the message says how to fix it.
    #[error("{0}")]
    Refused(String),
    /// The caller stopped the render; the message says what was saved and
    /// how to resume.
    #[error("{0}")]
    Interrupted(String),
    /// The caller stopped the render, and its checkpoint could not be saved.
    #[error("interrupted, and the checkpoint could not be saved")]
    NotCheckpointed(#[source] Box<JobError>),
    /// A finished render's outputs could not be written; its film state was
    /// saved at `state`, and `command` writes them from it.
    #[error("{error}\nthe render is not lost: its film state is saved in {}; once the problem is fixed, write the image with:\n  {command}", state.display())]
    Rescued {
        /// Why the outputs could not be written, with its causes.
        error: String,
        /// The film state saved instead.
        state: PathBuf,
        /// The shell command that writes the outputs from `state`.
        command: String,
    },
    /// The worker threads could not be started.
    #[error("cannot start worker threads")]
    Threads(#[from] rayon::ThreadPoolBuildError),
    /// A file or folder operation failed.
    #[error(transparent)]
    File(#[from] FileError),
    /// A film-state file (checkpoint or part).
    #[error(transparent)]
    FilmState(#[from] FilmStateError),
    /// An image that could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// The scene could not be opened.
    #[error(transparent)]
    Open(#[from] OpenError),
    /// The scene's subdivision surfaces could not be refined.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The render would not fit in memory, or its estimate cannot be made.
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// The scene cannot be rendered.
    #[error(transparent)]
    RenderState(#[from] RenderStateError),
}
