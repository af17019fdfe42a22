//! Heterogeneous volumes from OpenVDB grids.
//!
//! A `.vdb` file is opened through the OpenVDB bridge ([`VdbFile`]) and each
//! float grid the scene needs is copied once into a [`SparseGrid`], which the
//! renderer samples (nearest or trilinear, index or world space) without
//! crossing the FFI. Sampling follows OpenVDB's `BoxSampler` exactly; see
//! docs/conventions.md, "Voxel centres" and "Extinction and scattering", for
//! where voxel values sit and how density is scaled.
//!
//! Rendering: [`Media`] places every Volume in the world; a [`MajorantGrid`]
//! per grid bounds its trilinear density per 8^3-voxel cell (split into
//! sub-cells where density varies, with `MajorantKind::Adaptive`: the
//! criterion of Pixar's "Elemental" talk, refine.rs) and is walked by a 3D
//! DDA (Amanatides and Woo 1987) into [`MajorantSegment`]s; over those,
//! [`walk_tentative_collisions`] samples free flights and [`transmittance`] estimates
//! shadow-ray transmittance by ratio, residual ratio (Novák et al. 2014,
//! "Residual Ratio Tracking for Estimating Attenuation in Participating
//! Media") or track-length estimation (Novák, Georgiev, Hanika and Jarosz
//! 2018, "Monte Carlo Methods for Volumetric Light Transport Simulation");
//! scattering uses the Henyey-Greenstein (1941) phase function.

mod advection;
mod checks;
mod dda;
mod emission;
mod emitter;
mod fields;
mod grid;
mod grid_table;
mod lookup;
mod majorant;
mod medium;
mod moving;
mod near_picks;
mod overlap;
mod pass_through;
mod phase;
mod placement;
mod ray_marching;
mod refine;
mod stats;
mod tracking;
mod vdb;

pub use dda::{MajorantSegment, MajorantSegments};
pub use emission::{BlackbodyTable, REFERENCE_TEMPERATURE_K};
pub use grid::{GridStats, GridTransform, LayoutError, SparseGrid, Tile};
pub use grid_table::grid_table;
pub use lookup::GridAccessor;
pub use majorant::{MajorantGrid, MajorantKind};
pub use medium::{Emitter, Media, MediaRay, MediumPoint, RaySegments};
pub(crate) use near_picks::NearImportance;
pub use pass_through::PassThrough;
pub use phase::{HenyeyGreenstein, PhaseSample};
pub use stats::TrackingStats;
pub use tracking::{
    channel_mean, ratio_tracking_with_null_ratio, transmittance, walk_tentative_collisions,
    TransmittanceEstimator, RUSSIAN_ROULETTE_THRESHOLD,
};
pub use vdb::{GridInfo, Space, VdbFile, VolumeError};
