//! The lobes of the layered UsdPreviewSurface BSDF: each layer's weights and
//! parameters at one point ([`Layers`]), and what each lobe reflects or
//! transmits and with which density it draws a direction, in the shading
//! frame (+z the shading normal, `wo` above it).
//!
//! Layers, top to bottom, as the UsdPreviewSurface specification stacks them:
//! ```text
//! f = opacity * [ clearcoat * f_cc + A_cc * ( f_spec + A_spec * diffuse / pi ) ]
//!   + (1 - opacity) * f_dielectric
//! ```
//! - `f_cc`, `f_spec`: GGX reflection (microfacet.rs) with Schlick Fresnel;
//!   the clearcoat is white with F0 from the material's ior (the
//!   specification's `ior` covers "the clearcoat if clearcoat > 0") and has
//!   its own roughness.
//! - `A_x`: the energy a layer's Fresnel lets through on the way in and out,
//!   symmetric in `wo` and `wi` so that every reflection lobe stays
//!   reciprocal. Under the specular layer, `A_spec = (1 - F(cos_o)) (1 -
//!   F(cos_i)) / (1 - F_avg)` with `F_avg` the cosine-weighted hemispherical
//!   average of F: the Lambert base then reflects exactly `1 - F(cos_o)` of
//!   white light (Kelemen and Szirmay-Kalos 2001, "A Microfacet Based Coupled
//!   Specular-Matte BRDF Model", with Schlick's F standing in for the
//!   specular albedo). Under the clearcoat, whose base is not Lambertian,
//!   `A_cc = (1 - F(cos_o)) (1 - F(cos_i))` without the normalisation, which
//!   can lose a little energy but never create it.
//! - `f_dielectric`: a rough dielectric interface (Walter et al. 2007,
//!   "Microfacet Models for Refraction through Rough Surfaces") of relative
//!   index `eta`, exact Fresnel, radiance scaled by 1/eta^2 on refraction
//!   (Veach 1997 §5.2), or a thin sheet (see [`Layers::thin`]).

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use super::fresnel;
use super::microfacet::Ggx;
use crate::sampling::warp;

/// [`Bsdf::eval`](super::Bsdf::eval) by lobe category, each f(wo, wi) |cos theta_i| in RGB;
/// the three sum to `eval`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LobeValues {
    /// The Lambert base of the opaque stack, attenuated by the specular and
    /// clearcoat layers' Fresnel on the way in and out, times opacity.
    pub diffuse: Vec3,
    /// Every glossy reflection: the specular and clearcoat microfacet lobes
    /// and the dielectric's (or thin sheet's) reflection.
    pub specular: Vec3,
    /// Rough refraction through the dielectric (a thin sheet's straight-
    /// through Dirac lobe is never evaluated, so it is 0 here too).
    pub transmission: Vec3,
}

impl LobeValues {
    /// diffuse + specular + transmission: f(wo, wi) |cos theta_i|.
    pub fn total(&self) -> Vec3 {
        self.diffuse + self.specular + self.transmission
    }
}

/// Evaluated UsdPreviewSurface inputs at one point: the weights and
/// parameters of every layer.
#[derive(Clone, Debug)]
pub(crate) struct Layers {
    /// Lambert reflectance under the specular layer (diffuseColor, times
    /// 1 - metallic in the metallic workflow).
    pub(crate) diffuse: Vec3,
    /// Specular reflectance at normal incidence.
    pub(crate) specular_f0: Vec3,
    /// Specular reflectance at grazing incidence.
    pub(crate) specular_f90: Vec3,
    /// Specular (and dielectric) microfacets.
    pub(crate) specular: Ggx,
    /// Clearcoat weight in [0, 1].
    pub(crate) clearcoat: f32,
    /// Clearcoat reflectance at normal incidence, ((ior - 1) / (ior + 1))^2.
    pub(crate) clearcoat_f0: f32,
    /// Clearcoat microfacets.
    pub(crate) clearcoat_ggx: Ggx,
    /// Weight of the opaque stack; 1 - opacity goes to the dielectric.
    pub(crate) opacity: f32,
    /// Index of refraction of the far side over `wo`'s side.
    pub(crate) eta: f32,
    /// A thin sheet: rough reflection with the two faces' inter-reflections
    /// summed, and transmission straight through (a Dirac lobe, roughness
    /// ignored) instead of refraction.
    pub(crate) thin: bool,
    /// What [`Bsdf::albedo`](super::Bsdf::albedo) returns.
    pub(crate) albedo: Vec3,
}

