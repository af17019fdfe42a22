//! OpenPBR's fuzz layer: the sheen of Zeltner, Burley and Chiang 2022,
//! "Practical Multiple-Scattering Sheen Using Linearly Transformed Cosines",
//! which the specification cites. The lobe is a linearly transformed cosine
//! (Heitz et al. 2016) D(wi) = D_o(M^-1 wi / |M^-1 wi|) |M^-1| / |M^-1
//! wi|^3 with M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]] in a frame whose x
//! axis points towards `wo`'s azimuth, times the layer's directional albedo
//! R(mu_o, roughness). a, b and R are the paper's analytic fits to its
//! volumetric-fibre simulations (the constants of its supplemental code,
//! also used by MaterialX's reference implementation).
//!
//! M^-1 keeps the z component, so the transformed cosine never reaches
//! below the horizon: the lobe integrates to exactly R, it is sampled
//! exactly (pdf = D), and albedo scaling of what lies below by 1 - R
//! conserves energy. Not reciprocal (the fits depend on `wo`).

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};

use crate::sampling::warp;

/// The fuzz lobe for one `wo` (in the base shading frame).
#[derive(Clone, Copy, Debug)]
pub(super) struct Fuzz {
    /// Unit x axis of the LTC frame: `wo`'s azimuth in the shading frame.
    x: Vec2,
    /// M^-1's diagonal a and shear b.
    a: f32,
    b: f32,
    /// Directional albedo R(mu_o, roughness) in [0, 1].
    albedo: f32,
}

impl Fuzz {
    /// The lobe for `wo` (shading frame, wo.z > 0) and `fuzz_roughness`
    /// (clamped to [0.01, 1], the fits' range).
    pub(super) fn new(wo: Vec3, roughness: f32) -> Self {
        let mu = wo.z.clamp(1e-4, 1.0);
        let r = if roughness.is_nan() {
            1.0
        } else {
            roughness.clamp(0.01, 1.0)
        };
        let x = Vec2::new(wo.x, wo.y).normalize_or(Vec2::X);
        // Zeltner et al. 2022, supplemental fits (a and b of M^-1, and R
        // as a Gaussian in mu with roughness-dependent moments).
        let a = ((2.58126 * mu + 0.813703 * r) * r / (1.0 + 0.310327 * mu * mu + 2.60994 * mu * r))
            .max(1e-4);
        let b = (1.0 - mu).sqrt() * (r - 1.0) * r * r * r
            / (0.0000254053 + 1.71228 * mu - 1.71506 * mu * r + 1.34174 * r * r);
        let s = r * (0.0206607 + 1.58491 * r) / (0.0379424 + r * (1.32227 + r));
        let m = r * (-0.193854 + r * (-1.14885 + r * (1.7932 - 0.95943 * r * r))) / (0.046391 + r);
        let o =
            r * (0.000654023 + (-0.0207818 + 0.119681 * r) * r) / (1.26264 + r * (-1.92021 + r));
        let z = (mu - m) / s;
        let albedo = (-0.5 * z * z).exp() / (s * (2.0 * std::f32::consts::PI).sqrt()) + o;
        Self {
            x,
            a,
            b,
            albedo: albedo.clamp(0.0, 1.0),
        }
    }

    /// R(mu_o): the lobe's directional albedo.
    pub(super) fn albedo(&self) -> f32 {
        self.albedo
    }

    /// f(wo, wi) cos theta_i = R D(wi), shading frame.
    pub(super) fn eval(&self, wi: Vec3) -> f32 {
        self.albedo * self.pdf(wi)
    }

    /// The LTC density D(wi) per steradian (0 below the surface).
    pub(super) fn pdf(&self, wi: Vec3) -> f32 {
        let local = self.ltc_local(wi);
        let w = Vec3::new(
            self.a * local.x + self.b * local.z,
            self.a * local.y,
            local.z,
        );
        let len2 = w.length_squared();
        if w.z <= 0.0 || len2 == 0.0 {
            return 0.0;
        }
        let len = len2.sqrt();
        // D_o(w / len) |M^-1| / len^3 with D_o the clamped cosine / pi.
        FRAC_1_PI * (w.z / len) * self.a * self.a / (len2 * len)
    }

    /// A direction distributed as [`Fuzz::pdf`]: a cosine-distributed
    /// direction mapped through M.
    pub(super) fn sample(&self, u: Vec2) -> Vec3 {
        let c = warp::square_to_cosine_hemisphere(u);
        let w = Vec3::new((c.x - self.b * c.z) / self.a, c.y / self.a, c.z).normalize_or(Vec3::Z);
        self.shading_local(w)
    }

    fn ltc_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(
            v.x * self.x.x + v.y * self.x.y,
            -v.x * self.x.y + v.y * self.x.x,
            v.z,
        )
    }

    fn shading_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(
            v.x * self.x.x - v.y * self.x.y,
            v.x * self.x.y + v.y * self.x.x,
            v.z,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// D integrates to 1 over the hemisphere (uniform estimate, 4 sigma),
    /// samples round-trip through the frame, and R stays in (0, 1).
    #[test]
    fn ltc_is_normalised_and_sampled_exactly() {
        let mut rng = Pcg32::new(43, 0);
        let n = 100_000;
        for (mu, r) in [(0.9f32, 0.5f32), (0.3, 0.2), (0.1, 1.0), (0.7, 0.01)] {
            let wo = Vec3::new(
                0.6 * (1.0 - mu * mu).sqrt(),
                0.8 * (1.0 - mu * mu).sqrt(),
                mu,
            );
            let fuzz = Fuzz::new(wo, r);
            assert!(
                fuzz.albedo() > 0.0 && fuzz.albedo() < 1.0,
                "{}",
                fuzz.albedo()
            );
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let mut wi =
                    warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                wi.z = wi.z.abs();
                let v = f64::from(fuzz.pdf(wi)) * 2.0 * std::f64::consts::PI;
                sum += v;
                sum2 += v * v;
                let s = fuzz.sample(Vec2::new(rng.next_f32(), rng.next_f32()));
                assert!(s.z >= 0.0 && (s.length() - 1.0).abs() < 1e-4);
                assert!((fuzz.ltc_local(fuzz.shading_local(s)) - s).length() < 1e-5);
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            assert!(
                (mean - 1.0).abs() <= 4.0 * sigma + 2e-3,
                "{mu} {r}: {mean} +- {sigma}"
            );
        }
    }
}
