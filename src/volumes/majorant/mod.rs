//! Majorants: bounds on a [`SparseGrid`](crate::volumes::grid::SparseGrid)'s
//! trilinear density, so null-collision trackers (Novák et al. 2018, §4)
//! sample against a tight local bound and skip empty space, as pbrt-v4's
//! `MajorantGrid` does. cells.rs: a [`MajorantGrid`] per grid, one cell per
//! 8^3-voxel block with its max, min and support box; refine.rs: cells
//! split into sub-cells where density varies (`MajorantKind::Adaptive`, the
//! criterion of Pixar's "Elemental" talk); dda.rs: the 3D DDA (Amanatides
//! and Woo 1987) that walks them along a ray into
//! [`MajorantSegment`](crate::volumes::MajorantSegment)s.

mod cells;
mod dda;
mod refine;

pub(crate) use cells::OccupiedCell;
pub use cells::{MajorantGrid, MajorantKind};
pub use dda::MajorantSegments;
