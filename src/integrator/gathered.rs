//! What one path sample gathers: its radiance and the same contributions
//! split into the light-path AOVs by the first scattering event (see
//! `film::aov`), plus the other AOVs' values.

use glam::Vec3;

use crate::film::AovSample;
use crate::materials::LobeValues;

/// A first event in a volume takes all of what follows.
pub(super) const VOLUME_EVENT: [Vec3; 4] = [Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ONE];

/// What a path has gathered: its radiance and the same contributions split
/// into the light-path AOVs, plus the other AOVs' values.
#[derive(Default)]
pub(super) struct Gathered {
    radiance: Vec3,
    /// The AOV values; the path loop sets the camera-hit ones itself.
    pub(super) aovs: AovSample,
    /// Each first-event kind's share of what the path carries after its
    /// first event (see [`AovSample::add`]).
    first: [Vec3; 4],
    albedo_set: bool,
}

impl Gathered {
    /// Adds a contribution that reached the camera after `events` events.
    pub(super) fn add(&mut self, contribution: Vec3, events: u32) {
        self.radiance += contribution;
        self.aovs.add(contribution, events, &self.first);
    }

    /// Adds light reaching the camera straight after the first event, split
    /// by that event's own `shares` (next-event estimation at a surface).
    pub(super) fn add_first(&mut self, contribution: Vec3, shares: &[Vec3; 4]) {
        self.radiance += contribution;
        self.aovs.add(contribution, 1, shares);
    }

    /// Records how the path's first event splits what follows.
    pub(super) fn first_event(&mut self, shares: [Vec3; 4]) {
        self.first = shares;
    }

    /// The albedo AOV takes the first non-Dirac event's reflectance.
    pub(super) fn set_albedo(&mut self, albedo: Vec3) {
        if !self.albedo_set {
            self.aovs.albedo = albedo;
            self.albedo_set = true;
        }
    }

    /// The radiance (clamped if asked; the AOVs are scaled alike so they
    /// still sum to it) and the AOV values.
    pub(super) fn finish(mut self, clamp: Option<f32>) -> (Vec3, AovSample) {
        // Clamping would hide a NaN (f32::min drops it): non-finite samples
        // pass through for the film to count.
        match clamp {
            Some(max) if self.radiance.is_finite() => {
                let clamped = self.radiance.min(Vec3::splat(max));
                let scale = Vec3::select(
                    self.radiance.cmpgt(Vec3::ZERO),
                    clamped / self.radiance,
                    Vec3::ONE,
                );
                self.aovs.scale(scale);
                (clamped, self.aovs)
            }
            _ => (self.radiance, self.aovs),
        }
    }
}

/// Each lobe kind's share of the BSDF value (per RGB channel; 0 where the
/// BSDF is).
pub(super) fn lobe_shares(split: LobeValues) -> [Vec3; 4] {
    let total = split.total();
    let share = |part: Vec3| Vec3::select(total.cmpgt(Vec3::ZERO), part / total, Vec3::ZERO);
    [
        share(split.diffuse),
        share(split.specular),
        share(split.transmission),
        Vec3::ZERO,
    ]
}
