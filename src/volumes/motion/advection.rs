//! Volumes moved by their velocity fields over the shutter (Eulerian motion
//! blur): a lookup at time t (frames relative to the frame) reads the
//! volume's grids at x - t v(x), first-order semi-Lagrangian backward
//! advection, as Cycles does (Kim and Ko 2007, "Eulerian Motion Blur", §3,
//! take two half steps instead; one step is exact for the uniform and
//! slowly varying fields of a shutter's fraction of a frame and costs one
//! velocity lookup per density lookup). docs/volumes.md, "Motion blur".
//!
//! Velocities are in the VDB's world units (the Volume prim's space) per
//! second, scaled by `motion:velocityScale` and converted to per frame by
//! the stage's `timeCodesPerSecond`; the field is sampled where the density
//! is, through each grid's own transform, so a velocity grid need not share
//! the density grid's voxels.

use std::sync::Arc;

use glam::{Affine3A, Mat3A, Vec3};

use crate::scene::VolumeField;
use crate::volumes::grid::{GridTransform, SparseGrid, VdbFile, VolumeError};
use crate::volumes::placement::to_f32;

/// A velocity field read once: its x, y and z components as float grids.
pub(in crate::volumes) struct VelocityField {
    /// Components, world units per second, each with its own transform.
    components: [SparseGrid; 3],
    /// Per component, the smallest and largest value any trilinear lookup
    /// can return, world units per second (stored values and background).
    ranges: [(f32, f32); 3],
}

impl VelocityField {
    /// Reads `field`: a vec3s grid (`vel`, `v`), or a float grid named
    /// `NAME.x`, `NAME.y` or `NAME.z` together with the other two.
    pub(in crate::volumes) fn read(field: &VolumeField) -> Result<Self, VolumeError> {
        let file = VdbFile::open(&field.file)?;
        let index = field.index as usize;
        let at = file.find(&field.grid, index)?;
        let value_type = &file.grids()[at].value_type;
        let components = match (value_type.as_str(), split_stem(&field.grid)) {
            ("float", Some(stem)) => {
                let read = |axis: &str| file.read_float_grid(&format!("{stem}.{axis}"), index);
                [read("x")?, read("y")?, read("z")?]
            }
            ("float", None) => {
                return Err(VolumeError::NotVector {
                    path: field.file.clone(),
                    grid: field.grid.clone(),
                    value_type: value_type.clone(),
                })
            }
            _ => file.read_vector_grid(&field.grid, index)?,
        };
        let range = |g: &SparseGrid| {
            let s = g.stats();
            (
                s.min_value.min(g.background()),
                s.max_value.max(g.background()),
            )
        };
        let ranges = components.each_ref().map(range);
        Ok(Self { components, ranges })
    }

    /// NaN and infinite values over the three components (read as a zero
    /// velocity).
    pub(in crate::volumes) fn non_finite_count(&self) -> usize {
        self.components
            .iter()
            .map(|g| g.stats().non_finite_count)
            .sum()
    }

    /// Bytes held by the three component grids.
    pub(in crate::volumes) fn memory_bytes(&self) -> usize {
        self.components.iter().map(SparseGrid::memory_bytes).sum()
    }
}

/// `NAME` of a grid named `NAME.x`, `NAME.y` or `NAME.z`.
fn split_stem(grid: &str) -> Option<&str> {
    let (stem, axis) = grid.rsplit_once('.')?;
    matches!(axis, "x" | "y" | "z").then_some(stem)
}

/// A velocity field placed in one density grid's index space.
pub(in crate::volumes) struct Advection {
    field: Arc<VelocityField>,
    /// Density index point to each component's index point.
    component_from_density: [Affine3A; 3],
    /// Velocity (world units per second) to the density-index displacement
    /// it makes in one frame: the grid's index-from-world linear part x
    /// velocityScale / timeCodesPerSecond.
    index_per_frame: Mat3A,
}

impl Advection {
    /// `field` moving the density grid of transform `density`;
    /// `units_per_frame` is velocityScale / timeCodesPerSecond.
    pub(in crate::volumes) fn new(
        field: Arc<VelocityField>,
        density: &GridTransform,
        units_per_frame: f32,
    ) -> Self {
        let component_from_density = field
            .components
            .each_ref()
            .map(|g| to_f32(&(g.transform().index_from_world * density.world_from_index)));
        let index_per_frame =
            Mat3A::from(density.index_from_world.matrix3.as_mat3()) * units_per_frame;
        Self {
            field,
            component_from_density,
            index_per_frame,
        }
    }

    /// The field it samples.
    pub(in crate::volumes) fn field(&self) -> &Arc<VelocityField> {
        &self.field
    }

    /// How far, in density index units, the lookup at index point `p` and
    /// time `time` (frames) moves back: time x v(p) in index units, so the
    /// medium there holds what was at `p - displacement` at the frame. A
    /// non-finite velocity reads as zero.
    #[inline]
    pub(in crate::volumes) fn displacement(&self, p: Vec3, time: f32) -> Vec3 {
        let [x, y, z] = &self.field.components;
        let [mx, my, mz] = &self.component_from_density;
        let v = Vec3::new(
            x.trilinear_index(mx.transform_point3(p)),
            y.trilinear_index(my.transform_point3(p)),
            z.trilinear_index(mz.transform_point3(p)),
        );
        if !v.is_finite() {
            return Vec3::ZERO;
        }
        self.index_per_frame * (v * time)
    }

    /// Per density index axis, the range of [`Self::displacement`] over
    /// every lookup at times in `[open, close]` (frames), as (min, max):
    /// what the medium's majorant grid is dilated by. Interval arithmetic
    /// over the components' value ranges, the linear map and the times.
    pub(in crate::volumes) fn reach(
        field: &VelocityField,
        density: &GridTransform,
        units_per_frame: f32,
        (open, close): (f32, f32),
    ) -> (Vec3, Vec3) {
        let m = density.index_from_world.matrix3.transpose() * f64::from(units_per_frame);
        let m = m.as_mat3();
        let row = |r: Vec3| {
            let (mut lo, mut hi) = (0.0f32, 0.0f32);
            for (w, (a, b)) in r.to_array().into_iter().zip(field.ranges) {
                lo += (w * a).min(w * b);
                hi += (w * a).max(w * b);
            }
            let ends = [open * lo, open * hi, close * lo, close * hi];
            let min = ends.into_iter().fold(f32::INFINITY, f32::min);
            (min, ends.into_iter().fold(f32::NEG_INFINITY, f32::max))
        };
        let [(x0, x1), (y0, y1), (z0, z1)] = [row(m.x_axis), row(m.y_axis), row(m.z_axis)];
        (Vec3::new(x0, y0, z0), Vec3::new(x1, y1, z1))
    }
}
