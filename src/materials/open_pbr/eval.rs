//! Evaluating and sampling an [`OpenPbr`] mixture: f cos, the mixture
//! density, and a direction from one lobe (model.rs has the weights).
//!
//! AOV categories: EON and fuzz are `diffuse`; metal, dielectric
//! specular, coat and the dielectric's reflections are `specular`;
//! refraction is `transmission`.

use glam::{Vec2, Vec3};

use super::model::{mean, OpenPbr, OpenPbrLobe, OPEN_PBR_LOBES};
use crate::geometry::Frame;
use crate::materials::fresnel;
use crate::materials::lobes::{
    microfacet_reflection, reflection_pdf, refraction, refraction_half_vector, refraction_pdf,
    LobeValues,
};
use crate::materials::scatter::{pick_lobe, reflect, refract, BsdfSample, Drawn, Side};
use crate::sampling::warp;

/// The lobes in `lobe_pdf` order.
const ALL: [OpenPbrLobe; OPEN_PBR_LOBES] = [
    OpenPbrLobe::Diffuse,
    OpenPbrLobe::Specular,
    OpenPbrLobe::Translucent,
    OpenPbrLobe::Coat,
    OpenPbrLobe::Fuzz,
    OpenPbrLobe::Pass,
];

impl OpenPbr {
    /// f(wo, wi) |cos theta_i| by category; `wo`, `wi` world, `wo_l`,
    /// `wi_l` in the base frame, `side` where `wi` leaves.
    pub(crate) fn eval_split(
        &self,
        wo: Vec3,
        wi: Vec3,
        wo_l: Vec3,
        wi_l: Vec3,
        side: Side,
    ) -> LobeValues {
        let (wo_c, wi_c) = (self.coat_frame.to_local(wo), self.coat_frame.to_local(wi));
        let w = self.below_fuzz * self.base_weight(wi_c.z);
        if side == Side::Transmit {
            if self.thin || self.translucent <= 0.0 {
                return LobeValues::default();
            }
            let t = self.refraction(wo_l, wi_l);
            return LobeValues {
                transmission: w * self.translucent * t * self.transmission_tint,
                ..LobeValues::default()
            };
        }
        let mut values = LobeValues::default();
        if self.fuzz_tint != Vec3::ZERO {
            values.diffuse += self.fuzz_tint * self.fuzz.eval(wi_l);
        }
        if self.gloss > 0.0 {
            values.diffuse += w * self.gloss * self.through_specular * self.eon.eval(wo_l, wi_l);
        }
        if self.coat > 0.0 && wi_c.z > 0.0 {
            let h = (wo_c + wi_c).normalize();
            let f = fresnel::dielectric(wo_c.dot(h), self.coat_eta);
            values.specular += Vec3::splat(
                self.below_fuzz
                    * self.coat
                    * self.coat_compensation
                    * f
                    * microfacet_reflection(self.coat_ggx, wo_c, wi_c, h),
            );
        }
        let h = (wo_l + wi_l).normalize();
        let cos_h = wo_l.dot(h);
        let mut fresnel = Vec3::ZERO;
        if self.metal > 0.0 {
            fresnel += self.metal * self.metal_scale * self.metal_fresnel(cos_h);
        }
        if self.gloss > 0.0 {
            let f = self.specular_fresnel(cos_h);
            fresnel += self.specular_tint * (self.gloss * self.specular_compensation) * f;
        }
        if self.translucent > 0.0 {
            let f = if !self.thin {
                self.transmission_fresnel(cos_h)
            } else {
                self.thin_fresnel(cos_h)
            };
            fresnel += self.specular_tint * self.translucent * f;
        }
        if fresnel != Vec3::ZERO {
            values.specular += w * fresnel * microfacet_reflection(self.ggx, wo_l, wi_l, h);
        }
        values
    }

    /// The thick dielectric's rough refraction |cos_i| f_t (Walter et al.
    /// 2007, eq. 21, over eta^2), per channel: its transmittance is the
    /// film's where there is one.
    fn refraction(&self, wo_l: Vec3, wi_l: Vec3) -> Vec3 {
        let t = refraction(self.ggx, self.transmission_eta, wo_l, wi_l);
        self.with_film_transmittance(wo_l, wi_l, t)
    }

