//! Volumes that move over the shutter (docs/volumes.md, "Motion blur"): by
//! their velocity fields, read at x - t v(x) (advection.rs, Kim and Ko
//! 2007, "Eulerian Motion Blur"), or by their transforms, rays carried into
//! index space by the placement at their time (moving.rs).

mod advection;
mod moving;

pub(in crate::volumes) use advection::{Advection, VelocityField};
pub(in crate::volumes) use moving::PlacementMotion;
