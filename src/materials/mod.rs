//! UsdPreviewSurface materials and their textures
//! (<https://openusd.org/release/spec_usdpreviewsurface.html>).
//!
//! [`Materials::build`] reads every `UsdUVTexture` image once (texture.rs:
//! bilinear, wrap modes, `st` transform, scale and bias) and resolves every
//! material's inputs; [`Materials::bsdf`] evaluates them at a hit
//! (preview_surface.rs) into a layered [`Bsdf`] (bsdf.rs, sampled in
//! bsdf_sample.rs): clearcoat over GGX specular over Lambert, plus a rough
//! dielectric where opacity < 1 (the lobes: lobes.rs). GGX uses Smith
//! height-correlated masking-shadowing (Heitz 2014) and visible-normal
//! sampling through spherical caps (Dupuy and Benyoub 2023); refraction
//! follows Walter et al. 2007; shading normals that face away from `wo` are
//! bent as in Iray (Keller et al. 2017).

mod bsdf;
mod bsdf_sample;
mod fresnel;
mod lobes;
mod microfacet;
mod open_pbr;
mod preview_surface;
mod scatter;
mod texture;

#[cfg(test)]
mod open_pbr_tests;
#[cfg(test)]
mod test_support;

pub use bsdf::Bsdf;
pub use lobes::LobeValues;
pub use scatter::BsdfSample;

use glam::{Vec2, Vec3};
use thiserror::Error;

use crate::geometry::SurfacePoint;
use crate::scene::{Scene, NO_MATERIAL};
use preview_surface::PreviewSurface;
use texture::Texture;

/// Every material and texture of a scene, ready to build BSDFs at hits.
pub struct Materials {
    surfaces: Vec<PreviewSurface>,
    /// What a surface with [`NO_MATERIAL`] looks like.
    unbound: PreviewSurface,
    textures: Vec<Texture>,
}

/// A material that cannot be used.
#[derive(Debug, Error)]
pub enum MaterialError {
    /// `inputs:ior` is not a positive finite number, so no Fresnel or
    /// refraction can be computed.
    #[error("material {material}: ior {ior} is not a positive number")]
    InvalidIor {
        /// Prim path of the Material.
        material: String,
        /// The value read.
        ior: f32,
    },
}

impl Materials {
    /// Reads every texture file once and resolves every material's inputs.
    /// A missing or unreadable texture file is not an error: its lookups
    /// return the texture's `fallback` and one warning names the file.
    pub fn build(scene: &Scene) -> Result<Self, MaterialError> {
        let m = &scene.manifest;
        if let Some(bad) = m
            .materials
            .iter()
            .find(|r| !(r.ior.is_finite() && r.ior > 0.0))
        {
            return Err(MaterialError::InvalidIor {
                material: bad.path.clone(),
                ior: bad.ior,
            });
        }
        Ok(Self {
            surfaces: m
                .materials
                .iter()
                .map(PreviewSurface::from_record)
                .collect(),
            unbound: PreviewSurface::default_surface(),
            textures: Texture::load_all(&m.textures),
        })
    }

    /// The BSDF of `sp`'s material at `sp`, for the outgoing direction `wo`
    /// (unit, world, away from the surface). `wo` fixes the side of the
    /// surface, the shading normal's correction and the lobe probabilities,
    /// so the returned BSDF is for this `wo` only.
    pub fn bsdf(&self, sp: &SurfacePoint, wo: Vec3) -> Bsdf {
        Bsdf::new(
            self.surface(sp.material).shading(&self.textures, sp, wo),
            wo,
        )
    }

    /// `emissiveColor` of `material` at texture coordinates `uv`: radiance in
    /// W/(m^2 sr), linear Rec.709, leaving the front side (the caller decides
    /// sidedness). Black for [`NO_MATERIAL`].
    pub fn emission(&self, material: u32, uv: Vec2) -> Vec3 {
        self.surface(material)
            .emissive_color
            .eval(&self.textures, uv)
            .max(Vec3::ZERO)
    }

    /// Whether `material` can emit: its `emissiveColor` is textured or a
    /// non-black constant.
    pub fn is_emissive(&self, material: u32) -> bool {
        self.surface(material).is_emissive()
    }

    /// The surface for a material index ([`NO_MATERIAL`] = the defaults).
    fn surface(&self, material: u32) -> &PreviewSurface {
        if material == NO_MATERIAL {
            &self.unbound
        } else {
            &self.surfaces[material as usize]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::preview_surface::Param;
    use super::*;

    #[test]
    fn unbound_surfaces_are_grey_and_dark_and_emitters_emit() {
        let lamp = PreviewSurface {
            emissive_color: Param::Constant(Vec3::new(1.0, 2.0, 3.0)),
            ..PreviewSurface::default_surface()
        };
        let materials = Materials {
            surfaces: vec![PreviewSurface::default_surface(), lamp],
            unbound: PreviewSurface::default_surface(),
            textures: Vec::new(),
        };
        assert!(!materials.is_emissive(NO_MATERIAL) && !materials.is_emissive(0));
        assert_eq!(materials.emission(NO_MATERIAL, Vec2::ZERO), Vec3::ZERO);
        assert!(materials.is_emissive(1));
        assert_eq!(
            materials.emission(1, Vec2::new(0.3, 0.4)),
            Vec3::new(1.0, 2.0, 3.0)
        );
    }
}
