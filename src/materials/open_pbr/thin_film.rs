//! Thin-film iridescence (OpenPBR 1.1 "Thin-film iridescence"): a smooth,
//! non-absorbing film of index n_f and thickness d on the base, folded into
//! the Fresnel factor of the metal, dielectric-specular and transmission
//! microfacet lobes (transmission gets 1 - R: the film is lossless), by the
//! model the specification recommends, Belcour and Barla 2017 ("A
//! Practical Extension to Microfacet Theory for the Modeling of Varying
//! Iridescence", ACM TOG 36(4)):
//! ```text
//! R = C_0 + sum_{m=1..3} C_m S_m(m OPD, m phi)        per polarisation, averaged
//! C_0 = R12 + T121^2 R23 / (1 - R12 R23)              the incoherent sum (eq. 7)
//! C_m = (R_s - T121) r123^m, r123 = sqrt(R12 R23)      (eq. 9)
//! OPD = 2 n_f d cos theta_f,  phi = phi21 + phi23      path and phase difference
//! ```
//! S_m is the CIE XYZ sensitivity's Fourier transform at OPD, from the
//! paper's Gaussian fits, taken to linear Rec.709 and normalised so that a
//! flat spectrum is white (so a film thinner than any wavelength leaves the
//! base's colour as it is). The base below the film is a dielectric of real
//! relative index, or for metals the complex index that Gulbrandsen 2014
//! ("Artist Friendly Metallic Fresnel", JCGT 3(4)) fits to F0 and an edge
//! tint, as the specification suggests for its F82-tint metal; the edge
//! tint used is specular_color. `thin_film_weight` blends the film's
//! Fresnel with the filmless one.

use std::f32::consts::PI;

use glam::{Mat3, Vec3};
use num_complex::Complex32;

use crate::materials::fresnel;

/// A film on the base at one hit.
#[derive(Clone, Copy, Debug)]
pub(super) struct ThinFilm {
    /// thin_film_weight in [0, 1].
    pub(super) weight: f32,
    /// Thickness in nanometres.
    thickness_nm: f32,
    /// The film's index relative to the medium above it.
    eta: f32,
}

/// What lies below the film, per Rec.709 channel: complex indices relative
/// to the medium above the film.
#[derive(Clone, Copy, Debug)]
pub(super) struct Substrate([Complex32; 3]);

impl Substrate {
    /// A dielectric of relative index `eta` (> 0).
    pub(super) fn dielectric(eta: f32) -> Self {
        Self([Complex32::new(eta, 0.0); 3])
    }

    /// The metal whose normal-incidence reflectance is `f0` and whose edge
    /// tint is `tint` (Gulbrandsen 2014, eqs. 5 and 6 of its appendix):
    /// n = g (1 - r)/(1 + r) + (1 - g)(1 + sqrt r)/(1 - sqrt r),
    /// k = sqrt((r (n + 1)^2 - (n - 1)^2) / (1 - r)).
    pub(super) fn metal(f0: Vec3, tint: Vec3) -> Self {
        let channel = |r: f32, g: f32| {
            let r = r.clamp(0.0, 0.99);
            let g = g.clamp(0.0, 1.0);
            let s = r.sqrt();
            let n = g * (1.0 - r) / (1.0 + r) + (1.0 - g) * (1.0 + s) / (1.0 - s);
            let k2 = (r * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - r);
            Complex32::new(n, k2.max(0.0).sqrt())
        };
        Self([
            channel(f0.x, tint.x),
            channel(f0.y, tint.y),
            channel(f0.z, tint.z),
        ])
    }
}

