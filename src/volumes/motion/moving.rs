//! Volumes moved by their transforms over the shutter (a Volume prim, or an
//! instance placing one, whose xform is keyed inside it: `instances.motion`).
//! docs/volumes.md, "Motion blur".
//!
//! The grid, its majorant grid and its emission cells stay in index space,
//! untouched: a ray at time t (frames) is carried into index space by the
//! inverse of the placement at t, where it is still a straight line with
//! the same parameter (an affine map keeps lines and ratios), so the DDA,
//! free-flight sampling and every lookup along it run as for a still
//! volume, and the majorants stay exactly as conservative (pbrt-v4 moves
//! media with their `AnimatedTransform` the same way). The world box that
//! rejects rays is the union of the box's images at the keys: under matrix
//! lerp every point moves through convex combinations of its key positions
//! (`crate::motion`).

use glam::{Affine3A, DAffine3, Vec3};

use crate::motion::TransformTrack;
use crate::volumes::placement::{to_f32, to_f64, world_box};

/// A placed grid's world-from-index map keyed over the shutter.
pub(in crate::volumes) struct PlacementMotion {
    /// World-from-index keys: the instance's world-from-volume keys times
    /// the grid's volume-from-index map (lerping either gives the same).
    world_from_index: TransformTrack,
}

impl PlacementMotion {
    /// The motion of a grid whose volume moves by `world_from_volume`, with
    /// `volume_from_index` the grid's own transform.
    pub(in crate::volumes) fn new(
        world_from_volume: &TransformTrack,
        volume_from_index: &DAffine3,
    ) -> Self {
        let keys = world_from_volume
            .keys()
            .iter()
            .map(|key| to_f32(&(to_f64(key) * *volume_from_index)))
            .collect();
        Self {
            world_from_index: TransformTrack::new(world_from_volume.times().to_vec(), keys)
                .expect("the keys of a valid track, re-placed"),
        }
    }

    /// World (scene units) to index space at `time` (frames); non-finite
    /// where the placement then collapses the grid (no density is read
    /// there: [`Self::index_ray`] gives such rays nothing to cross).
    pub(in crate::volumes) fn index_from_world(&self, time: f32) -> Affine3A {
        self.world_from_index.at(time).inverse()
    }

    /// The index-space ray of world ray `origin + t direction` at `time`,
    /// with the same parameter t; `None` where the placement collapses.
    pub(in crate::volumes) fn index_ray(
        &self,
        origin: Vec3,
        direction: Vec3,
        time: f32,
    ) -> Option<(Vec3, Vec3)> {
        let m = self.index_from_world(time);
        let ray = (m.transform_point3(origin), m.transform_vector3(direction));
        (ray.0.is_finite() && ray.1.is_finite()).then_some(ray)
    }

    /// World box around index box `[lo, hi]` at every time of the shutter.
    pub(in crate::volumes) fn world_box(&self, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
        self.world_from_index.keys().iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(min, max), key| {
                let (a, b) = world_box(&to_f64(key), lo, hi);
                (min.min(a), max.max(b))
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of voxels 0.5 translated from x = 0 to x = 4 over [0, 1]: at
    /// t = 0.25 the world point (1, 0, 0) is the grid's index origin, and
    /// the world box spans both ends.
    #[test]
    fn a_translated_grid_is_entered_at_the_ray_time_and_boxed_over_the_motion() {
        let keys = vec![
            Affine3A::IDENTITY,
            Affine3A::from_translation(Vec3::new(4.0, 0.0, 0.0)),
        ];
        let track = TransformTrack::new(vec![0.0, 1.0], keys).unwrap();
        let voxels = DAffine3::from_scale(glam::DVec3::splat(0.5));
        let motion = PlacementMotion::new(&track, &voxels);
        let (o, d) = motion
            .index_ray(Vec3::new(1.0, 0.0, 0.0), Vec3::X, 0.25)
            .unwrap();
        assert!(o.abs_diff_eq(Vec3::ZERO, 1e-6), "{o}");
        assert!(d.abs_diff_eq(Vec3::new(2.0, 0.0, 0.0), 1e-6), "{d}");
        let (min, max) = motion.world_box(Vec3::ZERO, Vec3::splat(2.0));
        assert_eq!((min, max), (Vec3::ZERO, Vec3::new(5.0, 1.0, 1.0)));
        let flat = TransformTrack::new(vec![0.0], vec![Affine3A::ZERO]).unwrap();
        let collapsed = PlacementMotion::new(&flat, &voxels);
        assert!(collapsed.index_ray(Vec3::ZERO, Vec3::X, 0.0).is_none());
    }
}
