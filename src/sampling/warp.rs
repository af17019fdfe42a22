//! Warps from the unit square to the domains Monte Carlo integrals need, each
//! with its density, and the MIS weights. Formulas as in pbrt-v4 §A.5 and
//! Mitsuba 3's `warp.h`; directions are in a local frame with +z the normal.

use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

use glam::{Vec2, Vec3};

/// Shirley-Chiu concentric map of `u` in [0,1)^2 to the unit disk: area
/// preserving with low distortion, so stratification survives.
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method); density
/// [`cosine_hemisphere_pdf`].
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density per steradian of [`square_to_cosine_hemisphere`]: cos(theta) / pi.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere; density 1 / (4 pi).
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone of half-angle acos(`cos_theta_max`) around
/// +z; density [`uniform_cone_pdf`].
pub fn square_to_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_theta_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density per steradian of [`square_to_uniform_cone`]: 1 / (2 pi (1 - cos_theta_max)).
pub fn uniform_cone_pdf(cos_theta_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_theta_max))
}

/// Uniform point on a triangle as barycentric weights of its second and third
/// vertices (Heitz 2019, "A Low-Distortion Map Between Triangle and Square").
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    if u.y > u.x {
        let b0 = u.x / 2.0;
        let b1 = u.y - b0;
        Vec2::new(b1, 1.0 - b0 - b1)
    } else {
        let b1 = u.y / 2.0;
        let b0 = u.x - b1;
        Vec2::new(b1, 1.0 - b0 - b1)
    }
}

/// Veach's power heuristic (beta = 2) weight for a sample drawn from the
/// strategy with density `pdf_f` when the other strategy has density `pdf_g`
/// (one sample each): pdf_f^2 / (pdf_f^2 + pdf_g^2).
pub fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    if pdf_f.is_infinite() {
        return 1.0;
    }
    let (f, g) = (pdf_f * pdf_f, pdf_g * pdf_g);
    if f + g == 0.0 {
        0.0
    } else {
        f / (f + g)
    }
}

/// Solid-angle density of a point sampled by area density `pdf_area` (per
/// square scene unit), seen from `distance` away at cosine `cos_light` to the
/// light's normal: pdf_area d^2 / |cos|. Infinite for a grazing point.
pub fn area_to_solid_angle(pdf_area: f32, distance: f32, cos_light: f32) -> f32 {
    pdf_area * distance * distance / cos_light.abs()
}

/// Equiangular sampling of a distance along a ray towards a point (Kulla &
/// Fajardo 2012, "Importance Sampling Techniques for Path Tracing in
/// Participating Media", §4.1): t in [a, b] is `delta + h tan(theta)` with
/// theta uniform between the angles at which the point sees a and b, where
/// `delta` is the ray parameter of the closest approach and `h` its distance
/// to the point; so pdf(t) = h / ((theta_b - theta_a)(h^2 + (t - delta)^2)),
/// proportional to the inverse square distance to the point.
#[derive(Clone, Copy, Debug)]
pub struct Equiangular {
    delta: f32,
    h: f32,
    theta_a: f32,
    theta_b: f32,
}

impl Equiangular {
    /// A distance in [a, b] for `u` in [0, 1).
    pub fn sample(&self, u: f32) -> f32 {
        let theta = self.theta_a + u * (self.theta_b - self.theta_a);
        self.delta + self.h * theta.tan()
    }

    /// Density of `t` (per scene unit) within [a, b].
    pub fn pdf(&self, t: f32) -> f32 {
        let x = t - self.delta;
        self.h / ((self.theta_b - self.theta_a) * (self.h * self.h + x * x))
    }

