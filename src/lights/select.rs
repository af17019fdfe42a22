//! Picking one light per sample. Infinite lights (dome, distant) and bounded
//! ones (everything with a position) share the probability by their
//! importance at the shading point, in one unit: 4 pi x the irradiance a
//! light can deliver there. For the bounded lights that is the light BVH
//! root's importance (power x orientation / distance^2, `bvh.rs`; an
//! isotropic point of power P gives P / d^2 = 4 pi E); for an infinite light
//! its irradiance on a surface facing it (a distant light's own, pi L for a
//! dome of mean radiance L) times 4 pi. So a fire lights the ground beside
//! it as often as the sky does there, however large the scene (a share by
//! total power would weigh the sky by the flux through a disk of the
//! scene's radius, and starve every small light of a large scene). Among
//! infinite lights the choice is by power; among bounded lights the BVH
//! walk. Every light with power keeps a non-zero probability wherever it
//! can contribute, so the estimator stays unbiased, with one exception: a
//! constant dome (no image) is never picked. BSDF and phase sampling find it
//! with full weight (its light pdf is 0, so the MIS weight of what they find
//! is 1); light sampling could only draw it uniformly over the sphere, which
//! cosine-weighted, microfacet and phase sampling match or beat almost
//! everywhere, and its share of the light samples goes to the other lights
//! instead. Cycles does the same: it drops
//! background MIS for a world without spatial variation. Measured on the
//! volume benchmarks (docs/benchmarks.md, "Volumes"): 1.4x (teapot cloud)
//! and 2.2x (smoke over its ground) lower relMSE at equal spp and equal time.

use std::f32::consts::PI;

use glam::Vec3;

use super::bvh::{LightBvh, Pick};
use super::Light;
use crate::sampling::Distribution1D;
use crate::scene::Bounds;

/// The light-picking structure over a scene's lights.
#[derive(Clone, Debug)]
pub(crate) struct LightSelection {
    /// 4 pi x the summed irradiance of the infinite lights (see the module doc).
    infinite_importance: f32,
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
        let p_infinite = self.p_infinite(p);
        if u < p_infinite {
            let s = self
                .infinite_by_power
                .as_ref()?
                .sample_discrete(u / p_infinite);
            Some(Pick {
                light: self.infinite[s.index],
                probability: p_infinite * s.probability,
            })
        } else {
            let u = ((u - p_infinite) / (1.0 - p_infinite)).min(1.0 - f32::EPSILON / 2.0);
            let mut pick = self.bvh.as_ref()?.pick(p, u)?;
            pick.probability *= 1.0 - p_infinite;
            Some(pick)
        }
    }

    /// Probability of picking an infinite light (rather than a bounded one)
    /// at `p`: their share of the importance there.
    fn p_infinite(&self, p: Vec3) -> f32 {
        match &self.bvh {
            None => 1.0,
            Some(_) if self.infinite.is_empty() => 0.0,
            Some(bvh) => {
                let bounded = bvh.importance(p);
                let total = self.infinite_importance + bounded;
                if total > 0.0 && total.is_finite() {
                    self.infinite_importance / total
                } else {
                    0.5
                }
            }
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
            (Some(slot), Some(d), _) => self.p_infinite(p) * d.probability(slot),
            (None, _, Some(bvh)) => (1.0 - self.p_infinite(p)) * bvh.probability(p, light),
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
        let mut infinite_importance = 0.0f32;
        for (i, light) in lights.iter().enumerate() {
            match light.bounds() {
                Some(b) => bounded.push((i, b)),
                None if is_constant_dome(light) => {}
                None => {
                    infinite_slot[i] = Some(infinite.len());
                    infinite.push(i);
                    infinite_importance += 4.0 * PI * light.irradiance(radius);
                }
            }
        }
        let infinite_powers: Vec<f32> = infinite.iter().map(|&i| powers[i]).collect();
        Self {
            infinite_importance,
            infinite_by_power: (!infinite.is_empty())
                .then(|| Distribution1D::new(&infinite_powers)),
            infinite,
            infinite_slot,
            bvh: (!bounded.is_empty()).then(|| LightBvh::build(bounded, lights.len())),
        }
    }
}

/// Whether `light` is a dome of one colour, still or turning: never picked
/// (see the module doc).
fn is_constant_dome(light: &Light) -> bool {
    match light {
        Light::Dome(d) => d.is_constant(),
        Light::Moving(m) => is_constant_dome(m.frame()),
        _ => false,
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
