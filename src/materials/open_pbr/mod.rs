//! OpenPBR Surface (ASWF OpenPBR specification 1.1): inputs at a hit
//! (inputs.rs) to a [`Bsdf`].
//!
//! Stage 0: the BSDF is UsdPreviewSurface's layered model fed with the
//! OpenPBR inputs it can express (base, metal, specular, coat, presence);
//! the full model replaces this.

mod inputs;

pub(crate) use inputs::{OpenPbrInputs, ShadingFrames};

use glam::Vec3;

use super::fresnel;
use super::lobes::Layers;
use super::microfacet::Ggx;
use super::preview_surface::Shading;
use super::Bsdf;

impl Bsdf {
    /// The BSDF of an OpenPBR surface with `inputs` in `frames`, for the
    /// outgoing direction `wo`.
    pub(crate) fn from_open_pbr(inputs: &OpenPbrInputs, frames: &ShadingFrames, wo: Vec3) -> Bsdf {
        let i = inputs;
        let metal = i.base_metalness.clamp(0.0, 1.0);
        let base = (i.base_weight * i.base_color).max(Vec3::ZERO);
        let dielectric = Vec3::splat(fresnel::f0_from_ior(i.specular_ior) * i.specular_weight)
            * i.specular_color;
        let f0 = dielectric.lerp(base.min(Vec3::ONE), metal);
        let layers = Layers {
            diffuse: base * (1.0 - metal) * (1.0 - i.transmission_weight.clamp(0.0, 1.0)),
            specular_f0: f0,
            specular_f90: Vec3::splat(i.specular_weight.min(1.0)).lerp(Vec3::ONE, metal),
            specular: Ggx::from_roughness(i.specular_roughness),
            clearcoat: i.coat_weight.clamp(0.0, 1.0),
            clearcoat_f0: fresnel::f0_from_ior(i.coat_ior),
            clearcoat_ggx: Ggx::from_roughness(i.coat_roughness),
            opacity: i.geometry_opacity.clamp(0.0, 1.0),
            eta: 1.0,
            thin: true,
            albedo: base.lerp(f0, metal),
        };
        Bsdf::new(
            Shading {
                frame: frames.base,
                ng: frames.ng,
                layers,
            },
            wo,
        )
    }
}
