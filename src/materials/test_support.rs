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