    /// `bare`, a refraction value or density that carries the filmless
    /// transmittance 1 - F at the microfacet refracting `wo_l` into `wi_l`,
    /// with the film's 1 - R_film there instead (per channel); `bare`
    /// itself without a film.
    fn with_film_transmittance(&self, wo_l: Vec3, wi_l: Vec3, bare: f32) -> Vec3 {
        if self.transmission_film.is_none() || bare == 0.0 {
            return Vec3::splat(bare);
        }
        let Some((h, _)) = refraction_half_vector(wo_l, wi_l, self.transmission_eta) else {
            return Vec3::ZERO;
        };
        let cos = wo_l.dot(h);
        let f = fresnel::dielectric(cos, self.transmission_eta);
        bare / (1.0 - f) * (Vec3::ONE - self.transmission_fresnel(cos))
    }

    /// The mixture density of the non-Dirac lobes drawing `wi`.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3, wo_l: Vec3, wi_l: Vec3, side: Side) -> f32 {
        ALL.iter()
            .zip(self.lobe_pdf)
            .filter(|(_, p)| *p > 0.0)
            .map(|(lobe, p)| p * self.lobe_density(*lobe, wo, wi, wo_l, wi_l, side))
            .sum()
    }

    /// Density of `lobe` drawing `wi` (before its selection probability).
    fn lobe_density(
        &self,
        lobe: OpenPbrLobe,
        wo: Vec3,
        wi: Vec3,
        wo_l: Vec3,
        wi_l: Vec3,
        side: Side,
    ) -> f32 {
        match (lobe, side) {
            (OpenPbrLobe::Diffuse, Side::Reflect) => warp::cosine_hemisphere_pdf(wi_l.z),
            (OpenPbrLobe::Specular, Side::Reflect) => reflection_pdf(self.ggx, wo_l, wi_l),
            (OpenPbrLobe::Translucent, Side::Reflect) => {
                let cos_h = wo_l.dot((wo_l + wi_l).normalize());
                self.reflect_probability(cos_h) * reflection_pdf(self.ggx, wo_l, wi_l)
            }
            (OpenPbrLobe::Translucent, Side::Transmit) => {
                let pdf = refraction_pdf(self.ggx, self.transmission_eta, wo_l, wi_l);
                match self.transmission_film {
                    None => pdf,
                    Some(_) => mean(self.with_film_transmittance(wo_l, wi_l, pdf)),
                }
            }
            (OpenPbrLobe::Coat, Side::Reflect) => {
                let wi_c = self.coat_frame.to_local(wi);
                if wi_c.z <= 0.0 {
                    return 0.0;
                }
                reflection_pdf(self.coat_ggx, self.coat_frame.to_local(wo), wi_c)
            }
            (OpenPbrLobe::Fuzz, Side::Reflect) => self.fuzz.pdf(wi_l),
            _ => 0.0,
        }
    }

    /// Draws a lobe with `u_lobe` and a direction from it with `u`; the
    /// pass-through returns its finished Dirac sample.
    pub(crate) fn sample(&self, wo: Vec3, frame: &Frame, u_lobe: f32, u: Vec2) -> Option<Drawn> {
        let wo_l = frame.to_local(wo);
        let (lobe, u_lobe) = pick_lobe(&self.lobe_pdf, u_lobe)?;
        // Each arm's direction and whether it was reflected.
        let (wi_l, reflected) = match ALL[lobe] {
            OpenPbrLobe::Diffuse => (warp::square_to_cosine_hemisphere(u), true),
            OpenPbrLobe::Specular => (reflect(wo_l, self.ggx.sample_visible_normal(wo_l, u)), true),
            OpenPbrLobe::Translucent => {
                let h = self.ggx.sample_visible_normal(wo_l, u);
                if u_lobe < self.reflect_probability(wo_l.dot(h)) {
                    (reflect(wo_l, h), true)
                } else {
                    (refract(wo_l, h, self.transmission_eta)?, false)
                }
            }
            OpenPbrLobe::Coat => {
                let wo_c = self.coat_frame.to_local(wo);
                let wi_c = reflect(wo_c, self.coat_ggx.sample_visible_normal(wo_c, u));
                (frame.to_local(self.coat_frame.to_world(wi_c)), true)
            }
            OpenPbrLobe::Fuzz => (self.fuzz.sample(u), true),
            OpenPbrLobe::Pass => {
                let p = self.lobe_pdf[lobe];
                return Some(Drawn::Dirac(BsdfSample {
                    wi: -wo,
                    weight: self.pass / p,
                    pdf: p,
                    delta: true,
                }));
            }
        };
        // A reflection that ends below the surface (or a refraction above
        // it) scatters nothing: scoring it on the other side, with that
        // side's density, would not match the density it was drawn with.
        if (wi_l.z > 0.0) != reflected {
            return None;
        }
        Some(Drawn::Direction(wi_l))
    }
}
