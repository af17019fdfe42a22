//! The grid data: a `.vdb` file opened through the OpenVDB bridge
//! ([`VdbFile`], the only module that talks to OpenVDB) and each float grid
//! copied once into a [`SparseGrid`] (sparse.rs: two levels over OpenVDB's
//! own 8^3 leaf blocks, bricks with a one-voxel apron), which the renderer
//! samples (nearest or trilinear, index or world space, lookup.rs) without
//! crossing the FFI, exactly as OpenVDB's `PointSampler` and `BoxSampler`
//! do (docs/conventions.md, "Voxel centres"). table.rs prints a file's grid
//! table for `cirrus info`.

mod lookup;
mod sparse;
mod table;
mod vdb;

pub use lookup::GridAccessor;
pub(in crate::volumes) use sparse::blocks_spanned;
pub use sparse::{GridStats, GridTransform, LayoutError, SparseGrid, Tile};
pub use table::grid_table;
pub use vdb::{GridInfo, Space, VdbFile, VolumeError};
