//! Cirrus: a production path tracer for USD scenes and OpenVDB volumes.
//!
//! Data flows one way: scene -> render state -> integrator -> film -> output.
//! The render job (`job/`) drives that pipeline for a frame or a sequence
//! (opening the scene with its memory preflight, checkpoints, the files
//! written); `farm/` splits frames over a cluster and merges their parts.
//! Each folder under `src/` is one concern with its `mod.rs` as the interface;
//! the C++ libraries (OpenVDB, OpenImageIO, OpenSubdiv) are reached only through `ffi/`,
//! mounted privately by `volumes::vdb` and `output::exr`.

pub mod camera;
pub mod choice;
pub mod color;
pub mod farm;
pub mod file_error;
pub mod film;
pub mod geometry;
pub mod host;
pub mod image;
pub mod integrator;
pub mod job;
pub mod lab;
pub mod lights;
pub mod materials;
pub mod memory;
pub mod motion;
pub mod output;
pub mod progress_bar;
pub mod render_state;
pub mod sampling;
pub mod scene;
pub mod subdivision;
pub mod volumes;
