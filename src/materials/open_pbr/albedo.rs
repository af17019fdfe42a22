//! Directional albedos of GGX reflection lobes, tabulated once per process
//! (lazily, [`OnceLock`]) for energy compensation and albedo-scaling
//! layering.
//!
//! `E(mu_o, r, F0) = integral of F(wo.h) D G2 / (4 mu_o) over wi`: the
//! single-scattering reflection albedo of an isotropic GGX lobe of
//! roughness `r` (alpha = r^2) with the Fresnel of a dielectric interface
//! (or of a thin dielectric sheet) whose normal-incidence reflectance is
//! `F0`. F0 = 1 is a perfect mirror's Fresnel (1 everywhere), so that slice
//! is the Fresnel-free albedo E_ss used by the compensation.
//!
//! Compensation (Turquin 2019, "Practical multiple scattering compensation
//! for microfacet models"): a lobe is scaled by 1 + F0 (1 / E_ss(mu_o) - 1),
//! which returns the energy single scattering loses when F = 1 exactly and
//! approximately (F0 standing in for the average Fresnel) otherwise. The
//! factor depends on `wo` only, so compensated lobes are not reciprocal.

use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use crate::materials::fresnel;
use crate::materials::microfacet::Ggx;

/// Table nodes along mu_o = cos theta_o: i / (N_MU - 1), node 0 at
/// [`MIN_MU`].
const N_MU: usize = 32;
/// Nodes along the roughness r: j / (N_ROUGHNESS - 1).
const N_ROUGHNESS: usize = 32;
/// Nodes along sqrt(F0): k / (N_F0 - 1), denser at small F0 where the
/// Fresnel curve's grazing rise makes the albedo far from linear in F0;
/// ior 1.5 (F0 = 0.04) falls on node 3.
const N_F0: usize = 16;
/// Visible normals per table entry: a STRATA x STRATA midpoint grid.
const STRATA: usize = 32;
/// Cosine of the grazing-most node (mu = 0 has no visible microfacets).
const MIN_MU: f32 = 1e-3;

/// Which Fresnel factor a tabulated lobe carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Interface {
    /// One dielectric interface (exact unpolarised Fresnel).
    Dielectric,
    /// A thin dielectric sheet with its inter-reflections summed
    /// ([`fresnel::thin_dielectric`]).
    ThinSheet,
}

/// One interface's albedo table, mu fastest, then roughness, then sqrt(F0).
struct Table {
    albedo: Vec<f32>,
}

static DIELECTRIC: OnceLock<Table> = OnceLock::new();
static THIN_SHEET: OnceLock<Table> = OnceLock::new();

impl Interface {
    /// The relative index of refraction (>= 1) whose single interface
    /// reflects `f0` at normal incidence; infinite at `f0` = 1.
    pub(super) fn eta_from_f0(f0: f32) -> f32 {
        let s = f0.clamp(0.0, 1.0).sqrt();
        (1.0 + s) / (1.0 - s)
    }

    /// The interface's Fresnel reflectance at incidence cosine `cos` for a
    /// relative index `eta` >= 1 (1 everywhere when `eta` is infinite).
    pub(super) fn fresnel(self, cos: f32, eta: f32) -> f32 {
        if !eta.is_finite() {
            return 1.0;
        }
        match self {
            Interface::Dielectric => fresnel::dielectric(cos, eta),
            Interface::ThinSheet => fresnel::thin_dielectric(cos, eta),
        }
    }

    fn table(self) -> &'static Table {
        match self {
            Interface::Dielectric => DIELECTRIC.get_or_init(|| Table::build(self)),
            Interface::ThinSheet => THIN_SHEET.get_or_init(|| Table::build(self)),
        }
    }

    /// Single-scattering albedo E(mu_o, r, F0) of the GGX lobe `ggx` (read
    /// at its [`Ggx::equivalent_roughness`]) with this interface's Fresnel,
    /// trilinear in the table.
    pub(super) fn albedo(self, mu_o: f32, ggx: &Ggx, f0: f32) -> f32 {
        self.table().lookup(mu_o, ggx.equivalent_roughness(), f0)
    }
}

/// Turquin's compensation factor 1 + F0 (1 / E_ss(mu_o) - 1) for a GGX
/// lobe whose Fresnel is F0 at normal incidence (RGB for metals).
pub(super) fn compensation(mu_o: f32, ggx: &Ggx, f0: Vec3) -> Vec3 {
    let e_ss = Interface::Dielectric.albedo(mu_o, ggx, 1.0).max(1e-3);
    Vec3::ONE + f0 * (1.0 / e_ss - 1.0)
}

