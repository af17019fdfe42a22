//! Fresnel reflectances: Schlick's approximation for the opaque lobes and the
//! exact unpolarised dielectric formula for transmission.

use glam::Vec3;

/// Schlick's approximation (Schlick 1994): `f0 + (f90 - f0) (1 - cos)^5`,
/// the reflectance at incidence cosine `cos_theta` (clamped to [0, 1]).
pub(crate) fn schlick(f0: Vec3, f90: Vec3, cos_theta: f32) -> Vec3 {
    let m = (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5);
    f0 + (f90 - f0) * m
}

/// Cosine-weighted hemispherical average of [`schlick`]:
/// 2 * integral of F(mu) mu over [0, 1] = f0 + (f90 - f0) / 21.
pub(crate) fn schlick_average(f0: Vec3, f90: Vec3) -> Vec3 {
    f0 + (f90 - f0) / 21.0
}

/// The F82-tint metal Fresnel (Kutz et al. 2021, "Novel aspects of the
/// Adobe Standard Material"; OpenPBR 1.1 "Metal"): Schlick's curve less
/// `b` mu (1 - mu)^6, with `b` from [`f82_tint_b`]; clamped to [0, 1].
pub(crate) fn f82_tint(f0: Vec3, b: Vec3, cos_theta: f32) -> Vec3 {
    let mu = cos_theta.clamp(0.0, 1.0);
    let dip = mu * (1.0 - mu).powi(6);
    (schlick(f0, Vec3::ONE, mu) - b * dip).clamp(Vec3::ZERO, Vec3::ONE)
}

/// The F82-tint coefficient b = F_Schlick(mu_bar) (1 - tint) / (mu_bar (1 -
/// mu_bar)^6) with mu_bar = 1/7 (about 82 degrees), so that the curve passes
/// through tint * F_Schlick(mu_bar) there.
pub(crate) fn f82_tint_b(f0: Vec3, tint: Vec3) -> Vec3 {
    const MU_BAR: f32 = 1.0 / 7.0;
    let denom = MU_BAR * (1.0 - MU_BAR).powi(6);
    schlick(f0, Vec3::ONE, MU_BAR) * (Vec3::ONE - tint) / denom
}

/// Normal-incidence reflectance of a dielectric with relative index of
/// refraction `ior`: ((ior - 1) / (ior + 1))^2 (0.04 for 1.5).
pub(crate) fn f0_from_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface
/// (pbrt-v4 `FrDielectric`): `cos_i` is the incidence cosine on the side the
/// light arrives from, `eta` the ratio of the far side's index to the near
/// side's. Total internal reflection returns 1.
pub(crate) fn dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Reflectance of a thin dielectric sheet with inter-reflections between its
/// two faces summed (pbrt-v4 `ThinDielectricBxDF`): R + T^2 R / (1 - R^2);
/// the sheet transmits the rest straight through.
pub(crate) fn thin_dielectric(cos_i: f32, eta: f32) -> f32 {
    let r = dielectric(cos_i, eta);
    if r >= 1.0 {
        return 1.0;
    }
    let t = 1.0 - r;
    r + t * t * r / (1.0 - r * r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_matches_known_values() {
        // Normal incidence equals ((n - 1) / (n + 1))^2 from either side.
        assert!((dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        assert!((f0_from_ior(1.5) - 0.04).abs() < 1e-6);
        // Grazing reflects everything; index-matched reflects nothing.
        assert!((dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        assert!(dielectric(0.7, 1.0).abs() < 1e-6);
        // Total internal reflection past the critical angle (41.8 deg for 1.5).
        assert_eq!(dielectric(0.5, 1.0 / 1.5), 1.0);
        // Brewster's angle (56.3 deg): only s-polarised light reflects.
        let brewster = 1.5f32.atan().cos();
        let rs = ((brewster - 1.5 * (1.0 - (1.0 - brewster * brewster) / 2.25).sqrt())
            / (brewster + 1.5 * (1.0 - (1.0 - brewster * brewster) / 2.25).sqrt()))
        .powi(2);
        assert!((dielectric(brewster, 1.5) - 0.5 * rs).abs() < 1e-6);
        // A thin sheet reflects 2R / (1 + R) at normal incidence.
        assert!((thin_dielectric(1.0, 1.5) - 0.08 / 1.04).abs() < 1e-6);
        // Schlick hits f0 at normal incidence and f90 at grazing.
        let (f0, f90) = (Vec3::splat(0.04), Vec3::ONE);
        assert!((schlick(f0, f90, 1.0) - f0).length() < 1e-6);
        assert!((schlick(f0, f90, 0.0) - f90).length() < 1e-6);
        // Its hemispherical average, by the midpoint rule.
        let n = 10_000;
        let average = (0..n)
            .map(|i| {
                let mu = (i as f32 + 0.5) / n as f32;
                2.0 * schlick(f0, f90, mu) * mu / n as f32
            })
            .sum::<Vec3>();
        assert!((average - schlick_average(f0, f90)).length() < 1e-5);
    }
}
