//! Picking one light per sample. Infinite lights (dome, distant), each
//! emitting volume, and the other bounded lights (everything with a
//! position) share the probability by their importance at the shading
//! point, in one unit: 4 pi x the irradiance a light can deliver there. For
//! the bounded lights that is the light BVH root's importance (power x
//! orientation / distance^2, `bvh.rs`; an isotropic point of power P gives
//! P / d^2 = 4 pi E); for an infinite light its irradiance on a surface
//! facing it (a distant light's own, pi L for a dome of mean radiance L)
//! times 4 pi; for an emitting volume, near its emission, what its parts
//! deliver to the shading point's region (`volume.rs`), since a fire's
//! box-centred bound reads a flame's base as lit from the box's centre: on
//! the canyon it gave the fireball at most 16% of the light samples
//! anywhere, where it gives most of the light (measured: docs/benchmarks.md,
//! "Fire", 2026-12-03). So a fire lights the ground beside it as often as
//! the sky does there, however large the scene (a share by total power
//! would weigh the sky by the flux through a disk of the scene's radius,
//! and starve every small light of a large scene). Among infinite lights
//! the choice is by power; among the other bounded lights the BVH walk.
//! Every light with power keeps a non-zero probability wherever it can
//! contribute, so the estimator stays unbiased, with one exception: a
//! constant dome (no image) is never picked. (An emitting volume's estimate
//! may read 0 behind dense smoke: tracking, which MIS then weighs 1, still
//! finds all of its emission.) BSDF and phase sampling find it
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

use smallvec::SmallVec;

use super::bvh::{LightBvh, Pick};
use super::volume::VolumeLight;
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
    /// Per light index: where the selection holds it.
    slots: Vec<Slot>,
    /// The emitting volumes' lights, with their light indices.
    volumes: Vec<(usize, VolumeLight)>,
    /// Over the other bounded lights; `None` when there are none.
    bvh: Option<LightBvh>,
    /// How many classes share the picks: the infinite lights (when there
    /// are some), each volume, the BVH (when there is one).
    classes: usize,
}

/// Where [`LightSelection`] holds a light.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// Position in `infinite`.
    Infinite(usize),
    /// Position in `volumes`.
    Volume(usize),
    /// In the BVH.
    Bounded,
    /// Never picked (a constant dome).
    Unpicked,
}

/// The probabilities of picking the infinite lights, each emitting volume
/// and the BVH's lights at one shading point; they sum to 1.
struct Shares {
    infinite: f32,
    volumes: SmallVec<[f32; 2]>,
    bounded: f32,
}

impl LightSelection {
    /// Picks a light for shading point `p` with `u` in [0, 1); `None` when
    /// no light can reach `p`.
    pub fn pick(&self, p: Vec3, u: f32) -> Option<Pick> {
        let shares = self.shares(p);
        if u < shares.infinite {
            let s = self
                .infinite_by_power
                .as_ref()?
                .sample_discrete(u / shares.infinite);
            return Some(Pick {
                light: self.infinite[s.index],
                probability: shares.infinite * s.probability,
            });
        }
        let mut u = u - shares.infinite;
        for (&(light, _), &probability) in self.volumes.iter().zip(&shares.volumes) {
            if u < probability {
                return Some(Pick { light, probability });
            }
            u -= probability;
        }
        let u = (u / shares.bounded).min(1.0 - f32::EPSILON / 2.0);
        let mut pick = self.bvh.as_ref()?.pick(p, u)?;
        pick.probability *= shares.bounded;
        Some(pick)
    }

    /// The shares of the infinite lights, each volume and the BVH at `p`:
    /// their importance there (equal shares where those sum to 0 or
    /// overflow).
    fn shares(&self, p: Vec3) -> Shares {
        if self.classes <= 1 {
            // One class (or none) takes every pick: nothing to weigh
            // (fire_lit's flame under a constant dome spent 2% of its
            // render time weighing itself against nothing).
            return Shares {
                infinite: f32::from(u8::from(!self.infinite.is_empty())),
                volumes: self.volumes.iter().map(|_| 1.0).collect(),
                bounded: f32::from(u8::from(self.bvh.is_some())),
            };
        }
        let infinite = if self.infinite.is_empty() {
            0.0
        } else {
            self.infinite_importance
        };
        let volumes: SmallVec<[f32; 2]> =
            self.volumes.iter().map(|(_, v)| v.importance(p)).collect();
        let bounded = self.bvh.as_ref().map_or(0.0, |bvh| bvh.importance(p));
        let total = infinite + volumes.iter().sum::<f32>() + bounded;
        let (scale, present) = if total > 0.0 && total.is_finite() {
            (1.0 / total, None)
        } else {
            (0.0, Some(1.0 / self.classes as f32))
        };
        let share = |importance: f32, there: bool| match present {
            None => importance * scale,
            Some(equal) if there => equal,
            Some(_) => 0.0,
        };
        let mut shares = Shares {
            infinite: share(infinite, !self.infinite.is_empty()),
            volumes: volumes.iter().map(|&v| share(v, true)).collect(),
            bounded: share(bounded, self.bvh.is_some()),
        };
        // Without a BVH (whose walk takes any u past the others), the last
        // volume takes what rounding left, so a pick never falls past it.
        if self.bvh.is_none() {
            let rest = 1.0 - shares.infinite - shares.volumes.iter().sum::<f32>();
            if let Some(last) = shares.volumes.last_mut() {
                *last = (*last + rest).max(0.0);
            }
        }
        shares
    }

