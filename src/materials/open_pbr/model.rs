//! Building an [`OpenPbr`] lobe mixture from [`OpenPbrInputs`] at one hit
//! for one `wo`: every weight and Fresnel parameter that does not depend on
//! `wi`, and the lobes' selection probabilities.
//!
//! The specification's layer tree (OpenPBR 1.1, "Model"), with `layer`
//! implemented by its non-reciprocal albedo scaling f_top + (1 - E_top(wo))
//! f_below (eq. "non-reciprocal-albedo-scaling"):
//! ```text
//! f = (1 - opacity) delta_pass + opacity [ F fuzz_color f_fuzz + (1 - F E_fuzz(wo)) (
//!       C f_coat + W(wo, wi) ( M f_metal + (1 - M) [ T f_translucent
//!         + (1 - T) ( f_specular + (1 - E_specular(wo)) f_eon ) ] ) ) ]
//! W = (1 - C) + C T_coat(wo, wi) (1 - E_coat(wo)) lerp(1, Delta, coat_darkening)
//! ```
//! F = fuzz_weight, C = coat_weight, M = base_metalness, T =
//! transmission_weight; the subsurface slab is the specification's
//! diffuse fallback: the EON colour is lerp(base_weight base_color,
//! subsurface_color, subsurface_weight).

use glam::Vec3;

use super::albedo::{self, Interface};
use super::eon::Eon;
use super::fuzz::Fuzz;
use super::inputs::{OpenPbrInputs, ShadingFrames};
use super::medium::has_interior;
use super::thin_film::{with_film, Substrate, ThinFilm};
use crate::geometry::Frame;
use crate::materials::fresnel;
use crate::materials::microfacet::Ggx;
use crate::materials::scatter::normalized;

/// Below this |eta - 1| the transmissive dielectric is index-matched and
/// passes light straight through (as UsdPreviewSurface's ior 1).
const INDEX_MATCHED: f32 = 1e-3;

/// Number of [`OpenPbrLobe`]s.
pub(super) const OPEN_PBR_LOBES: usize = 6;

/// The sampling strategies; the value indexes `lobe_pdf`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum OpenPbrLobe {
    /// EON, cosine-sampled.
    Diffuse = 0,
    /// The base GGX reflection shared by metal, dielectric specular and
    /// the thin wall's reflection (one roughness and anisotropy).
    Specular = 1,
    /// The thick transmissive dielectric: reflection or refraction by F.
    Translucent = 2,
    /// The coat's GGX reflection, in the coat frame.
    Coat = 3,
    /// The fuzz LTC.
    Fuzz = 4,
    /// The Dirac pass-through (geometry opacity, thin wall).
    Pass = 5,
}

