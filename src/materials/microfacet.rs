//! The GGX (Trowbridge-Reitz) microfacet distribution with Smith's
//! height-correlated masking-shadowing (Heitz 2014, "Understanding the
//! Masking-Shadowing Function in Microfacet-Based BRDFs") and sampling of its
//! visible normals through a spherical cap (Dupuy and Benyoub 2023, "Sampling
//! Visible GGX Normals with Spherical Caps"). Directions are in the shading
//! frame (+z the normal); `wo` must be above it.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

/// Smallest GGX alpha used: roughness 0 becomes alpha 1e-3 (a mirror to
/// within a fraction of a degree) rather than a Dirac lobe, so every GGX lobe
/// keeps a finite density and MIS with light sampling works unchanged. The
/// peak density 1 / (pi alpha^2) = 3.2e5 stays well inside f32.
pub(crate) const MIN_ALPHA: f32 = 1e-3;

/// A GGX distribution with roughness `alpha` along the frame's x axis and
/// `alpha_y` along its y axis (equal for the isotropic UsdPreviewSurface
/// lobes, which then take the isotropic formulas' exact arithmetic).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ggx {
    alpha: f32,
    alpha_y: f32,
}

impl Ggx {
    /// Normal distribution D(h) per unit projected area (Walter et al. 2007, eq. 33).
    pub(crate) fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        if self.alpha != self.alpha_y {
            // Heitz 2014, eq. 85: slopes stretched by each axis' alpha.
            let (x, y) = (h.x / self.alpha, h.y / self.alpha_y);
            let k = x * x + y * y + h.z * h.z;
            return 1.0 / (PI * self.alpha * self.alpha_y * k * k);
        }
        let a2 = self.alpha * self.alpha;
        let k = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
        1.0 / (PI * a2 * k * k)
    }

    /// Smith's Lambda(w) for GGX (Heitz 2014, eq. 72); symmetric in w.z's sign.
    fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f32::INFINITY;
        }
        if self.alpha != self.alpha_y {
            // Heitz 2014, eq. 86: alpha projected on w's azimuth.
            let (x, y) = (w.x * self.alpha, w.y * self.alpha_y);
            return 0.5 * ((1.0 + (x * x + y * y) / z2).sqrt() - 1.0);
        }
        let tan2 = (w.x * w.x + w.y * w.y) / z2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// Smith masking G1(w) = 1 / (1 + Lambda(w)).
    pub(crate) fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2 = 1 / (1 + Lambda(wo) + Lambda(wi))
    /// (Heitz 2014, eq. 99), for reflection and transmission alike.
    pub(crate) fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of [`Ggx::sample_visible_normal`] drawing `h` for `wo`:
    /// D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z (Heitz 2018, eq. 3).
    pub(crate) fn visible_normal_pdf(&self, wo: Vec3, h: Vec3) -> f32 {
        let cos = wo.dot(h);
        if cos <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * cos * self.d(h) / wo.z
    }

    /// A microfacet normal visible from `wo` (wo.z > 0), distributed as
    /// [`Ggx::visible_normal_pdf`]: Dupuy and Benyoub 2023, listing 3. The
    /// view is stretched to the unit-roughness configuration, where visible
    /// normals are `wo` plus a uniform point on the spherical cap below it.
    pub(crate) fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let (a, a_y) = (self.alpha, self.alpha_y);
        let wo_std = Vec3::new(wo.x * a, wo.y * a_y, wo.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
        let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let cap = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), z);
        let h_std = cap + wo_std;
        Vec3::new(h_std.x * a, h_std.y * a_y, h_std.z.max(0.0)).normalize_or(Vec3::Z)
    }

    /// GGX with `alpha` = max(`roughness`^2, [`MIN_ALPHA`]), the
    /// UsdPreviewSurface (and Disney 2012) remapping of perceptual roughness.
    pub(crate) fn from_roughness(roughness: f32) -> Self {
        let r = roughness.clamp(0.0, 1.0);
        let alpha = (r * r).max(MIN_ALPHA);
        Self {
            alpha,
            alpha_y: alpha,
        }
    }

    /// OpenPBR's anisotropic GGX (specification 1.1, "Microfacet model"):
    /// alpha_t = r^2 sqrt(2 / (1 + (1 - a)^2)) along the tangent (local x),
    /// alpha_b = (1 - a) alpha_t along the bitangent, for roughness `r` and
    /// anisotropy `a` (both clamped to [0, 1]), each at least [`MIN_ALPHA`].
    /// At a = 0 this is [`Ggx::from_roughness`].
    pub(crate) fn anisotropic(roughness: f32, anisotropy: f32) -> Self {
        let r = roughness.clamp(0.0, 1.0);
        let a = anisotropy.clamp(0.0, 1.0);
        if a == 0.0 {
            return Self::from_roughness(r);
        }
        let alpha_t = r * r * (2.0 / (1.0 + (1.0 - a) * (1.0 - a))).sqrt();
        Self {
            alpha: alpha_t.max(MIN_ALPHA),
            alpha_y: ((1.0 - a) * alpha_t).max(MIN_ALPHA),
        }
    }

    /// The isotropic roughness with the same slope area, sqrt(sqrt(alpha_t
    /// alpha_b)): where albedo tables (indexed by isotropic roughness) are
    /// read for an anisotropic lobe.
    pub(crate) fn equivalent_roughness(&self) -> f32 {
        (self.alpha * self.alpha_y).sqrt().sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{warp, Pcg32};

    /// Projected-area normalisation: the integral of D(h) h.z over the
    /// hemisphere is 1, and of D_wo(h) over the hemisphere is 1 (uniform
    /// hemisphere estimates within 4 sigma), for smooth and rough alphas and
    /// an anisotropic one.
    #[test]
    fn distribution_and_visible_normals_are_normalised() {
        let mut rng = Pcg32::new(7, 1);
        let n = 200_000;
        for (roughness, anisotropy) in [(0.3f32, 0.0), (0.6, 0.0), (1.0, 0.0), (0.5, 0.8)] {
            let ggx = Ggx::anisotropic(roughness, anisotropy);
            let wo = Vec3::new(0.6, 0.0, 0.8);
            for f in [
                (|g: &Ggx, _: Vec3, h: Vec3| g.d(h) * h.z) as fn(&Ggx, Vec3, Vec3) -> f32,
                |g: &Ggx, wo: Vec3, h: Vec3| g.visible_normal_pdf(wo, h),
            ] {
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let mut h =
                        warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                    h.z = h.z.abs();
                    let v = f64::from(f(&ggx, wo, h)) * 2.0 * std::f64::consts::PI;
                    sum += v;
                    sum2 += v * v;
                }
                let mean = sum / n as f64;
                let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                assert!(
                    (mean - 1.0).abs() < 4.0 * sigma + 1e-4,
                    "{roughness}: {mean} +- {sigma}"
                );
            }
        }
    }
}
