//! Heterogeneous volumes from OpenVDB grids.
//!
//! A `.vdb` file is opened through the OpenVDB bridge ([`VdbFile`]) and each
//! float grid the scene needs is copied once into a [`SparseGrid`], which the
//! renderer samples (nearest or trilinear, index or world space) without
//! crossing the FFI. Sampling follows OpenVDB's `BoxSampler` exactly; see
//! `CONVENTIONS.md` for where voxel values sit and how density is scaled.

mod grid;
mod vdb;

pub use grid::{GridAccessor, GridStats, GridTransform, LayoutError, SparseGrid, Tile};
pub use vdb::{GridInfo, Space, VdbFile, VolumeError};
