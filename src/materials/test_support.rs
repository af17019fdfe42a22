//! Shared pieces of the materials' unit tests: surface points,
//! UsdPreviewSurface configurations that exercise every lobe, and directions.

use glam::{Vec2, Vec3};

use super::param::Param;
use super::preview_surface::PreviewSurface;
use crate::geometry::SurfacePoint;
use crate::sampling::Pcg32;

/// A surface point at the origin with geometric and shading normal +z.
pub(crate) fn point(double_sided: bool) -> SurfacePoint {
    SurfacePoint {
        p: Vec3::ZERO,
        offset: 0.0,
        ng: Vec3::Z,
        ns: Vec3::Z,
        dpdu: Vec3::X,
        uv: Vec2::ZERO,
        barycentrics: Vec2::ZERO,
        material: 0,
        double_sided,
        instance: 0,
        prototype_mesh: 0,
        mesh: 0,
        triangle: 0,
    }
}

/// The default surface ([`PreviewSurface::default_surface`]) with `edit` applied.
pub(crate) fn surface(edit: impl FnOnce(&mut PreviewSurface)) -> PreviewSurface {
    let mut s = PreviewSurface::default_surface();
    edit(&mut s);
    s
}

/// Lambert only: specular workflow with specularColor 0 (F90 fades to 0).
pub(crate) fn white_lambert() -> PreviewSurface {
    surface(|s| {
        s.use_specular_workflow = true;
        s.diffuse_color = Param::Constant(Vec3::ONE);
    })
}

/// A white mirror-like metal (F0 = F90 = 1) of the given roughness.
pub(crate) fn white_metal(roughness: f32) -> PreviewSurface {
    surface(|s| {
        s.diffuse_color = Param::Constant(Vec3::ONE);
        s.metallic = Param::Constant(1.0);
        s.roughness = Param::Constant(roughness);
    })
}

/// Every lobe configuration: (name, surface, double-sided).
pub(crate) fn configurations() -> Vec<(&'static str, PreviewSurface, bool)> {
    vec![
        ("lambert", white_lambert(), false),
        ("default plastic", PreviewSurface::default_surface(), false),
        ("rough metal", white_metal(0.6), false),
        (
            "clearcoat over red plastic",
            surface(|s| {
                s.diffuse_color = Param::Constant(Vec3::new(0.8, 0.1, 0.1));
                s.clearcoat = 1.0;
                s.clearcoat_roughness = 0.3;
            }),
            false,
        ),
        (
            "specular workflow",
            surface(|s| {
                s.use_specular_workflow = true;
                s.specular_color = Param::Constant(Vec3::new(0.3, 0.5, 0.9));
                s.roughness = Param::Constant(0.3);
            }),
            false,
        ),
        (
            "rough glass",
            surface(|s| {
                s.opacity = Param::Constant(0.0);
                s.roughness = Param::Constant(0.4);
            }),
            false,
        ),
        (
            "half-opaque rough glass",
            surface(|s| {
                s.opacity = Param::Constant(0.5);
                s.roughness = Param::Constant(0.7);
                s.ior = 1.33;
            }),
            false,
        ),
        (
            "thin sheet",
            surface(|s| {
                s.opacity = Param::Constant(0.3);
                s.roughness = Param::Constant(0.5);
            }),
            true,
        ),
    ]
}

/// Unit directions with the given cosines to +z, in a few azimuths.
pub(crate) fn directions(cosines: &[f32]) -> Vec<Vec3> {
    cosines
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            let s = (1.0 - c * c).sqrt();
            let phi = 0.7 + i as f32;
            Vec3::new(s * phi.cos(), s * phi.sin(), c)
        })
        .collect()
}

/// A random UsdPreviewSurface: either workflow, optional clearcoat,
/// opacity 1 or random below 1; double-sided (a thin sheet when not
/// opaque) at random.
pub(crate) fn random_surface(rng: &mut Pcg32) -> (PreviewSurface, bool) {
    let mut color = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let (diffuse, specular) = (color(), color());
    let mut u = || rng.next_f32();
    let s = surface(|s| {
        s.diffuse_color = Param::Constant(diffuse);
        s.use_specular_workflow = u() < 0.5;
        s.specular_color = Param::Constant(specular);
        s.metallic = Param::Constant(u());
        s.roughness = Param::Constant(u());
        s.ior = 1.0 + u();
        s.clearcoat = if u() < 0.5 { u() } else { 0.0 };
        s.clearcoat_roughness = u();
        s.opacity = Param::Constant(if u() < 0.3 { 1.0 } else { u() });
    });
    (s, u() < 0.5)
}

/// Chi-square test of a BSDF's sampling against its density (pbrt-v4's
/// bsdfs_test): `sample(u_lobe, u)` draws a direction (and whether it is a
/// Dirac sample, not counted), `pdf(wi)` is the density it claims; 100k
/// samples in 10 x 20 bins in (cos theta, phi) over the sphere, expected
/// counts from the pdf integrated on 16 x 16 points per bin, bins expecting
/// fewer than 5 pooled; the statistic must stay below df + 5 sqrt(2 df).
pub(crate) fn assert_samples_follow_density(
    name: &str,
    sample: impl Fn(f32, Vec2) -> Option<(Vec3, bool)>,
    pdf: impl Fn(Vec3) -> f32,
    rng: &mut Pcg32,
) {
    let (nt, np, sub) = (10usize, 20usize, 16usize);
    let n = 100_000;
    let bin = |w: Vec3| {
        let t = (((w.z + 1.0) * 0.5 * nt as f32) as usize).min(nt - 1);
        let phi = w.y.atan2(w.x).rem_euclid(std::f32::consts::TAU);
        let p = ((phi / std::f32::consts::TAU * np as f32) as usize).min(np - 1);
        t * np + p
    };
    let mut observed = vec![0.0f64; nt * np];
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        if let Some((wi, false)) = sample(rng.next_f32(), u) {
            observed[bin(wi)] += 1.0;
        }
    }
    let mut expected = vec![0.0f64; nt * np];
    for (t, p) in (0..nt).flat_map(|t| (0..np).map(move |p| (t, p))) {
        let mut sum = 0.0f64;
        for (a, b) in (0..sub).flat_map(|a| (0..sub).map(move |b| (a, b))) {
            let z = -1.0 + 2.0 * (t as f32 + (a as f32 + 0.5) / sub as f32) / nt as f32;
            let phi =
                std::f32::consts::TAU * (p as f32 + (b as f32 + 0.5) / sub as f32) / np as f32;
            let s = (1.0 - z * z).max(0.0).sqrt();
            sum += f64::from(pdf(Vec3::new(s * phi.cos(), s * phi.sin(), z)));
        }
        // Each bin spans 2/nt in z and 2 pi/np in phi (equal areas).
        let area = 4.0 * std::f64::consts::PI / (nt * np) as f64;
        expected[t * np + p] = sum / (sub * sub) as f64 * area * n as f64;
    }
    let (mut chi2, mut df, mut pooled_o, mut pooled_e) = (0.0f64, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            df += 1;
        }
    }
    if pooled_e >= 5.0 {
        chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        df += 1;
    }
    let df = df.saturating_sub(1).max(1) as f64;
    eprintln!("{name}: chi2 {chi2:.1} for {df} dof");
    assert!(
        chi2 < df + 5.0 * (2.0 * df).sqrt(),
        "{name}: chi2 {chi2} for {df} dof"
    );
}
