//! Ray intersection with a scene's triangle meshes, built from a [`Scene`]
//! (which stays plain data).
//!
//! Meshes the scene places once go, in world space, into one BVH over all
//! their triangles, so a ray walks one tree however many of them overlap.
//! Meshes placed more than once keep two levels, as instancing needs: one
//! BVH per such mesh (shared by every instance of it) and a top-level BVH
//! over its placements; a ray enters a mesh through the inverse of its world
//! transform, so memory grows with unique geometry plus one small leaf per
//! placed mesh. Every BVH is obvhs's compressed wide BVH8 (Ylitie, Karras
//! and Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs"), built with PLOC (Meister and Bittner 2018); the
//! top level is built in Morton cells (an LBVH split above PLOC), which
//! keeps its build's peak memory small (see `bvh.rs`). Triangles are tested
//! with the watertight algorithm of Woop, Benthin and Wald (2013), so rays
//! through shared edges and vertices never slip between triangles.
//!
//! Motion blur: a mesh placed by a moving instance always sits under the
//! top level, its box the union of its boxes at the motion keys (exact for
//! the matrix lerp of `crate::motion`), and a ray at time t enters it
//! through the inverse of its transform at t (`motion.rs`).
//!
//! [`Scene`]: crate::scene::Scene

mod boxes;
mod bvh;
mod frame;
mod intersect;
mod motion;
mod round_bvh;
mod round_intersect;
mod round_surface;
mod surface;
mod top_level;

pub use bvh::{Geometry, Hit};
pub use frame::Frame;
pub use motion::MovingInstances;
pub use obvhs::ray::Ray;
pub use surface::{shadow_ray, MeshSite, SurfacePoint};