    /// Probability that [`Self::pick`] returns `light` at `p` (`p` does not
    /// matter for infinite lights).
    pub fn probability(&self, p: Vec3, light: usize) -> f32 {
        match (self.slots[light], &self.infinite_by_power, &self.bvh) {
            (Slot::Infinite(slot), Some(d), _) => self.shares(p).infinite * d.probability(slot),
            (Slot::Volume(slot), _, _) => self.shares(p).volumes[slot],
            (Slot::Bounded, _, Some(bvh)) => self.shares(p).bounded * bvh.probability(p, light),
            _ => 0.0,
        }
    }

    /// Over the `lights` (not empty) for which `linked` holds (the others
    /// are never picked: light linking), with the scene's `bounds` for the
    /// infinite lights' power.
    pub fn new(lights: &[Light], bounds: &Bounds, linked: impl Fn(usize) -> bool) -> Self {
        let radius = scene_radius(bounds);
        let powers: Vec<f32> = lights.iter().map(|l| l.power(radius)).collect();
        let mut infinite = Vec::new();
        let mut slots = vec![Slot::Unpicked; lights.len()];
        let mut volumes = Vec::new();
        let mut bounded = Vec::new();
        let mut infinite_importance = 0.0f32;
        for (i, light) in lights.iter().enumerate().filter(|&(i, _)| linked(i)) {
            match (light, light.bounds()) {
                (Light::Volume(v), _) => {
                    slots[i] = Slot::Volume(volumes.len());
                    volumes.push((i, v.clone()));
                }
                (_, Some(b)) => {
                    slots[i] = Slot::Bounded;
                    bounded.push((i, b));
                }
                (_, None) if is_constant_dome(light) => {}
                (_, None) => {
                    slots[i] = Slot::Infinite(infinite.len());
                    infinite.push(i);
                    infinite_importance += 4.0 * PI * light.irradiance(radius);
                }
            }
        }
        let infinite_powers: Vec<f32> = infinite.iter().map(|&i| powers[i]).collect();
        let classes =
            usize::from(!infinite.is_empty()) + volumes.len() + usize::from(!bounded.is_empty());
        Self {
            classes,
            infinite_importance,
            infinite_by_power: (!infinite.is_empty())
                .then(|| Distribution1D::new(&infinite_powers)),
            infinite,
            slots,
            volumes,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{assert_picks_follow, record};
    use crate::scene::LightShape;
    use crate::volumes::emission::NearImportance;
    use crate::volumes::Emitter;

    /// A sun, a sphere light (the BVH's) and a fire whose near estimate is
    /// 300 within 2 units of its box: beside the fire the selection weighs
    /// it by that estimate, farther by its power over the squared distance
    /// (as the BVH weighs a light); everywhere the probabilities sum to 1
    /// and every pick reports the probability `probability` gives, with the
    /// frequency it says (4 sigma).
    #[test]
    fn a_fire_is_picked_by_what_it_delivers_near_it() {
        let sun = record(LightShape::Distant { angle_deg: 1.0 }, true, 4.0);
        let bulb = LightShape::Sphere {
            radius: 0.1,
            treat_as_point: false,
        };
        let (fire_min, fire_max) = (Vec3::splat(4.0), Vec3::splat(6.0));
        let fire = VolumeLight::new(&Emitter {
            medium: 0,
            world_min: fire_min,
            world_max: fire_max,
            power: 20.0,
            near: NearImportance::constant((fire_min - 2.0, fire_max + 2.0), 300.0),
        });
        let lights = [
            Light::from_record(&sun).unwrap(),
            Light::from_record(&record(bulb, false, 10.0)).unwrap(),
            Light::Volume(fire.clone()),
        ];
        let bounds = Bounds {
            min: [-10.0; 3],
            max: [10.0; 3],
        };
        let selection = LightSelection::new(&lights, &bounds, |_| true);
        let bvh = selection.bvh.as_ref().unwrap();
        for (p, fire_importance) in [
            (Vec3::splat(3.0), 300.0),
            (
                Vec3::new(-9.0, 0.0, 0.0),
                fire.bounds().importance(Vec3::new(-9.0, 0.0, 0.0)),
            ),
        ] {
            let total = selection.infinite_importance + fire_importance + bvh.importance(p);
            let probabilities: Vec<f32> = (0..3).map(|i| selection.probability(p, i)).collect();
            assert!(
                (probabilities[2] - fire_importance / total).abs() < 1e-6,
                "at {p}: {probabilities:?}"
            );
            assert!(
                (probabilities.iter().sum::<f32>() - 1.0).abs() < 1e-6,
                "at {p}"
            );
            let what = format!("at {p}");
            assert_picks_follow(
                &probabilities,
                (20_000, 7),
                |u| selection.pick(p, u).map(|k| (k.light, k.probability)),
                &what,
            );
        }
    }
}