/// Hemispherical (cosine-weighted) average of a smooth dielectric
/// interface's Fresnel from outside, 2 integral of F(mu, eta) mu dmu, by the
/// midpoint rule on 64 intervals: what the coat darkening's K_r needs.
pub(super) fn average_fresnel(eta: f32) -> f32 {
    const N: usize = 64;
    (0..N)
        .map(|i| {
            let mu = (i as f32 + 0.5) / N as f32;
            2.0 * mu * Interface::Dielectric.fresnel(mu, eta) / N as f32
        })
        .sum()
}

impl Table {
    fn build(interface: Interface) -> Self {
        let mut albedo = Vec::with_capacity(N_MU * N_ROUGHNESS * N_F0);
        for k in 0..N_F0 {
            let s = k as f32 / (N_F0 - 1) as f32;
            let eta = Interface::eta_from_f0(s * s);
            for j in 0..N_ROUGHNESS {
                let ggx = Ggx::from_roughness(j as f32 / (N_ROUGHNESS - 1) as f32);
                for i in 0..N_MU {
                    let mu = (i as f32 / (N_MU - 1) as f32).max(MIN_MU);
                    albedo.push(single_scattering(interface, &ggx, eta, mu));
                }
            }
        }
        Self { albedo }
    }

    fn lookup(&self, mu: f32, roughness: f32, f0: f32) -> f32 {
        let (i, fi) = node(mu, N_MU);
        let (j, fj) = node(roughness, N_ROUGHNESS);
        let (k, fk) = node(f0.max(0.0).sqrt(), N_F0);
        let at = |i: usize, j: usize, k: usize| self.albedo[(k * N_ROUGHNESS + j) * N_MU + i];
        let bilinear = |k: usize| {
            let a = at(i, j, k) * (1.0 - fi) + at(i + 1, j, k) * fi;
            let b = at(i, j + 1, k) * (1.0 - fi) + at(i + 1, j + 1, k) * fi;
            a * (1.0 - fj) + b * fj
        };
        bilinear(k) * (1.0 - fk) + bilinear(k + 1) * fk
    }
}

/// The cell below `x` in [0, 1] on `n` uniform nodes and the fraction
/// across it (a NaN reads as 0).
fn node(x: f32, n: usize) -> (usize, f32) {
    let t = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) } * (n - 1) as f32;
    let i = (t as usize).min(n - 2);
    (i, t - i as f32)
}

/// E(mu) of `ggx` with `interface`'s Fresnel for `eta`: visible normals on
/// a midpoint grid, each reflected sample weighing F G2 / G1 (Heitz 2018).
fn single_scattering(interface: Interface, ggx: &Ggx, eta: f32, mu: f32) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let mut sum = 0.0f64;
    for a in 0..STRATA {
        for b in 0..STRATA {
            let u = Vec2::new(
                (a as f32 + 0.5) / STRATA as f32,
                (b as f32 + 0.5) / STRATA as f32,
            );
            let h = ggx.sample_visible_normal(wo, u);
            let cos = wo.dot(h);
            let wi = 2.0 * cos * h - wo;
            if wi.z <= 0.0 {
                continue;
            }
            let weight = interface.fresnel(cos, eta) * ggx.g2(wo, wi) / ggx.g1(wo);
            sum += f64::from(weight);
        }
    }
    (sum / (STRATA * STRATA) as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{warp, Pcg32};

    /// The table against an independent estimate: uniform-hemisphere
    /// sampling of f cos = F D G2 / (4 mu_o), off the table's nodes, within
    /// 4 sigma + 0.004 (interpolation).
    #[test]
    fn table_matches_a_uniform_sphere_estimate() {
        let mut rng = Pcg32::new(31, 0);
        let n = 100_000;
        for (mu, r, f0) in [
            (0.83f32, 0.37f32, 0.04f32),
            (0.31, 0.71, 0.5),
            (0.12, 0.55, 1.0),
        ] {
            let ggx = Ggx::from_roughness(r);
            let eta = Interface::eta_from_f0(f0);
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let wi = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let wi = Vec3::new(wi.x, wi.y, wi.z.abs());
                let h = (wo + wi).normalize();
                let f = Interface::Dielectric.fresnel(wo.dot(h), eta) * ggx.d(h) * ggx.g2(wo, wi)
                    / (4.0 * mu);
                let v = f64::from(f) * 2.0 * std::f64::consts::PI;
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            let table = f64::from(Interface::Dielectric.albedo(mu, &ggx, f0));
            assert!(
                (table - mean).abs() <= 4.0 * sigma + 0.004,
                "{mu} {r} {f0}: table {table} vs {mean} +- {sigma}"
            );
        }
    }

    #[test]
    fn average_fresnel_matches_known_values() {
        // Glass (1.5): about 0.092 (Kulla and Conty 2017's fit gives 0.090).
        assert!((average_fresnel(1.5) - 0.092).abs() < 3e-3);
        assert_eq!(average_fresnel(f32::INFINITY), 1.0);
        assert!(average_fresnel(1.0).abs() < 1e-6);
    }
}