/// Number of [`Lobe`]s.
pub(super) const LOBES: usize = 4;

/// The sampling strategies, one per layer; the value indexes `lobe_pdf`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Lobe {
    Diffuse = 0,
    Specular = 1,
    Clearcoat = 2,
    Dielectric = 3,
}

pub(super) const ALL_LOBES: [Lobe; LOBES] = [
    Lobe::Diffuse,
    Lobe::Specular,
    Lobe::Clearcoat,
    Lobe::Dielectric,
];

impl Layers {
    /// The clearcoat's weighted Fresnel reflectance (Schlick, white at grazing).
    pub(super) fn clearcoat_fresnel(&self, cos: f32) -> f32 {
        self.clearcoat * fresnel::schlick(Vec3::splat(self.clearcoat_f0), Vec3::ONE, cos).x
    }

    /// The opaque stack (clearcoat over specular over Lambert), times
    /// opacity: the Lambert base as `diffuse`, the clearcoat and specular
    /// microfacet lobes as `specular`.
    pub(super) fn opaque_reflection(&self, wo: Vec3, wi: Vec3) -> LobeValues {
        let l = self;
        if l.opacity <= 0.0 {
            return LobeValues::default();
        }
        let h = (wo + wi).normalize();
        let spec_f = |cos| fresnel::schlick(l.specular_f0, l.specular_f90, cos);
        let through_spec = (Vec3::ONE - spec_f(wo.z)) * (Vec3::ONE - spec_f(wi.z))
            / (Vec3::ONE - fresnel::schlick_average(l.specular_f0, l.specular_f90))
                .max(Vec3::splat(1e-6));
        let specular = microfacet_reflection(l.specular, wo, wi, h) * spec_f(wo.dot(h));
        let diffuse = l.diffuse * through_spec * (wi.z * FRAC_1_PI);
        let (coat, through_cc) = if l.clearcoat > 0.0 {
            let cc_f = |cos| l.clearcoat_fresnel(cos);
            (
                microfacet_reflection(l.clearcoat_ggx, wo, wi, h) * cc_f(wo.dot(h)),
                (1.0 - cc_f(wo.z)) * (1.0 - cc_f(wi.z)),
            )
        } else {
            (0.0, 1.0)
        };
        LobeValues {
            diffuse: l.opacity * through_cc * diffuse,
            specular: l.opacity * (coat + through_cc * specular),
            transmission: Vec3::ZERO,
        }
    }

    /// The dielectric's reflection (without its 1 - opacity weight).
    pub(super) fn dielectric_reflection(&self, wo: Vec3, wi: Vec3) -> f32 {
        let l = self;
        if l.opacity >= 1.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let f = if l.thin {
            fresnel::thin_dielectric(wo.dot(h), l.eta)
        } else {
            fresnel::dielectric(wo.dot(h), l.eta)
        };
        f * microfacet_reflection(l.specular, wo, wi, h)
    }

    /// Rough refraction |cos_i| f_t (Walter et al. 2007, eq. 21, divided by
    /// eta^2 for radiance), without the 1 - opacity weight; `wi.z < 0`.
    pub(super) fn refraction(&self, wo: Vec3, wi: Vec3) -> f32 {
        refraction(self.specular, self.eta, wo, wi)
    }

