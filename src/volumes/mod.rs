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
//! criterion of Pixar's "Elemental" talk, majorant/refine.rs) and is walked by a 3D
//! DDA (Amanatides and Woo 1987) into [`MajorantSegment`]s; over those,
//! [`walk_tentative_collisions`] samples free flights and [`transmittance`] estimates
//! shadow-ray transmittance by ratio, residual ratio (Novák et al. 2014,
//! "Residual Ratio Tracking for Estimating Attenuation in Participating
//! Media") or track-length estimation (Novák, Georgiev, Hanika and Jarosz
//! 2018, "Monte Carlo Methods for Volumetric Light Transport Simulation");
//! scattering uses the Henyey-Greenstein (1941) phase function.

//!
//! The folder by job, each sub-folder's `mod.rs` its interface and its papers:
//! - [`grid`]: the grid data: [`grid::SparseGrid`], its lookups, and reading
//!   `.vdb` files through the OpenVDB bridge ([`grid::VdbFile`]).
//! - [`majorant`]: bounds on density per cell ([`majorant::MajorantGrid`],
//!   adaptive sub-cells) and the DDA that walks them along a ray.
//! - [`estimators`]: free flights and transmittance over majorant segments
//!   (delta, ratio, residual ratio, track-length, ray marching, the camera
//!   ray's pass-through weight) and the counters they add to.
//! - [`emission`]: what a volume emits (blackbody) and where, for sampling
//!   it as a light (its cells, picked by power or from near by).
//! - `motion/`: volumes moved over the shutter by a velocity field or by
//!   their transforms.
//!
//! Here, tying them: [`Media`] (medium.rs), the scene's volumes placed in the
//! world, built step by step (assembly.rs) from the scene's fields (fields.rs,
//! checked by checks.rs); [`MajorantSegment`] (segment.rs), the stretch of
//! ray the majorant grids yield and the estimators walk, merged where media
//! overlap (overlap.rs); the phase function (phase.rs); and placement.rs,
//! the affine maps' helpers.

mod assembly;
mod checks;
pub mod emission;
pub mod estimators;
mod fields;
pub mod grid;
pub mod majorant;
mod medium;
mod motion;
mod overlap;
mod phase;
mod placement;
mod segment;

pub use medium::{Emitter, Media, MediaRay, MediumPoint, RaySegments};
pub use phase::{HenyeyGreenstein, PhaseSample};
pub use segment::MajorantSegment;