/// OpenPBR Surface at one hit for one `wo`: the lobes of the layer tree
/// with every `wo`-dependent weight evaluated. Directions are in the base
/// shading frame unless named `_c` (coat frame).
#[derive(Clone, Debug)]
pub(crate) struct OpenPbr {
    /// The coat's shading frame (world).
    pub(super) coat_frame: Frame,
    /// presence (1 - F E_fuzz(wo)): what reaches the coat and base.
    pub(super) below_fuzz: f32,
    /// presence F fuzz_color.
    pub(super) fuzz_tint: Vec3,
    pub(super) fuzz: Fuzz,
    /// coat_weight in [0, 1].
    pub(super) coat: f32,
    pub(super) coat_ggx: Ggx,
    /// coat_ior (relative to the ambient medium), >= 1.
    pub(super) coat_eta: f32,
    /// The coat lobe's Turquin compensation at `wo`.
    pub(super) coat_compensation: f32,
    /// C (1 - E_coat(wo)) lerp(1, Delta, coat_darkening): the coated part of
    /// W before the coat's absorption.
    pub(super) coated: Vec3,
    /// ln(coat_color) / 2: T_coat = exp(this (1/mu_t,i + 1/mu_t,o)).
    pub(super) coat_log_t: Vec3,
    /// 1 / mu_t,o: `wo`'s path length factor inside the coat.
    pub(super) coat_path_o: f32,
    /// base_metalness M.
    pub(super) metal: f32,
    /// (1 - M)(1 - T): the glossy-diffuse (and subsurface) slab.
    pub(super) gloss: f32,
    /// (1 - M) T: the translucent slab.
    pub(super) translucent: f32,
    /// Base GGX (specular_roughness roughened by the coat, anisotropy).
    pub(super) ggx: Ggx,
    /// specular_weight base_weight base_color: the metal's F0.
    pub(super) metal_f0: Vec3,
    /// F82-tint coefficient b.
    pub(super) metal_b: Vec3,
    /// specular_weight times the metal's Turquin compensation at `wo`.
    pub(super) metal_scale: Vec3,
    /// specular_color: tints the dielectric reflections.
    pub(super) specular_tint: Vec3,
    /// Modulated specular ior ratio eta'_s >= 1 (may be infinite).
    pub(super) specular_eta: f32,
    /// Turquin compensation of the dielectric specular at `wo`.
    pub(super) specular_compensation: f32,
    /// 1 - E_specular(wo): what the specular layer lets reach the diffuse
    /// (per channel: a thin film colours it).
    pub(super) through_specular: Vec3,
    /// The thin film on the base, if any (thin_film.rs).
    pub(super) film: Option<ThinFilm>,
    /// What the film lies on: the dielectric specular's interface and the
    /// metal's fitted complex index.
    pub(super) specular_below: Substrate,
    pub(super) metal_below: Substrate,
    pub(super) eon: Eon,
    /// thin-walled transmission: reflection with the thin sheet's Fresnel
    /// and a Dirac pass-through.
    pub(super) thin: bool,
    /// Relative index of the far side over `wo`'s side for refraction.
    pub(super) transmission_eta: f32,
    /// transmission_color where it tints the interface (thin walls, and
    /// thick ones of transmission_depth 0); white where the interior
    /// absorbs instead (medium.rs).
    pub(super) transmission_tint: Vec3,
    /// The thin film on the dielectric's outer face (each face of a thin
    /// wall), under the ambient medium (the transmission interface is
    /// uncoated), if any.
    pub(super) transmission_film: Option<ThinFilm>,
    /// Turquin compensation of the thin wall's reflection at `wo`.
    pub(super) thin_compensation: f32,
    /// The Dirac pass-through's weight at `wo` (RGB).
    pub(super) pass: Vec3,
    pub(super) lobe_pdf: [f32; OPEN_PBR_LOBES],
    /// What [`OpenPbr::albedo`] returns.
    pub(super) albedo: Vec3,
}

/// A weight clamped to [0, 1] (NaN to 0).
fn unit(x: f32) -> f32 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// A colour clamped to [0, 1] per channel (NaN to 0).
fn unit_color(c: Vec3) -> Vec3 {
    Vec3::new(unit(c.x), unit(c.y), unit(c.z))
}

/// An index of refraction: finite and positive, else 1.5.
fn ior(n: f32) -> f32 {
    if n.is_finite() && n > 0.0 {
        n
    } else {
        1.5
    }
}

/// OpenPBR's specular_weight modulation (eqs. "unmodulated_fresnel" and
/// "modulated_ior"): the normal-incidence reflectance ((eta - 1) / (eta +
/// 1))^2 times xi, clamped to [0, 1]. The returned F0 defines eta'_s.
fn modulated_f0(eta: f32, xi: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    let xi = if xi.is_nan() { 0.0 } else { xi.max(0.0) };
    (xi * r * r).clamp(0.0, 1.0)
}

/// The mean of the three channels.
pub(super) fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

