//! The inputs of an OpenPBR Surface (ASWF OpenPBR specification 1.1,
//! <https://academysoftwarefoundation.github.io/OpenPBR/>) evaluated at one
//! shading point: what the BSDF is built from. Names and defaults are the
//! specification's; colours are linear Rec.709.

use glam::Vec3;

use crate::geometry::Frame;

/// Every OpenPBR input the BSDF reads, as plain values at one hit
/// (textures, primvars and node maths already evaluated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct OpenPbrInputs {
    pub(crate) base_weight: f32,
    pub(crate) base_color: Vec3,
    pub(crate) base_diffuse_roughness: f32,
    pub(crate) base_metalness: f32,
    pub(crate) specular_weight: f32,
    pub(crate) specular_color: Vec3,
    pub(crate) specular_roughness: f32,
    pub(crate) specular_roughness_anisotropy: f32,
    pub(crate) specular_ior: f32,
    pub(crate) transmission_weight: f32,
    pub(crate) transmission_color: Vec3,
    /// Distance (scene units) at which a thick medium's transmittance
    /// reaches `transmission_color`; 0 = no interior absorption.
    pub(crate) transmission_depth: f32,
    pub(crate) subsurface_weight: f32,
    pub(crate) subsurface_color: Vec3,
    pub(crate) fuzz_weight: f32,
    pub(crate) fuzz_color: Vec3,
    pub(crate) fuzz_roughness: f32,
    pub(crate) coat_weight: f32,
    pub(crate) coat_color: Vec3,
    pub(crate) coat_roughness: f32,
    pub(crate) coat_roughness_anisotropy: f32,
    pub(crate) coat_ior: f32,
    pub(crate) coat_darkening: f32,
    pub(crate) thin_film_weight: f32,
    /// Micrometres.
    pub(crate) thin_film_thickness: f32,
    pub(crate) thin_film_ior: f32,
    /// Nits; emitted radiance is `emission_luminance * emission_color`
    /// with 1 nit = 1 W/(m^2 sr) of scene radiance, as UsdLux intensities.
    pub(crate) emission_luminance: f32,
    pub(crate) emission_color: Vec3,
    /// Presence in [0, 1]: 1 - opacity of the light passes straight through.
    pub(crate) geometry_opacity: f32,
    pub(crate) geometry_thin_walled: bool,
}

impl Default for OpenPbrInputs {
    /// The specification's defaults.
    fn default() -> Self {
        Self {
            base_weight: 1.0,
            base_color: Vec3::splat(0.8),
            base_diffuse_roughness: 0.0,
            base_metalness: 0.0,
            specular_weight: 1.0,
            specular_color: Vec3::ONE,
            specular_roughness: 0.3,
            specular_roughness_anisotropy: 0.0,
            specular_ior: 1.5,
            transmission_weight: 0.0,
            transmission_color: Vec3::ONE,
            transmission_depth: 0.0,
            subsurface_weight: 0.0,
            subsurface_color: Vec3::splat(0.8),
            fuzz_weight: 0.0,
            fuzz_color: Vec3::ONE,
            fuzz_roughness: 0.5,
            coat_weight: 0.0,
            coat_color: Vec3::ONE,
            coat_roughness: 0.0,
            coat_roughness_anisotropy: 0.0,
            coat_ior: 1.6,
            coat_darkening: 1.0,
            thin_film_weight: 0.0,
            thin_film_thickness: 0.5,
            thin_film_ior: 1.4,
            emission_luminance: 0.0,
            emission_color: Vec3::ONE,
            geometry_opacity: 1.0,
            geometry_thin_walled: false,
        }
    }
}

/// Where an OpenPBR BSDF is built: the shading frames (normal-mapped,
/// turned to `wo`'s side and bent so `wo` lies above them, as for
/// UsdPreviewSurface) and the side of the surface `wo` is on.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadingFrames {
    /// Frame of the base, specular, fuzz and transmission lobes
    /// (`geometry_normal`, x along `geometry_tangent`).
    pub(crate) base: Frame,
    /// Frame of the coat (`geometry_coat_normal`).
    pub(crate) coat: Frame,
    /// Unit geometric normal on `wo`'s side.
    pub(crate) ng: Vec3,
    /// `wo` is on the front side of the geometric normal (entering a
    /// thick transmissive interior).
    pub(crate) front: bool,
}