impl ThinFilm {
    /// The film of the inputs (thickness in micrometres, index absolute),
    /// under a medium of index `n_above`; `None` where it has no effect
    /// (weight or thickness 0, or an index matching the medium above).
    pub(super) fn new(weight: f32, thickness_um: f32, ior: f32, n_above: f32) -> Option<Self> {
        let weight = if weight.is_nan() {
            0.0
        } else {
            weight.clamp(0.0, 1.0)
        };
        let usable = |x: f32| x.is_finite() && x > 0.0;
        if weight == 0.0 || !usable(thickness_um) || !usable(ior) || !usable(n_above) {
            return None;
        }
        let eta = ior / n_above;
        ((eta - 1.0).abs() > 1e-4).then_some(Self {
            weight,
            thickness_nm: thickness_um * 1000.0,
            eta,
        })
    }

    /// The film's reflectance over `below` at microfacet incidence cosine
    /// `cos` (from above), per Rec.709 channel, in [0, 1]: 1 where the film
    /// totally reflects.
    pub(super) fn reflectance(&self, cos: f32, below: Substrate) -> Vec3 {
        let cos1 = cos.clamp(0.0, 1.0);
        let sin2_f = (1.0 - cos1 * cos1) / (self.eta * self.eta);
        if sin2_f >= 1.0 {
            return Vec3::ONE;
        }
        let cos_f = (1.0 - sin2_f).sqrt();
        let opd = 2.0 * self.eta * self.thickness_nm * cos_f;
        let mut total = Vec3::ZERO;
        for polarisation in [Polarisation::S, Polarisation::P] {
            // Above -> film: real amplitude; its sign is the phase (0 or pi),
            // and the film -> above reflection has the opposite sign.
            let r12 = polarisation.amplitude(
                Complex32::new(1.0, 0.0),
                Complex32::new(self.eta, 0.0),
                Complex32::new(cos1, 0.0),
                Complex32::new(cos_f, 0.0),
            );
            let big_r12 = r12.norm_sqr();
            let t121 = 1.0 - big_r12;
            let phi21 = if r12.re >= 0.0 { PI } else { 0.0 };
            let mut r23 = [0.0f32; 3];
            let mut phi = [0.0f32; 3];
            for (c, n3) in below.0.iter().enumerate() {
                let n = *n3 / self.eta;
                let cos3 = (Complex32::new(1.0, 0.0) - sin2_f / (n * n)).sqrt();
                let a = polarisation.amplitude(Complex32::new(1.0, 0.0), n, cos_f.into(), cos3);
                r23[c] = a.norm_sqr().min(1.0);
                phi[c] = phi21 + a.arg();
            }
            let r23 = Vec3::from(r23);
            let r123 = r23 * big_r12;
            let rs = t121 * t121 * r23 / (Vec3::ONE - r123).max(Vec3::splat(1e-6));
            let mut sum = Vec3::splat(big_r12) + rs;
            let mut cm = rs - Vec3::splat(t121);
            let root = Vec3::new(r123.x.sqrt(), r123.y.sqrt(), r123.z.sqrt());
            for m in 1..=3 {
                cm *= root;
                let m = m as f32;
                sum += cm * 2.0 * sensitivity(m * opd, m * Vec3::from(phi));
            }
            total += 0.5 * sum;
        }
        total.clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// `bare`, the Fresnel reflectance without a film at microfacet cosine
/// `cos`, blended towards the film's over `below` by its weight.
pub(super) fn with_film(film: Option<&ThinFilm>, bare: Vec3, cos: f32, below: &Substrate) -> Vec3 {
    match film {
        Some(film) => bare.lerp(film.reflectance(cos, *below), film.weight),
        None => bare,
    }
}

impl ThinFilm {
    /// The film on the outer face of a thick dielectric (relative index
    /// `eta` of the far side over `wo`'s: > 1 from outside, < 1 from
    /// inside) at microfacet cosine `cos` on `wo`'s side, blended with the
    /// filmless reflectance `bare` there by the weight. The film is lossless
    /// and a lossless stack transmits alike both ways (Stokes relations), so
    /// it reflects the same from inside as from outside at the angle Snell's
    /// law pairs with it: from inside the film's reflectance is read at that
    /// outside angle, and is 1 under total internal reflection. The light
    /// transmitted is 1 minus this, per channel.
    pub(super) fn lossless_reflectance(&self, cos: f32, eta: f32, bare: f32) -> Vec3 {
        let (cos_out, eta_out) = if eta >= 1.0 {
            (cos, eta)
        } else {
            let eta_out = 1.0 / eta;
            let cos2 = 1.0 - (1.0 - cos * cos) * eta_out * eta_out;
            if cos2 <= 0.0 {
                return Vec3::ONE;
            }
            (cos2.sqrt(), eta_out)
        };
        let below = Substrate::dielectric(eta_out);
        with_film(Some(self), Vec3::splat(bare), cos_out, &below)
    }

    /// A thin wall of relative index `eta` (> 1) whose face towards the
    /// light carries the film: the incoherent sum of the filmed face's
    /// reflectance r1 (from either side, as [`Self::lossless_reflectance`])
    /// and the bare face's r2 = F, R = r1 + (1 - r1)^2 r2 / (1 - r1 r2)
    /// (the thin sheet's r + t^2 r / (1 - r^2) with r1 for one r), at
    /// cosine `cos`; the wall transmits 1 - R.
    pub(super) fn sheet_reflectance(&self, cos: f32, eta: f32) -> Vec3 {
        let r2 = fresnel::dielectric(cos, eta);
        let r1 = self.lossless_reflectance(cos, eta, r2);
        let t1 = Vec3::ONE - r1;
        let inner = (Vec3::ONE - r1 * r2).max(Vec3::splat(1e-6));
        (r1 + t1 * t1 * r2 / inner).min(Vec3::ONE)
    }
}

/// The two linear polarisations of the Fresnel amplitudes.
#[derive(Clone, Copy)]
enum Polarisation {
    S,
    P,
}

impl Polarisation {
    /// Fresnel amplitude reflection coefficient from index `n1` into `n2`
    /// (complex for absorbing media) at cosines `cos1`, `cos2`.
    fn amplitude(
        self,
        n1: Complex32,
        n2: Complex32,
        cos1: Complex32,
        cos2: Complex32,
    ) -> Complex32 {
        let (a, b) = match self {
            Polarisation::S => (n1 * cos1, n2 * cos2),
            Polarisation::P => (n2 * cos1, n1 * cos2),
        };
        let d = a + b;
        if d.norm_sqr() < 1e-12 {
            return Complex32::new(-1.0, 0.0);
        }
        (a - b) / d
    }
}

/// CIE XYZ to linear Rec.709 (D65 primaries).
const XYZ_TO_REC709: Mat3 = Mat3::from_cols_array(&[
    3.240_454_2,
    -0.969_266,
    0.055_643_4,
    -1.537_138_5,
    1.876_010_8,
    -0.204_025_9,
    -0.498_531_4,
    0.041_556,
    1.057_225_2,
]);

/// The XYZ sensitivity's Fourier transform at optical path difference
/// `opd` nanometres and phase shift `shift` (per channel), from Belcour and
/// Barla's Gaussian fits (supplemental, "Spectral integration"), in linear
/// Rec.709 divided by the Rec.709 value of a flat spectrum (1 at opd 0).
fn sensitivity(opd: f32, shift: Vec3) -> Vec3 {
    let phase = 2.0 * PI * opd * 1e-9;
    let gaussian = |val: f32, pos: f32, var: f32, shift: f32| {
        val * (2.0 * PI * var).sqrt() * (pos * phase + shift).cos() * (-phase * phase * var).exp()
    };
    let xyz = Vec3::new(
        gaussian(5.4856e-13, 1.6810e6, 4.3278e9, shift.x)
            + gaussian(9.7470e-14, 2.2399e6, 4.5282e9, shift.x),
        gaussian(4.4201e-13, 1.7953e6, 9.3046e9, shift.y),
        gaussian(5.2481e-13, 2.2084e6, 6.6121e9, shift.z),
    ) / 1.0685e-7;
    XYZ_TO_REC709 * xyz / (XYZ_TO_REC709 * Vec3::ONE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(thickness_um: f32, ior: f32) -> ThinFilm {
        ThinFilm::new(1.0, thickness_um, ior, 1.0).unwrap()
    }

    #[test]
    fn no_film_where_it_cannot_act() {
        assert!(ThinFilm::new(0.0, 0.5, 1.4, 1.0).is_none());
        assert!(ThinFilm::new(1.0, 0.0, 1.4, 1.0).is_none());
        assert!(ThinFilm::new(1.0, 0.5, 1.4, 1.4).is_none());
        assert!(ThinFilm::new(f32::NAN, 0.5, 1.4, 1.0).is_none());
    }

    /// A film far thicker than the coherence length reflects the
    /// incoherent two-interface sum: the oscillating terms vanish.
    #[test]
    fn a_thick_film_reflects_the_incoherent_sum() {
        for cos in [1.0f32, 0.6, 0.2] {
            let r = film(50.0, 1.33).reflectance(cos, Substrate::dielectric(1.5));
            let r12 = fresnel::dielectric(cos, 1.33);
            let cos_f = (1.0 - (1.0 - cos * cos) / (1.33 * 1.33)).sqrt();
            let r23 = fresnel::dielectric(cos_f, 1.5 / 1.33);
            let incoherent = r12 + (1.0 - r12).powi(2) * r23 / (1.0 - r12 * r23);
            // Unpolarised on both sides here: the polarisations differ by
            // less than this at these angles.
            assert!(
                (r - Vec3::splat(incoherent)).abs().max_element() < 2e-3,
                "{cos}: {r} vs {incoherent}"
            );
        }
    }

    /// A film far thinner than a wavelength is no film: the base's own
    /// Fresnel, white (within the 3-term truncation of the Airy series).
    #[test]
    fn a_vanishing_film_leaves_the_base_fresnel() {
        let r = film(0.001, 1.33).reflectance(1.0, Substrate::dielectric(1.5));
        assert!(
            (r - Vec3::splat(fresnel::f0_from_ior(1.5)))
                .abs()
                .max_element()
                < 4e-3,
            "{r}"
        );
        let gold = Vec3::new(1.0, 0.78, 0.34);
        let r = film(0.001, 1.33).reflectance(1.0, Substrate::metal(gold, Vec3::ONE));
        assert!((r - gold).abs().max_element() < 0.03, "{r}");
    }

    /// A quarter-wave film of index sqrt(n) at 550 nm is an anti-reflection
    /// coating: green reflects far less than the bare 4%, red and blue
    /// more than green (the coating's purple cast).
    #[test]
    fn a_quarter_wave_film_is_an_anti_reflection_coating() {
        let n_f = 1.5f32.sqrt();
        let r = film(0.550 / (4.0 * n_f), n_f).reflectance(1.0, Substrate::dielectric(1.5));
        assert!(r.y < 0.01 && r.x > r.y && r.z > r.y, "{r}");
    }

    #[test]
    fn the_film_conserves_energy_and_stays_finite() {
        for d in [0.1f32, 0.3, 0.5, 1.0] {
            for cos in [1.0f32, 0.5, 0.05, 0.0] {
                for below in [
                    Substrate::dielectric(1.5),
                    Substrate::dielectric(0.8),
                    Substrate::metal(Vec3::new(0.9, 0.6, 0.3), Vec3::splat(0.8)),
                ] {
                    let r = film(d, 1.8).reflectance(cos, below);
                    assert!(
                        r.is_finite() && r.min_element() >= 0.0 && r.max_element() <= 1.0,
                        "{r}"
                    );
                }
            }
        }
    }
}
