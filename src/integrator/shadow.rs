//! Shadow rays, the leaf that surface and medium vertices share: whether
//! geometry or another light blocks the way to a light sample, the media's
//! transmittance estimate along it (ratio tracking, Novák et al. 2014, or
//! the estimator `--volume-estimator` names), and the counters every ray
//! adds to.

use glam::Vec3;
use obvhs::ray::Ray;

use super::{PathSettings, RayCounts, VolumeEstimator};
use crate::lights::Receiver;
use crate::render_state::RenderState;
use crate::sampling::Pcg32;
use crate::volumes::estimators::{ratio_tracking_with_null_ratio, transmittance, TrackingStats};

/// Counters a path adds to.
pub struct PathCounts<'a> {
    /// Rays traced.
    pub rays: &'a mut RayCounts,
    /// Density lookups and collisions in media.
    pub tracking: &'a mut TrackingStats,
}

/// What a shadow ray lets through.
pub(super) struct Visibility {
    /// The fraction of the light's radiance that arrives, per RGB channel:
    /// 0 when geometry or another area light blocks the ray, else the
    /// media's transmittance estimate (1 without media).
    pub(super) transmittance: Vec3,
    /// The factor that turns the vertex's directional sampling density into
    /// its density for the whole null-scattering path (ratio tracking's
    /// product of sigma_n / sigma_maj under null-scattering MIS, else 1).
    pub(super) null_ratio: f32,
}

impl Visibility {
    /// Nothing arrives.
    const BLOCKED: Self = Self {
        transmittance: Vec3::ZERO,
        null_ratio: 1.0,
    };
    /// Everything arrives (no media on the way).
    const CLEAR: Self = Self {
        transmittance: Vec3::ONE,
        null_ratio: 1.0,
    };
}

/// Whether geometry that casts light `light`'s shadow lies on `shadow`:
/// any geometry, unless the light's shadow is linked; then the hits are
/// walked front to back, passing those of parts its `collection:shadowLink`
/// leaves out (transparent to it).
fn occluded(state: &RenderState, shadow: &Ray, time: f32, light: usize) -> bool {
    let lights = &state.lights;
    if !lights.shadow_linked(light) {
        return state.occluded(shadow, time);
    }
    let mut ray = *shadow;
    while let Some(hit) = state.intersect(&ray, time) {
        if lights.casts_shadow(light, hit.instance, hit.prototype_mesh) {
            return true;
        }
        // The next float past the hit: the same hit is never found twice.
        ray.tmin = f32::from_bits(hit.t.max(0.0).to_bits() + 1);
    }
    false
}

/// Traces the shadow ray `shadow` at its time (frames) towards light
/// `light` from a vertex in link set `receiver` through geometry, the other
/// lights and the media, with the configured transmittance estimator.
pub(super) fn visibility(
    state: &RenderState,
    settings: &PathSettings,
    (shadow, time): (&Ray, f32),
    (light, receiver): (usize, Receiver),
    rng: &mut Pcg32,
    counts: &mut PathCounts,
) -> Visibility {
    counts.rays.shadow += 1;
    let (origin, direction) = (Vec3::from(shadow.origin), Vec3::from(shadow.direction));
    if occluded(state, shadow, time, light)
        || state
            .lights
            .blocks((origin, receiver), direction, shadow.tmax, time, light)
    {
        return Visibility::BLOCKED;
    }
    if state.media.is_empty() {
        return Visibility::CLEAR;
    }
    let along = state.media.along(origin, direction, shadow.tmax, time);
    if along.is_empty() {
        return Visibility::CLEAR;
    }
    let segments = along.segments(shadow.tmin, shadow.tmax);
    let sigma_t = |t| along.sigma_t(t);
    match settings.volume_estimator {
        VolumeEstimator::NullScatteringMis => {
            let (transmittance, null_ratio) =
                ratio_tracking_with_null_ratio(segments, sigma_t, rng, counts.tracking);
            Visibility {
                transmittance,
                null_ratio,
            }
        }
        estimator => {
            let tr = transmittance(
                estimator.transmittance(),
                segments,
                sigma_t,
                rng,
                counts.tracking,
            );
            Visibility {
                transmittance: tr,
                null_ratio: 1.0,
            }
        }
    }
}
