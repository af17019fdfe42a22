//! Picking one light per sample. Infinite lights (dome, distant) and bounded
//! ones (everything with a position) share the probability by their power,
//! the infinite lights counting the flux through a disk of the scene's
//! bounding radius as pbrt-v4's `Phi` does: with a single bounded light this
//! is pbrt-v4's `PowerLightSampler`. Among infinite lights the choice is by
//! power; among bounded lights a light BVH (`bvh.rs`) weighs power by
//! distance and orientation from the shading point. Every light with power
//! keeps a non-zero probability wherever it can contribute, so the estimator
//! stays unbiased.

use glam::Vec3;

use super::bvh::{LightBvh, Pick};
use super::Light;
use crate::sampling::Distribution1D;
use crate::scene::Bounds;

/// The light-picking structure over a scene's lights.
#[derive(Clone, Debug)]
pub(crate) struct LightSelection {
    /// Probability of picking an infinite light (rather than a bounded one).
    p_infinite: f32,
    /// Light indices of the infinite lights.
    infinite: Vec<usize>,
    /// Over `infinite`, by power; `None` when there are none.
    infinite_by_power: Option<Distribution1D>,
    /// Per light index: its position in `infinite`, if infinite.
    infinite_slot: Vec<Option<usize>>,
    /// Over the bounded lights; `None` when there are none.
    bvh: Option<LightBvh>,
}

impl LightSelection {
    /// Picks a light for shading point `p` with `u` in [0, 1); `None` when
    /// no light can reach `p`.
    pub fn pick(&self, p: Vec3, u: f32) -> Option<Pick> {
        if u < self.p_infinite {
            let s = self
                .infinite_by_power
                .as_ref()?
                .sample_discrete(u / self.p_infinite);
            Some(Pick {
                light: self.infinite[s.index],
                probability: self.p_infinite * s.probability,
            })
        } else {
            let u = ((u - self.p_infinite) / (1.0 - self.p_infinite)).min(1.0 - f32::EPSILON / 2.0);
            let mut pick = self.bvh.as_ref()?.pick(p, u)?;
            pick.probability *= 1.0 - self.p_infinite;
            Some(pick)
        }
    }

    /// Probability that [`Self::pick`] returns `light` at `p` (`p` does not
    /// matter for infinite lights).
    pub fn probability(&self, p: Vec3, light: usize) -> f32 {
        match (
            self.infinite_slot[light],
            &self.infinite_by_power,
            &self.bvh,
        ) {
            (Some(slot), Some(d), _) => self.p_infinite * d.probability(slot),
            (None, _, Some(bvh)) => (1.0 - self.p_infinite) * bvh.probability(p, light),
            _ => 0.0,
        }
    }

    /// Over `lights` (not empty) with the scene's `bounds` for the infinite
    /// lights' power.
    pub fn new(lights: &[Light], bounds: &Bounds) -> Self {
        let radius = scene_radius(bounds);
        let powers: Vec<f32> = lights.iter().map(|l| l.power(radius)).collect();
        let mut infinite = Vec::new();
        let mut infinite_slot = vec![None; lights.len()];
        let mut bounded = Vec::new();
        let (mut infinite_power, mut bounded_power) = (0.0f64, 0.0f64);
        for (i, light) in lights.iter().enumerate() {
            match light.bounds() {
                Some(b) => {
                    bounded.push((i, b));
                    bounded_power += f64::from(powers[i]);
                }
                None => {
                    infinite_slot[i] = Some(infinite.len());
                    infinite.push(i);
                    infinite_power += f64::from(powers[i]);
                }
            }
        }
        let p_infinite = match (infinite.is_empty(), bounded.is_empty()) {
            (true, _) => 0.0,
            (false, true) => 1.0,
            _ if infinite_power + bounded_power > 0.0 => {
                (infinite_power / (infinite_power + bounded_power)) as f32
            }
            _ => infinite.len() as f32 / lights.len() as f32,
        };
        let infinite_powers: Vec<f32> = infinite.iter().map(|&i| powers[i]).collect();
        Self {
            p_infinite,
            infinite_by_power: (!infinite.is_empty())
                .then(|| Distribution1D::new(&infinite_powers)),
            infinite,
            infinite_slot,
            bvh: (!bounded.is_empty()).then(|| LightBvh::build(bounded, lights.len())),
        }
    }
}

/// Radius of the sphere around the scene's bounding box (half its diagonal),
/// scene units; 1 for empty or non-finite bounds (a scene of lights only).
pub(crate) fn scene_radius(bounds: &Bounds) -> f32 {
    let (min, max) = (Vec3::from(bounds.min), Vec3::from(bounds.max));
    let r = 0.5 * (max - min).length();
    if r.is_finite() && r > 0.0 && min.cmple(max).all() {
        r
    } else {
        1.0
    }
}