    /// Towards `point` along `origin + t direction` (unit direction) for t
    /// in [a, b]; `None` for an empty interval. A ray through the point
    /// keeps a tiny `h` (relative to the interval), so the density stays
    /// finite and normalised.
    pub fn new(origin: Vec3, direction: Vec3, point: Vec3, a: f32, b: f32) -> Option<Self> {
        let delta = (point - origin).dot(direction);
        let h = (origin + direction * delta - point)
            .length()
            .max(1e-5 * (b - a).max(f32::MIN_POSITIVE));
        let theta_a = ((a - delta) / h).atan();
        let theta_b = ((b - delta) / h).atan();
        (theta_b > theta_a).then_some(Self {
            delta,
            h,
            theta_a,
            theta_b,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    #[test]
    fn equiangular_density_is_normalised_and_matches_its_samples() {
        let origin = Vec3::new(-1.0, 0.3, 0.2);
        let direction = Vec3::new(1.0, 0.2, -0.1).normalize();
        let point = Vec3::new(0.5, 0.6, 0.0);
        for (a, b) in [(0.0f32, 3.0f32), (1.2, 1.4), (2.0, 9.0)] {
            let e = Equiangular::new(origin, direction, point, a, b).unwrap();
            // Midpoint rule over [a, b]: the density integrates to 1.
            let n = 20_000;
            let step = (b - a) / n as f32;
            let integral: f64 = (0..n)
                .map(|i| f64::from(e.pdf(a + (i as f32 + 0.5) * step) * step))
                .sum();
            assert!((integral - 1.0).abs() < 1e-3, "integral {integral}");
            // The sampled mean equals the density's mean within 4 sigma.
            let mean_pdf: f64 = (0..n)
                .map(|i| {
                    let t = a + (i as f32 + 0.5) * step;
                    f64::from(t * e.pdf(t) * step)
                })
                .sum();
            let mut rng = Pcg32::new(3, 0);
            let samples: Vec<f64> = (0..20_000)
                .map(|_| f64::from(e.sample(rng.next_f32())))
                .collect();
            assert!(samples
                .iter()
                .all(|t| (a as f64 - 1e-4..=b as f64 + 1e-4).contains(t)));
            let m = samples.iter().sum::<f64>() / samples.len() as f64;
            let var =
                samples.iter().map(|t| (t - m).powi(2)).sum::<f64>() / (samples.len() - 1) as f64;
            let sigma = (var / samples.len() as f64).sqrt();
            assert!(
                (m - mean_pdf).abs() < 4.0 * sigma + 1e-4,
                "{m} vs {mean_pdf}"
            );
        }
        assert!(Equiangular::new(origin, direction, point, 1.0, 1.0).is_none());
    }

    fn grid(n: u32) -> impl Iterator<Item = Vec2> {
        (0..n * n).map(move |i| {
            Vec2::new(
                ((i % n) as f32 + 0.5) / n as f32,
                ((i / n) as f32 + 0.5) / n as f32,
            )
        })
    }

    #[test]
    fn warps_land_on_their_domains() {
        for u in grid(64) {
            assert!(square_to_concentric_disk(u).length() <= 1.0 + 1e-6);
            let c = square_to_cosine_hemisphere(u);
            assert!((c.length() - 1.0).abs() < 1e-5 && c.z >= 0.0);
            assert!((square_to_uniform_sphere(u).length() - 1.0).abs() < 1e-5);
            let k = square_to_uniform_cone(u, 0.9);
            assert!(k.z >= 0.9 - 1e-6 && (k.length() - 1.0).abs() < 1e-5);
            let b = square_to_uniform_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }

    /// E[cos^2 / pdf] over cosine sampling is the integral of cos^2 over the
    /// hemisphere, 2 pi / 3; E[z] under uniform triangle sampling is 1/3 per
    /// barycentric. Means within 4 sigma of the analytic values.
    #[test]
    fn estimators_match_analytic_integrals_within_4_sigma() {
        let mut rng = Pcg32::new(7, 0);
        let n = 200_000;
        let (mut sum, mut sum2, mut bary) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..n {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let w = square_to_cosine_hemisphere(u);
            let v = f64::from(w.z * w.z / cosine_hemisphere_pdf(w.z));
            sum += v;
            sum2 += v * v;
            bary += f64::from(square_to_uniform_triangle(u).x);
        }
        let mean = sum / n as f64;
        let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        let exact = 2.0 * std::f64::consts::PI / 3.0;
        assert!(
            (mean - exact).abs() < 4.0 * sigma,
            "{mean} vs {exact} (sigma {sigma})"
        );
        // Uniform barycentric weight: variance 1/18 per sample.
        let bary_sigma = (1.0 / 18.0 / n as f64).sqrt();
        assert!((bary / n as f64 - 1.0 / 3.0).abs() < 4.0 * bary_sigma);
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (f, g) in [(1.0, 3.0), (0.2, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(f, g) + power_heuristic(g, f) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(f32::INFINITY, 2.0), 1.0);
    }
}