    /// Density of `lobe` drawing `wi` (before the lobe's selection probability).
    pub(super) fn lobe_density(&self, lobe: Lobe, wo: Vec3, wi: Vec3, reflect: bool) -> f32 {
        let l = self;
        match (lobe, reflect) {
            (Lobe::Diffuse, true) => warp::cosine_hemisphere_pdf(wi.z),
            (Lobe::Specular, true) => reflection_pdf(l.specular, wo, wi),
            (Lobe::Clearcoat, true) => reflection_pdf(l.clearcoat_ggx, wo, wi),
            (Lobe::Dielectric, true) if l.thin => {
                fresnel::thin_dielectric(wo.z, l.eta) * reflection_pdf(l.specular, wo, wi)
            }
            (Lobe::Dielectric, true) => dielectric_reflection_pdf(l.specular, l.eta, wo, wi),
            (Lobe::Dielectric, false) if !l.thin => refraction_pdf(l.specular, l.eta, wo, wi),
            _ => 0.0,
        }
    }
}

/// Rough refraction |cos_i| f_t through a dielectric of relative index
/// `eta` (Walter et al. 2007, eq. 21, divided by eta^2 for radiance);
/// `wo.z > 0 > wi.z`.
pub(super) fn refraction(ggx: Ggx, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    let Some((h, jacobian)) = refraction_half_vector(wo, wi, eta) else {
        return 0.0;
    };
    let f = fresnel::dielectric(wo.dot(h), eta);
    let denom_eta2 = jacobian / (eta * eta);
    // |wo.h| |wi.h| / (wo.z (wo.h + eta wi.h)^2), the eta^2 of Walter's
    // eq. 21 cancelled by the radiance scaling.
    (1.0 - f) * ggx.d(h) * ggx.g2(wo, wi) * wo.dot(h) * denom_eta2 / wo.z
}

/// Density of a rough dielectric's sampling (a visible normal, then
/// reflection with probability F) drawing the reflected `wi`.
pub(super) fn dielectric_reflection_pdf(ggx: Ggx, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    fresnel::dielectric(wo.dot((wo + wi).normalize()), eta) * reflection_pdf(ggx, wo, wi)
}

/// Density of a rough dielectric's sampling drawing the refracted `wi`:
/// (1 - F) D_wo(h) dh/dwi (Walter et al. 2007, eq. 17).
pub(super) fn refraction_pdf(ggx: Ggx, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    let Some((h, jacobian)) = refraction_half_vector(wo, wi, eta) else {
        return 0.0;
    };
    let f = fresnel::dielectric(wo.dot(h), eta);
    (1.0 - f) * ggx.visible_normal_pdf(wo, h) * jacobian
}

/// GGX reflection without Fresnel, cosine included:
/// D(h) G2(wo, wi) / (4 cos_o) (Walter et al. 2007, eq. 20, times cos_i).
pub(super) fn microfacet_reflection(ggx: Ggx, wo: Vec3, wi: Vec3, h: Vec3) -> f32 {
    ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z)
}

/// Density of reflecting `wo` about a visible normal: D_wo(h) / (4 wo.h)
/// (Heitz 2018, eq. 17).
pub(super) fn reflection_pdf(ggx: Ggx, wo: Vec3, wi: Vec3) -> f32 {
    let h = (wo + wi).normalize();
    let cos = wo.dot(h);
    if cos <= 0.0 {
        return 0.0;
    }
    ggx.visible_normal_pdf(wo, h) / (4.0 * cos)
}

/// The microfacet normal refracting `wo` into `wi` (on opposite sides, relative
/// index `eta`), oriented up, and the Jacobian dh/dwi = eta^2 |wi.h| /
/// (wo.h + eta wi.h)^2 (Walter et al. 2007, eq. 17). `None` when no
/// microfacet facing `wo` refracts it into `wi`.
pub(super) fn refraction_half_vector(wo: Vec3, wi: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let mut h = (wo + eta * wi).try_normalize()?;
    if h.z < 0.0 {
        h = -h;
    }
    let (cos_o, cos_i) = (wo.dot(h), wi.dot(h));
    if cos_o <= 0.0 || cos_i >= 0.0 {
        return None;
    }
    let denom = cos_o + eta * cos_i;
    Some((h, eta * eta * cos_i.abs() / (denom * denom)))
}
