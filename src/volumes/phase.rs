//! The Henyey-Greenstein phase function (Henyey & Greenstein 1941,
//! "Diffuse radiation in the galaxy"): the angular distribution of light
//! scattered inside a medium, with one parameter, the mean cosine `g`.

use std::f32::consts::{FRAC_1_PI, TAU};

use glam::{Vec2, Vec3};

use crate::geometry::Frame;

/// A direction sampled from a phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// Unit world direction towards the next vertex.
    pub wi: Vec3,
    /// Density of `wi` per steradian; equals the phase function's value, so
    /// the sample's weight (value / pdf) is 1.
    pub pdf: f32,
}

/// The Henyey-Greenstein phase function with mean cosine `g` in (-1, 1):
/// `g > 0` scatters forward, `g < 0` backward, `g = 0` is isotropic.
/// Directions follow the path tracer: `wo` points back towards the previous
/// vertex, `wi` towards the next, so forward scattering means `wi ≈ -wo` and
/// `E[dot(-wo, wi)] = g`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    /// Mean cosine of the scattering angle, in (-1, 1).
    pub g: f32,
}

impl HenyeyGreenstein {
    /// The phase function value for scattering `wo -> wi`, per steradian; it
    /// integrates to 1 over the sphere, so it is also the pdf of [`Self::sample`].
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        henyey_greenstein(wo.dot(wi), self.g)
    }

    /// Samples `wi` exactly proportionally to [`Self::eval`] from the uniform
    /// `u` in [0, 1)^2 by inverting the CDF in `cos_theta = dot(wo, wi)`
    /// (pbrt-v4's `SampleHenyeyGreenstein`, rearranged as below).
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> PhaseSample {
        let cos_theta = sample_cos_theta(self.g, u.x);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
        let local = Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta);
        let wi = Frame::from_normal(wo).to_world(local);
        // The pdf is evaluated at the final `wi`, not at `cos_theta`: near the
        // peak of a strongly anisotropic lobe the two differ by f32 rounding,
        // and MIS needs the value that `eval` gives for the same pair.
        PhaseSample {
            wi,
            pdf: self.eval(wo, wi),
        }
    }
}

/// HG at `cos_theta = dot(wo, wi)`:
/// `(1 - g^2) / (4 pi (1 + g^2 + 2 g cos_theta)^(3/2))`. The denominator is
/// computed as `(1 + g cos)^2 + g^2 sin^2`, a sum of squares, so rounding
/// cannot make it negative when `g -> ±1` and `cos -> ∓1`.
#[inline]
fn henyey_greenstein(cos_theta: f32, g: f32) -> f32 {
    let sin2_theta = (1.0 - cos_theta * cos_theta).max(0.0);
    let denom = (1.0 + g * cos_theta).powi(2) + g * g * sin2_theta;
    0.25 * FRAC_1_PI * (1.0 - g * g) / (denom * denom.sqrt())
}

/// `cos_theta = dot(wo, wi)` for the uniform `u`: pbrt-v4's inverse CDF
/// `-(1 + g^2 - ((1 - g^2) / (1 + g v))^2) / (2 g)` with `v = 1 - 2u`,
/// expanded so the factor `g` cancels analytically:
/// `-(v (1 + g^2) + g (v^2 + 3) / 2 + g^3 (v^2 - 1) / 2) / (1 + g v)^2`.
/// This has no division by `g` (at `g = 0` it is exactly the isotropic
/// `2u - 1`) and no cancellation for small `|g|`.
#[inline]
fn sample_cos_theta(g: f32, u: f32) -> f32 {
    let v = 1.0 - 2.0 * u;
    let v2 = v * v;
    let numerator = v * (1.0 + g * g) + 0.5 * g * (v2 + 3.0) + 0.5 * g * g * g * (v2 - 1.0);
    (-numerator / (1.0 + g * v).powi(2)).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{warp, Pcg32};
    use std::f64::consts::PI;

    const GS: [f32; 4] = [-0.7, 0.0, 0.3, 0.9];

    fn mean_and_std_error(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let variance = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, (variance / n).sqrt())
    }

    fn rng_vec2(rng: &mut Pcg32) -> Vec2 {
        Vec2::new(rng.next_f32(), rng.next_f32())
    }

    #[test]
    fn eval_integrates_to_one_over_the_sphere() {
        // Uniform sphere sampling: E[p(wo, wi) * 4 pi] = 1.
        let wo = Vec3::new(0.2, -0.5, 0.7).normalize();
        for g in GS {
            let hg = HenyeyGreenstein { g };
            let mut rng = Pcg32::new(1, 0);
            let xs: Vec<f64> = (0..200_000)
                .map(|_| {
                    let wi = warp::square_to_uniform_sphere(rng_vec2(&mut rng));
                    hg.eval(wo, wi) as f64 * 4.0 * PI
                })
                .collect();
            let (mean, se) = mean_and_std_error(&xs);
            // The floor covers g = 0, where every term is 1 up to rounding.
            assert!((mean - 1.0).abs() < 4.0 * se + 1e-6, "g {g}: {mean} ± {se}");
        }
    }

    #[test]
    fn sampled_pdf_equals_eval_and_is_the_density_of_the_samples() {
        // If pdf is the density of the sampled directions (and positive
        // everywhere, as HG is), E[1 / pdf(wi)] is the sphere's area, 4 pi.
        for g in GS.into_iter().chain([0.5e-3, -0.99, 0.99]) {
            let hg = HenyeyGreenstein { g };
            let mut rng = Pcg32::new(2, 0);
            let inverse_pdfs: Vec<f64> = (0..100_000)
                .map(|_| {
                    let wo = warp::square_to_uniform_sphere(rng_vec2(&mut rng));
                    let s = hg.sample(wo, rng_vec2(&mut rng));
                    assert!((s.wi.length() - 1.0).abs() < 1e-4, "g {g}: {:?}", s.wi);
                    assert!(s.pdf > 0.0 && s.pdf.is_finite(), "g {g}: pdf {}", s.pdf);
                    assert_eq!(s.pdf, hg.eval(wo, s.wi), "g {g}");
                    1.0 / s.pdf as f64
                })
                .collect();
            let (mean, se) = mean_and_std_error(&inverse_pdfs);
            let area = 4.0 * PI;
            assert!(
                (mean - area).abs() < 4.0 * se + 1e-5,
                "g {g}: E[1/pdf] {mean} ± {se}"
            );
        }
    }

    #[test]
    fn mean_cosine_and_second_legendre_moment_match_g() {
        // HG's Legendre moments are g^l: E[cos] = g, E[P2(cos)] = g^2, with
        // cos = dot(-wo, wi) (forward scattering along the ray).
        let wo = Vec3::new(-0.3, 0.8, 0.1).normalize();
        for g in GS {
            let hg = HenyeyGreenstein { g };
            let mut rng = Pcg32::new(3, 0);
            let cosines: Vec<f64> = (0..200_000)
                .map(|_| (-wo).dot(hg.sample(wo, rng_vec2(&mut rng)).wi) as f64)
                .collect();
            let (mean, se) = mean_and_std_error(&cosines);
            assert!(
                (mean - g as f64).abs() < 4.0 * se,
                "g {g}: E[cos] {mean} ± {se}"
            );
            let p2: Vec<f64> = cosines.iter().map(|c| 1.5 * c * c - 0.5).collect();
            let (mean, se) = mean_and_std_error(&p2);
            let g2 = (g as f64).powi(2);
            assert!((mean - g2).abs() < 4.0 * se, "g {g}: E[P2] {mean} ± {se}");
        }
    }
}
