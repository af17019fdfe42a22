//! Blackbody colour: Planck's law through the CIE 1931 observer into linear
//! Rec.709, used by UsdLux's `colorTemperature` (lights) and by temperature
//! fields of volumes (fire).

use glam::{DVec3, Vec3};

use super::luminance;

/// Linear Rec.709 colour of a blackbody at `temperature_k`, scaled to
/// luminance 1 as UsdLux's `enableColorTemperature` asks (see
/// [`blackbody_radiance`] for the unscaled colour).
pub fn blackbody_rgb(temperature_k: f32) -> Vec3 {
    let rgb = blackbody_radiance(temperature_k);
    rgb / luminance(rgb)
}

/// Linear Rec.709 radiance of a blackbody at `temperature_k`, up to one
/// constant factor common to all temperatures (so ratios between
/// temperatures are Planck's): Planck's law integrated against the CIE 1931
/// 2-degree observer (the multi-lobe fit of Wyman, Sloan and Shirley 2013,
/// "Simple Analytic Approximations to the CIE XYZ Color Matching Functions")
/// over 360-830 nm, then XYZ to Rec.709 (D65). Out-of-gamut (negative)
/// components are clipped. Zero at 0 K and below.
pub fn blackbody_radiance(temperature_k: f32) -> Vec3 {
    // Second radiation constant hc/k, in nm K.
    const C2: f64 = 1.438_776_9e7;
    if temperature_k.is_nan() || temperature_k <= 0.0 {
        return Vec3::ZERO;
    }
    let t = f64::from(temperature_k);
    let mut xyz = DVec3::ZERO;
    for nm in 360..=830 {
        let l = f64::from(nm);
        // Planck's spectral radiance up to a constant factor (scaled by 1e15
        // so the sums stay far from f32's smallest normals when narrowed).
        let planck = 1e15 / (l.powi(5) * ((C2 / (l * t)).exp_m1()));
        xyz += planck * cie_xyz(l);
    }
    DVec3::new(
        3.240_454_2 * xyz.x - 1.537_138_5 * xyz.y - 0.498_531_4 * xyz.z,
        -0.969_266_0 * xyz.x + 1.876_010_8 * xyz.y + 0.041_556_0 * xyz.z,
        0.055_643_4 * xyz.x - 0.204_025_9 * xyz.y + 1.057_225_2 * xyz.z,
    )
    .max(DVec3::ZERO)
    .as_vec3()
}

/// CIE 1931 colour matching functions at `nm` (Wyman et al. 2013, multi-lobe fit).
fn cie_xyz(nm: f64) -> DVec3 {
    let g = |mu: f64, s_lo: f64, s_hi: f64| {
        let s = if nm < mu { s_lo } else { s_hi };
        (-0.5 * ((nm - mu) / s).powi(2)).exp()
    };
    DVec3::new(
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blackbody_has_unit_luminance_and_the_expected_tint() {
        for t in [1500.0, 3000.0, 6504.0, 10000.0] {
            assert!((luminance(blackbody_rgb(t)) - 1.0).abs() < 1e-5);
        }
        // Near D65 the blackbody is close to white (D65 lies just off the locus).
        let white = blackbody_rgb(6504.0);
        assert!((white - Vec3::ONE).abs().max_element() < 0.1, "{white}");
        // Candle light is red over blue, blue sky light blue over red.
        let warm = blackbody_rgb(2000.0);
        assert!(warm.x > 1.3 && warm.z < 0.2, "{warm}");
        let cool = blackbody_rgb(12000.0);
        assert!(cool.z > cool.x, "{cool}");
    }
}
