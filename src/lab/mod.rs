//! The lab: benchmarks and studies that measure the renderer rather than
//! run it. Each study prints Markdown tables headed by the machine, date
//! and commit, so that every number in the README can be rerun, and some
//! write CSVs and log-log SVG charts beside them. Never used by the
//! renderer, nor by tests as timings.
//!
//! Studies, one file each (the convergence study a folder), import only
//! the shared helpers, never each other:
//! - `instances`: ingest time and memory of a PointInstancer stage.
//! - `vdb`: the sparse grid layout's load time, memory and lookup rates.
//! - `render`: ray rates and equal-time MSE of the estimators and samplers.
//! - `volumes`: majorants and volume estimators at equal time.
//! - `fire`: emitting volumes as lights, light sampling on and off.
//! - `aovs`: what the AOVs cost to render and write.
//! - `converge`: error against spp and time per method, with peers.
//!
//! Shared helpers: `stats` (medians, Student-t intervals, log-log slopes),
//! `machine` (the machine line, the worker pool), `metrics` (relMSE, MSE,
//! bias), `scenes` (default scenes from `scenes/`, names, loading),
//! `reference` (base settings, cached references), `equal_time` (ladders
//! of renders read off at equal time), `markdown` (table cells), `chart`
//! (SVG charts), `files` (CSV and text files), `peers` (the peer
//! renderers, driven through `scenes/peers/render_peer.py`).

mod aovs;
mod chart;
mod converge;
mod equal_time;
mod files;
mod fire;
mod instances;
mod machine;
mod markdown;
mod metrics;
mod peers;
mod reference;
mod render;
mod scenes;
mod stats;
mod vdb;
mod volumes;

pub use aovs::{run as bench_aovs, AovsBench};
pub use converge::{parse_method, run as converge, ConvergeOptions, Method};
pub use equal_time::EqualTimeBench;
pub use fire::run as bench_fire;
pub use instances::{print_memory as instances_memory, run as bench_instances, InstancesBench};
pub use peers::Peer;
pub use render::run as bench_render;
pub use vdb::{run as bench_vdb, VdbBench};
pub use volumes::run as bench_volumes;
