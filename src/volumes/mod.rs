//! Heterogeneous volumes from OpenVDB grids.
//!
//! A `.vdb` file is opened through the OpenVDB bridge ([`VdbFile`]) and each
//! float grid the scene needs is copied once into a [`SparseGrid`], which the
//! renderer samples (nearest or trilinear, index or world space) without
//! crossing the FFI. Sampling follows OpenVDB's `BoxSampler` exactly; see
//! `CONVENTIONS.md` for where voxel values sit and how density is scaled.

mod grid;
mod majorant;
mod medium;
mod phase;
mod tracking;
mod vdb;

pub use grid::{GridAccessor, GridStats, GridTransform, LayoutError, SparseGrid, Tile};
pub use majorant::{MajorantGrid, MajorantKind, MajorantSegment, MajorantSegments};
pub use medium::{Media, MediaRay};
pub use phase::{HenyeyGreenstein, PhaseSample};
pub use tracking::{
    delta_tracking, transmittance, TrackingStats, TransmittanceEstimator,
    RUSSIAN_ROULETTE_THRESHOLD,
};
pub use vdb::{GridInfo, Space, VdbFile, VolumeError};