impl OpenPbr {
    /// The mixture for `inputs` seen from `wo` (world), with the base frame
    /// `frames.base` (which the [`Bsdf`](crate::materials::Bsdf) keeps).
    pub(crate) fn new(inputs: &OpenPbrInputs, frames: &ShadingFrames, wo: Vec3) -> Self {
        let i = inputs;
        let wo_l = frames.base.to_local(wo);
        let wo_c = frames.coat.to_local(wo);
        let mu_o = wo_l.z.clamp(0.0, 1.0);
        let presence = unit(i.geometry_opacity);

        // Fuzz (Zeltner et al. 2022).
        let fuzz = Fuzz::new(wo_l, i.fuzz_roughness);
        let fuzz_weight = unit(i.fuzz_weight);
        let fuzz_tint = presence * fuzz_weight * i.fuzz_color.max(Vec3::ZERO);
        let below_fuzz = presence * (1.0 - fuzz_weight * fuzz.albedo());

        // Coat: Fresnel of coat_ior, own roughness and frame.
        let coat = if wo_c.z > 0.0 {
            unit(i.coat_weight)
        } else {
            0.0
        };
        let coat_ior = ior(i.coat_ior);
        let coat_eta = coat_ior.max(1.0 / coat_ior);
        let coat_ggx = Ggx::anisotropic(i.coat_roughness, i.coat_roughness_anisotropy);
        let coat_f0 = fresnel::f0_from_ior(coat_eta);
        let mu_c = wo_c.z.clamp(0.0, 1.0);
        let coat_compensation = albedo::compensation(mu_c, &coat_ggx, Vec3::splat(coat_f0)).x;
        let coat_albedo =
            (coat_compensation * Interface::Dielectric.albedo(mu_c, &coat_ggx, coat_f0)).min(1.0);
        let coat_log_t = 0.5 * i.coat_color.max(Vec3::splat(1e-6)).min(Vec3::ONE).ln();
        let coat_path_o = refracted_path(mu_c, coat_eta);

        // Roughening of the base by a rough coat (spec "Roughening").
        let r = unit(i.specular_roughness);
        let r_c = unit(i.coat_roughness);
        let roughened = (r.powi(4) + 2.0 * r_c.powi(4)).min(1.0).powf(0.25);
        let r_base = r + (roughened - r) * coat;
        let ggx = Ggx::anisotropic(r_base, i.specular_roughness_anisotropy);

        // Metal: F82-tint, scaled by specular_weight.
        let xi = if i.specular_weight.is_nan() {
            0.0
        } else {
            i.specular_weight.max(0.0)
        };
        let metal_f0 = unit_color(unit(i.base_weight) * i.base_color);
        let metal_b = fresnel::f82_tint_b(metal_f0, unit_color(i.specular_color));
        let metal_scale = xi.min(1.0)
            * albedo::compensation(mu_o, &ggx, fresnel::f82_tint(metal_f0, metal_b, 1.0));

        // Dielectric specular: ior relative to the coat where present (with
        // the spec's TIR fix), modulated by specular_weight.
        let n_b = ior(i.specular_ior);
        let eta_bc = if coat_ior > n_b {
            coat_ior / n_b
        } else {
            n_b / coat_ior
        };
        let eta_s = n_b.max(1.0 / n_b) + (eta_bc - n_b.max(1.0 / n_b)) * coat;
        let specular_f0 = modulated_f0(eta_s, xi);
        let specular_eta = Interface::eta_from_f0(specular_f0);
        let specular_compensation = albedo::compensation(mu_o, &ggx, Vec3::splat(specular_f0)).x;
        let specular_albedo = |mu: f32| {
            (albedo::compensation(mu, &ggx, Vec3::splat(specular_f0)).x
                * Interface::Dielectric.albedo(mu, &ggx, specular_f0))
            .min(1.0)
        };
        // Thin film on the base, under the coat (the medium above it is the
        // coat where coated, blended by coat_weight as the indices are).
        let film = ThinFilm::new(
            i.thin_film_weight,
            i.thin_film_thickness,
            i.thin_film_ior,
            1.0 + (coat_ior - 1.0) * coat,
        );
        let specular_below = Substrate::dielectric(specular_eta.min(1e4));
        let metal_below = Substrate::metal(metal_f0, unit_color(i.specular_color));
        // With a film, its directional albedo, approximated as the filmless
        // one scaled by the ratio of the Fresnel factors at wo.
        let e_specular = match &film {
            None => Vec3::splat(specular_albedo(mu_o)),
            Some(f) => {
                let bare = Interface::Dielectric.fresnel(mu_o, specular_eta);
                let ratio =
                    with_film(Some(f), Vec3::splat(bare), mu_o, &specular_below) / bare.max(1e-6);
                (specular_albedo(mu_o) * ratio).min(Vec3::ONE)
            }
        };

        // Diffuse: EON, its colour blended with the subsurface fallback.
        let subsurface = unit(i.subsurface_weight);
        let rho = (unit(i.base_weight) * i.base_color.max(Vec3::ZERO))
            .lerp(i.subsurface_color.max(Vec3::ZERO), subsurface);
        let eon = Eon::new(rho, i.base_diffuse_roughness, mu_o);

        // Transmission: the same interface with the uncoated, modulated ior.
        let metal = unit(i.base_metalness);
        let transmission = unit(i.transmission_weight);
        let (gloss, translucent) = (
            (1.0 - metal) * (1.0 - transmission),
            (1.0 - metal) * transmission,
        );
        let transmission_f0 = modulated_f0(n_b.max(1.0 / n_b), xi).min(0.999);
        let eta_t = Interface::eta_from_f0(transmission_f0);
        let index_matched = eta_t - 1.0 < INDEX_MATCHED;
        let thin = i.geometry_thin_walled;
        let transmission_eta = if thin || frames.front {
            eta_t
        } else {
            1.0 / eta_t
        };
        let transmission_tint = if thin || !has_interior(i.transmission_depth) {
            unit_color(i.transmission_color)
        } else {
            Vec3::ONE
        };
        let transmission_film = if index_matched {
            None
        } else {
            ThinFilm::new(
                i.thin_film_weight,
                i.thin_film_thickness,
                i.thin_film_ior,
                1.0,
            )
        };
        let thin_f0 = fresnel::thin_dielectric(1.0, eta_t);
        let thin_compensation = albedo::compensation(mu_o, &ggx, Vec3::splat(thin_f0)).x;
        // With a film, the sheet's albedo scaled by the ratio of its
        // reflectances with and without the film at wo (as e_specular).
        let thin_albedo = if thin && !index_matched {
            let e = thin_compensation * Interface::ThinSheet.albedo(mu_o, &ggx, transmission_f0);
            let ratio = transmission_film.as_ref().map_or(Vec3::ONE, |f| {
                let bare = Interface::ThinSheet.fresnel(mu_o, eta_t);
                f.sheet_reflectance(mu_o, eta_t) / bare.max(1e-6)
            });
            (e * ratio).min(Vec3::ONE)
        } else {
            Vec3::ZERO
        };

        // Coat darkening (spec "Darkening"): Delta = (1 - K) / (1 - E_b K).
        let k_r = 1.0 - (1.0 - albedo::average_fresnel(coat_eta)) / (coat_eta * coat_eta);
        let k_s = fresnel::dielectric(mu_c, coat_eta);
        let r_dielectric = 1.0 + (r - 1.0) * specular_f0;
        let k = k_s + (k_r - k_s) * (r_dielectric + (r - r_dielectric) * metal);
        let e_base_normal = metal * fresnel::f82_tint(metal_f0, metal_b, 1.0) * xi.min(1.0)
            + gloss * (specular_albedo(1.0) + (1.0 - specular_albedo(1.0)) * rho.min(Vec3::ONE))
            + Vec3::splat(translucent);
        let delta = Vec3::splat(1.0 - k) / (Vec3::ONE - e_base_normal * k).max(Vec3::splat(1e-6));
        let darkening = Vec3::ONE.lerp(delta, unit(i.coat_darkening));
        let coated = coat * (1.0 - coat_albedo) * darkening;

        let mut model = Self {
            coat_frame: frames.coat,
            below_fuzz,
            fuzz_tint,
            fuzz,
            coat,
            coat_ggx,
            coat_eta,
            coat_compensation,
            coated,
            coat_log_t,
            coat_path_o,
            metal,
            gloss,
            translucent,
            ggx,
            metal_f0,
            metal_b,
            metal_scale,
            specular_tint: i.specular_color.max(Vec3::ZERO),
            specular_eta,
            specular_compensation,
            through_specular: Vec3::ONE - e_specular,
            film,
            specular_below,
            metal_below,
            eon,
            thin: thin || index_matched,
            transmission_eta,
            transmission_tint,
            transmission_film,
            thin_compensation,
            pass: Vec3::ZERO,
            lobe_pdf: [0.0; OPEN_PBR_LOBES],
            albedo: Vec3::ZERO,
        };
        // The pass-through: what geometry_opacity lets by, and what the
        // thin (or index-matched) wall transmits straight through.
        let w_o = below_fuzz * model.base_weight(mu_c);
        model.pass = Vec3::splat(1.0 - presence)
            + w_o
                * (translucent * (Vec3::ONE - thin_albedo))
                * transmission_tint
                * f32::from(thin || index_matched);
        let metal_albedo = model.metal_scale * model.metal_fresnel(mu_o);
        let thick = translucent * f32::from(!(thin || index_matched));
        let f_t = model.reflect_probability(mu_o);
        model.lobe_pdf = normalized([
            mean(w_o) * gloss * mean((Vec3::ONE - e_specular) * rho),
            mean(w_o)
                * (metal * mean(metal_albedo)
                    + gloss * mean(e_specular * model.specular_tint)
                    + translucent * mean(thin_albedo)),
            mean(w_o) * thick * (f_t + (1.0 - f_t) * mean(transmission_tint)),
            below_fuzz * coat * coat_albedo,
            mean(fuzz_tint) * fuzz.albedo(),
            mean(model.pass),
        ]);
        let opaque = rho.lerp(Vec3::ONE, transmission).lerp(metal_f0, metal);
        model.albedo = presence * opaque + Vec3::splat(1.0 - presence);
        model
    }

