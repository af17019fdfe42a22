//! EON, the energy-preserving Oren-Nayar diffuse BRDF that OpenPBR 1.1
//! specifies for `base_diffuse_roughness` (Portsmouth, Kutz and Hill 2024,
//! "EON: A practical energy-preserving rough diffuse BRDF"): Fujii's
//! improved Oren-Nayar ("FON") single-scattering lobe plus a
//! multiple-scattering lobe that returns exactly the energy FON loses.
//! At roughness 0 it is Lambert. Reciprocal. Sampled cosine-weighted.

use std::f32::consts::{FRAC_1_PI, PI};

use glam::Vec3;

/// 1/2 - 2/(3 pi): FON's A = 1 / (1 + C1 r).
const C1: f32 = 0.5 - 2.0 / (3.0 * PI);
/// 2/3 - 28/(15 pi): FON's cosine-weighted average albedo A (1 + C2 r).
const C2: f32 = 2.0 / 3.0 - 28.0 / (15.0 * PI);

/// The EON lobe of albedo colour `rho` and roughness `r` for one `wo`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Eon {
    rho: Vec3,
    r: f32,
    /// FON's A coefficient.
    a: f32,
    /// Multiple-scattering albedo rho^2 E_avg / (1 - rho (1 - E_avg)).
    rho_ms: Vec3,
    /// 1 / (1 - E_avg) (0 at r = 0, where nothing is lost).
    inv_lost_avg: f32,
    /// 1 - E_FON(mu_o): what single scattering loses towards `wo`.
    lost_o: f32,
}

impl Eon {
    /// EON with albedo colour `rho` (>= 0) and roughness `r` (clamped to
    /// [0, 1]) seen from `mu_o` = cos theta_o.
    pub(super) fn new(rho: Vec3, roughness: f32, mu_o: f32) -> Self {
        let r = if roughness.is_nan() {
            0.0
        } else {
            roughness.clamp(0.0, 1.0)
        };
        let rho = rho.max(Vec3::ZERO);
        let a = 1.0 / (1.0 + C1 * r);
        let e_avg = a * (1.0 + C2 * r);
        let (rho_ms, inv_lost_avg) = if r > 0.0 {
            (
                rho * rho * e_avg / (Vec3::ONE - rho * (1.0 - e_avg)).max(Vec3::splat(1e-6)),
                1.0 / (1.0 - e_avg),
            )
        } else {
            (Vec3::ZERO, 0.0)
        };
        Self {
            rho,
            r,
            a,
            rho_ms,
            inv_lost_avg,
            lost_o: (1.0 - fon_albedo(mu_o, r)).max(0.0),
        }
    }

    /// f(wo, wi) cos theta_i (shading frame, both above the surface):
    /// rho/pi A (1 + r s/t) + rho_ms/pi (1 - E(mu_o)) (1 - E(mu_i)) / (1 -
    /// E_avg), with s = wi.wo - mu_i mu_o and t = max(mu_i, mu_o) where s > 0
    /// (EON paper, eqs. 4, 9 and 11).
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (mu_i, mu_o) = (wi.z, wo.z);
        let s = wi.dot(wo) - mu_i * mu_o;
        let s_over_t = if s > 0.0 { s / mu_i.max(mu_o) } else { s };
        let single = self.rho * (FRAC_1_PI * self.a * (1.0 + self.r * s_over_t));
        let multiple = if self.inv_lost_avg > 0.0 {
            let lost_i = (1.0 - fon_albedo(mu_i, self.r)).max(0.0);
            self.rho_ms * (FRAC_1_PI * self.lost_o * lost_i * self.inv_lost_avg)
        } else {
            Vec3::ZERO
        };
        (single + multiple).max(Vec3::ZERO) * mu_i
    }
}

/// FON's exact directional albedo (EON paper, eq. 6): A + B/pi G(mu) with
/// B = r A and G = sin(acos mu - sin mu) + 2/3 (sin/mu (1 - sin^3) - sin),
/// where sin = sin theta. 1 - sin^3 is written (1 - sin)(1 + sin + sin^2)
/// with 1 - sin = mu^2 / (1 + sin), which stays accurate at grazing angles.
pub(super) fn fon_albedo(mu: f32, r: f32) -> f32 {
    let mu = mu.clamp(1e-6, 1.0);
    let a = 1.0 / (1.0 + C1 * r);
    let sin = (1.0 - mu * mu).max(0.0).sqrt();
    let one_minus_sin = mu * mu / (1.0 + sin);
    let one_minus_sin3 = one_minus_sin * (1.0 + sin + sin * sin);
    let g = sin * (mu.acos() - sin * mu) + (2.0 / 3.0) * (sin / mu * one_minus_sin3 - sin);
    a + r * a * FRAC_1_PI * g
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::sampling::{warp, Pcg32};

    /// White EON reflects everything (cosine-sampled estimate, 4 sigma and
    /// 1%), the exact FON albedo matches its lobe, and the lobe is
    /// reciprocal.
    #[test]
    fn white_eon_conserves_energy_and_is_reciprocal() {
        let mut rng = Pcg32::new(41, 0);
        let n = 40_000;
        for r in [0.0f32, 0.5, 1.0] {
            for mu_o in [1.0f32, 0.6, 0.15] {
                let wo = Vec3::new((1.0 - mu_o * mu_o).sqrt(), 0.0, mu_o);
                let eon = Eon::new(Vec3::ONE, r, mu_o);
                let single = Eon {
                    inv_lost_avg: 0.0,
                    ..eon
                };
                let (mut sum, mut sum2, mut ss) = (0.0f64, 0.0f64, 0.0f64);
                for _ in 0..n {
                    let wi = warp::square_to_cosine_hemisphere(Vec2::new(
                        rng.next_f32(),
                        rng.next_f32(),
                    ));
                    let pdf = warp::cosine_hemisphere_pdf(wi.z);
                    let v = f64::from(eon.eval(wo, wi).x / pdf);
                    sum += v;
                    sum2 += v * v;
                    ss += f64::from(single.eval(wo, wi).x / pdf);
                    let back = eon.eval(wi, wo).x / mu_o;
                    let forth = Eon::new(Vec3::ONE, r, wi.z).eval(wi, wo).x / mu_o;
                    let there = eon.eval(wo, wi).x / wi.z;
                    assert!(
                        (forth - there).abs() <= 1e-4 * there.max(1e-3),
                        "{forth} {there} {back}"
                    );
                }
                let mean = sum / n as f64;
                let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                assert!(
                    (mean - 1.0).abs() <= (4.0 * sigma + 1e-4).min(0.01),
                    "r {r} mu {mu_o}: {mean} +- {sigma}"
                );
                let fon = f64::from(fon_albedo(mu_o, r));
                assert!(
                    (ss / n as f64 - fon).abs() < 0.01,
                    "{} vs {fon}",
                    ss / n as f64
                );
            }
        }
    }
}
