//! The lab: benchmarks and studies that measure the renderer rather than
//! run it. Each study prints Markdown tables headed by the machine, date
//! and commit, so that every number in the README can be rerun, and some
//! write CSVs and log-log SVG charts beside them. Never used by the
//! renderer, nor by tests as timings. Part of the library (the CLI's
//! `bench` and `converge` commands only parse flags and call in), so tests
//! can call it; its errors are [`LabError`]s.
//!
//! Studies, one file each (the convergence study a folder), import only
//! the shared helpers, never each other:
//! - `instances`: ingest time and memory of a PointInstancer stage.
//! - `points_curves`: build time, memory and ray rates of points and hair curves.
//! - `vdb`: the sparse grid layout's load time, memory and lookup rates.
//! - `render`: ray rates and equal-time MSE of the estimators and samplers.
//! - `volumes`: majorants and volume estimators at equal time.
//! - `fire`: emitting volumes as lights, light sampling on and off.
//! - `aovs`: what the AOVs cost to render and write.
//! - `looks`: the shader ball's sample rate, the chess set's load time and memory.
//! - `converge`: error against spp and time per method, with peers.
//!
//! Shared helpers: `stats` (medians, Student-t intervals, log-log slopes),
//! `machine` (the machine line, the worker pool), `metrics` (relMSE, MSE,
//! bias), `scenes` (default scenes from `scenes/`, names, loading),
//! `reference` (base settings, cached references), `equal_time` (ladders
//! of renders read off at equal time), `markdown` (table cells), `chart`
//! (SVG charts), `files` (CSV and text files), `peers` (the peer
//! renderers, driven through `scenes/peers/render_peer.py`).

mod adaptive;
mod aovs;
mod chart;
mod converge;
mod equal_time;
mod files;
mod fire;
mod instances;
mod looks;
mod machine;
mod markdown;
mod metrics;
mod motion;
mod peers;
mod points_curves;
mod reference;
mod render;
mod scenes;
mod stats;
mod subdivision;
mod vdb;
mod volumes;

use crate::file_error::FileError;

use thiserror::Error;

use crate::image::ImageError;
use crate::render_state::RenderStateError;
use crate::scene::{ExportError, OpenError, SceneError};
use crate::volumes::grid::VolumeError;

pub use adaptive::run as bench_adaptive;
pub use aovs::{run as bench_aovs, AovsBench};
pub use converge::{parse_method, run as converge, ConvergeOptions, Method};
pub use equal_time::{EqualTimeBench, EqualTimeDefaults};
pub use fire::{run as bench_fire, DEFAULTS as FIRE_DEFAULTS};
pub use instances::{print_memory as instances_memory, run as bench_instances, InstancesBench};
pub use looks::{print_memory as looks_memory, run as bench_looks, LooksBench};
pub use motion::{run as bench_motion, MotionBench};
pub use peers::Peer;
pub use points_curves::{run as bench_points_curves, PointsCurvesBench};
pub use render::{run as bench_render, DEFAULTS as RENDER_DEFAULTS};
pub use subdivision::run as bench_subdivision;
pub use vdb::{run as bench_vdb, VdbBench};
pub use volumes::{run as bench_volumes, DEFAULTS as VOLUMES_DEFAULTS};

/// Why a benchmark or study stopped. Printed with its causes (`{e:#}`),
/// each variant reads as the one line it replaces.
#[derive(Debug, Error)]
pub enum LabError {
    /// A study that cannot go on; the message says why.
    #[error("{0}")]
    Failed(String),
    /// A file or folder operation failed.
    #[error(transparent)]
    File(#[from] FileError),
    /// A system call or a child process failed.
    #[error("{doing}")]
    System {
        /// What was being done: `running <script>`, `finding the cirrus
        /// executable`, a file or folder, ...
        doing: String,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// What the OS said, alone (`bench aovs`'s output folder and EXR sizes).
    #[error(transparent)]
    Os(std::io::Error),
    /// A scene that could not be opened (exported or loaded).
    #[error(transparent)]
    Open(#[from] OpenError),
    /// An exported scene that could not be read.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A USD stage that could not be exported.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// A render state that could not be built.
    #[error(transparent)]
    RenderState(#[from] RenderStateError),
    /// An EXR (a reference, a benchmark's film) that could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A VDB file or grid that could not be read.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The worker pool could not be started.
    #[error(transparent)]
    Threads(#[from] rayon::ThreadPoolBuildError),
}

impl LabError {
    /// A [`LabError::System`] error.
    fn system(doing: impl Into<String>, source: std::io::Error) -> Self {
        Self::System {
            doing: doing.into(),
            source,
        }
    }
}

/// A lab result: [`LabError`] unless said otherwise.
pub type Result<T, E = LabError> = std::result::Result<T, E>;