    /// W(wo, wi) = (1 - C) + C T_coat (1 - E_coat(wo)) lerp(1, Delta, delta):
    /// what reaches the base through the coat, for `wi` at coat-frame cosine
    /// `mu_i_c` (either side).
    pub(super) fn base_weight(&self, mu_i_c: f32) -> Vec3 {
        if self.coat <= 0.0 {
            return Vec3::ONE;
        }
        let path = self.coat_path_o + refracted_path(mu_i_c.abs(), self.coat_eta);
        let absorbed = if self.coat_log_t == Vec3::ZERO {
            Vec3::ONE
        } else {
            (self.coat_log_t * path).exp()
        };
        Vec3::splat(1.0 - self.coat) + self.coated * absorbed
    }

    /// The metal's F82-tint Fresnel at microfacet cosine `cos`, with the
    /// film where present.
    pub(super) fn metal_fresnel(&self, cos: f32) -> Vec3 {
        let bare = fresnel::f82_tint(self.metal_f0, self.metal_b, cos);
        with_film(self.film.as_ref(), bare, cos, &self.metal_below)
    }

    /// The dielectric specular's Fresnel at microfacet cosine `cos`, with
    /// the film where present.
    pub(super) fn specular_fresnel(&self, cos: f32) -> Vec3 {
        let bare = Vec3::splat(Interface::Dielectric.fresnel(cos, self.specular_eta));
        with_film(self.film.as_ref(), bare, cos, &self.specular_below)
    }

