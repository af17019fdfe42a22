//! Emitting volumes (fire) as lights (Villemin & Hery 2013, "Practical
//! Illumination from Flames", JCGT 2(2)): each placed volume that emits is
//! one light, with its emitting cells' world box, its power and emission in
//! every direction for the light BVH; a sample is a point of the volume
//! picked by power, or near the volume by what it delivers to the shading
//! point (`volumes/emission/emitter.rs`, `volumes/emission/near_picks.rs`).
//!
//! A sampled point stands for a tentative collision of free-flight tracking
//! there: its radiance is sigma_a Le / sigma_maj, what tracking adds at a
//! collision, and its pdf the point's volume density x d^2 / sigma_maj, so
//! radiance / pdf is the estimator sigma_a Le / (p_V d^2) of the volume
//! emission integral, and the pdf is in the measure of a phase or BSDF
//! density: tracking along the direction places a collision at the point
//! with density sigma_maj per unit length, so p_dir x sigma_maj against
//! p_V d^2 is the ratio of the two strategies' densities of the same point
//! (null-scattering path MIS, Miller et al. 2019).

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::LightSample;
use crate::volumes::emission::NearImportance;
use crate::volumes::{Emitter, Media};

/// Resolution of the split of one uniform number into two (see
/// [`VolumeLight::sample`]).
const SPLIT: f32 = 4096.0;

/// One placed emitting volume.
#[derive(Clone, Debug)]
pub(crate) struct VolumeLight {
    /// The medium, as [`Media`] numbers them.
    medium: usize,
    /// Its emitting box, and the luminance of the power that leaves it
    /// (W) as `phi`.
    bounds: LightBounds,
    /// What it delivers near its emission, by region.
    near: NearImportance,
}

impl VolumeLight {
    /// A point of the volume's emission picked for shading point `p`; `None`
    /// where the picked point emits nothing. The cell and its first axis
    /// come from `u.x`, the other two axes from `u.y` and its fraction at
    /// 1/4096 resolution (finer than a voxel per cell edge by 500x).
    /// At `time` (frames), a medium advected by its velocity field emits
    /// where it is then: the point is picked by the emission at the frame
    /// and weighed by the source at `time` (MIS with tracking, which finds
    /// emission wherever it has moved, keeps the sum unbiased).
    pub fn sample(&self, media: &Media, p: Vec3, u: Vec2, time: f32) -> Option<LightSample> {
        let u3 = Vec3::new(u.x, u.y, (u.y * SPLIT).fract());
        let (point, pdf_volume) = media.sample_emission(self.medium, p, u3)?;
        let offset = point - p;
        let distance = offset.length();
        let source = media.source(point, time);
        let sigma_maj = media.sigma_maj_at(point, time);
        if source == Vec3::ZERO || sigma_maj <= 0.0 || distance <= 0.0 {
            return None;
        }
        let pdf = pdf_volume * distance * distance / sigma_maj;
        pdf.is_finite().then(|| LightSample {
            radiance: source / sigma_maj,
            wi: offset / distance,
            distance,
            pdf,
            delta: false,
        })
    }

    /// The density [`Self::sample`] from shading point `from` gives `point`
    /// (where tracking's majorant is `sigma_maj`), in its measure; without
    /// selection.
    pub fn pdf(&self, media: &Media, from: Vec3, point: Vec3, sigma_maj: f32) -> f32 {
        let distance = point.distance(from);
        media.emission_pdf(self.medium, from, point) * distance * distance / sigma_maj
    }

    /// Where and how much it emits, in every direction.
    pub fn bounds(&self) -> LightBounds {
        self.bounds
    }

    /// 4 pi x an estimate of the irradiance it delivers at `p`, in the unit
    /// of the light BVH's importance (`bvh.rs`), for the light selection:
    /// near its emission, the near picks' estimate for `p`'s region (the
    /// power of its parts x their transmittance to the region / their
    /// squared distance); farther, its escaping power over the squared
    /// distance to its box's centre (at least its box's half diagonal), as
    /// the BVH weighs a light.
    pub fn importance(&self, p: Vec3) -> f32 {
        self.near.at(p).unwrap_or_else(|| self.bounds.importance(p))
    }

    /// Luminance of the power that leaves the volume, W.
    pub fn power(&self) -> f32 {
        self.bounds.phi
    }

    /// The light of one emitting medium.
    pub fn new(emitter: &Emitter) -> Self {
        Self {
            medium: emitter.medium,
            bounds: LightBounds::omni(emitter.world_min, emitter.world_max, emitter.power),
            near: emitter.near.clone(),
        }
    }
}
