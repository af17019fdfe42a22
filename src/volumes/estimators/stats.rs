//! The counters every tracking estimator adds to: density lookups, real
//! and null collisions, and majorant violations. A leaf the estimators
//! (`tracking.rs`, `ray_marching.rs`) share.

use glam::Vec3;

/// Per-render counters of the tracking estimators, summed over threads by
/// the caller and reported beside the film (in `RenderStats`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct TrackingStats {
    /// Evaluations of `sigma_t`, one per tentative collision.
    pub density_lookups: u64,
    /// Tentative collisions that delta tracking accepted as real.
    pub real_collisions: u64,
    /// Tentative collisions that delta tracking rejected as null.
    pub null_collisions: u64,
    /// Lookups where `sigma_t` exceeded the segment's `sigma_maj`: delta
    /// tracking is biased then (its acceptance probability is clamped to 1);
    /// ratio tracking stays unbiased but its weights turn negative.
    pub majorant_violations: u64,
}

impl TrackingStats {
    /// Counts one density lookup that found `sigma` (per RGB channel) under
    /// the grey majorant `sigma_maj`, and a violation when any channel
    /// exceeds it.
    #[inline]
    pub fn count_lookup(&mut self, sigma: Vec3, sigma_maj: f32) {
        self.density_lookups += 1;
        if sigma.max_element() > sigma_maj {
            self.majorant_violations += 1;
        }
    }

    /// Adds another thread's counters to these.
    pub fn merge(&mut self, other: &TrackingStats) {
        self.density_lookups += other.density_lookups;
        self.real_collisions += other.real_collisions;
        self.null_collisions += other.null_collisions;
        self.majorant_violations += other.majorant_violations;
    }
}