    /// The thick dielectric's reflectance at microfacet cosine `cos` (from
    /// `wo`'s side), per channel: exact Fresnel, or with the film where
    /// present (its transmittance is 1 minus this: the film is lossless).
    pub(super) fn transmission_fresnel(&self, cos: f32) -> Vec3 {
        let bare = fresnel::dielectric(cos, self.transmission_eta);
        match &self.transmission_film {
            None => Vec3::splat(bare),
            Some(film) => film.lossless_reflectance(cos, self.transmission_eta, bare),
        }
    }

    /// The thin wall's reflectance at microfacet cosine `cos`, compensated:
    /// the thin sheet's, or with the film on its faces where present.
    pub(super) fn thin_fresnel(&self, cos: f32) -> Vec3 {
        let eta = self.transmission_eta;
        self.thin_compensation
            * match &self.transmission_film {
                None => Vec3::splat(Interface::ThinSheet.fresnel(cos, eta)),
                Some(film) => film.sheet_reflectance(cos, eta),
            }
    }

    /// The probability that sampling the thick dielectric reflects at
    /// microfacet cosine `cos`: its reflectance, averaged over channels.
    pub(super) fn reflect_probability(&self, cos: f32) -> f32 {
        match &self.transmission_film {
            None => fresnel::dielectric(cos, self.transmission_eta),
            Some(_) => mean(self.transmission_fresnel(cos)),
        }
    }

    /// Reflectance for the albedo AOV: the EON colour, white where the
    /// dielectric transmits, the metal's F0 by metalness; white where
    /// geometry_opacity lets light by.
    pub(crate) fn albedo(&self) -> Vec3 {
        self.albedo
    }

    /// Only the Dirac pass-through has weight.
    pub(crate) fn is_delta(&self) -> bool {
        self.lobe_pdf[OpenPbrLobe::Pass as usize] >= 1.0
    }
}

/// 1 / mu_t: the path length factor of a direction at cosine `mu` outside
/// once refracted into a coat of relative index `eta` (spec "View-dependent
/// absorption": mu_t = sqrt(1 - (1 - mu^2) / eta^2)).
fn refracted_path(mu: f32, eta: f32) -> f32 {
    let mu_t2 = 1.0 - (1.0 - mu * mu) / (eta * eta);
    1.0 / mu_t2.max(1e-4).sqrt()
}
