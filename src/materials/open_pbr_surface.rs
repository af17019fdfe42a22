//! An OpenPBR Surface record (`model: open_pbr`) with its inputs resolved to
//! [`Param`]s, evaluated at a hit into [`OpenPbrInputs`] and
//! [`ShadingFrames`] (normal maps with MaterialX `normalmap` semantics, the
//! frames turned and bent for `wo` as UsdPreviewSurface's are), from which
//! [`Bsdf::from_open_pbr`] builds the BSDF. Absent inputs take the
//! specification's defaults ([`OpenPbrInputs::default`]).

use glam::Vec3;

use super::open_pbr::{interior_absorption, OpenPbrInputs, ShadingFrames};
use super::param::{Lookups, Param, Value};
use super::preview_surface::{side, tangent_space_normal, wo_frame};
use super::primvars::PrimvarNames;
use super::Bsdf;
use crate::geometry::{MeshSite, SurfacePoint};
use crate::scene::{self, Channel};

/// One [`Param`] per OpenPBR input of [`OpenPbrInputs`] but
/// `geometry_thin_walled` (a plain flag of the record).
macro_rules! open_pbr_params {
    ($($name:ident: $value:ty,)*) => {
        /// Every OpenPBR input as a [`Param`].
        #[derive(Clone, Debug)]
        struct OpenPbrParams {
            $($name: Param<$value>,)*
        }

        impl OpenPbrParams {
            /// The record's inputs; absent ones the specification's defaults.
            fn from_record(record: &scene::OpenPbr, names: &mut PrimvarNames) -> Self {
                let defaults = OpenPbrInputs::default();
                Self {
                    $($name: record.$name.as_ref().map_or(
                        Param::Constant(defaults.$name),
                        |input| Param::from_input(input, names),
                    ),)*
                }
            }

            /// Every input's value at `site`.
            fn eval(&self, lookups: &Lookups, site: &MeshSite, thin_walled: bool) -> OpenPbrInputs {
                OpenPbrInputs {
                    $($name: self.$name.eval(lookups, site),)*
                    geometry_thin_walled: thin_walled,
                }
            }
        }
    };
}

open_pbr_params! {
    base_weight: f32,
    base_color: Vec3,
    base_diffuse_roughness: f32,
    base_metalness: f32,
    specular_weight: f32,
    specular_color: Vec3,
    specular_roughness: f32,
    specular_roughness_anisotropy: f32,
    specular_ior: f32,
    transmission_weight: f32,
    transmission_color: Vec3,
    transmission_depth: f32,
    subsurface_weight: f32,
    subsurface_color: Vec3,
    fuzz_weight: f32,
    fuzz_color: Vec3,
    fuzz_roughness: f32,
    coat_weight: f32,
    coat_color: Vec3,
    coat_roughness: f32,
    coat_roughness_anisotropy: f32,
    coat_ior: f32,
    coat_darkening: f32,
    thin_film_weight: f32,
    thin_film_thickness: f32,
    thin_film_ior: f32,
    emission_luminance: f32,
    emission_color: Vec3,
    geometry_opacity: f32,
}

/// One OpenPBR Surface material.
#[derive(Clone, Debug)]
pub(crate) struct OpenPbrSurface {
    params: OpenPbrParams,
    thin_walled: bool,
    /// `geometry_normal`; `None` = the interpolated shading normal.
    normal: Option<NormalMap>,
    /// `geometry_coat_normal`; `None` = the interpolated shading normal.
    coat_normal: Option<NormalMap>,
}

/// A MaterialX `normalmap` node fed by a texture.
#[derive(Clone, Copy, Debug)]
struct NormalMap {
    texture: u32,
    channel: Channel,
    /// Bumpiness: scales the tangent-space x and y.
    scale: f32,
}

impl NormalMap {
    /// The unit world normal at `sp` (MaterialX `normalmap`, tangent space):
    /// normalize((2 v - 1) * (scale, scale, 1)), x along `dpdu`, z along `ns`.
    fn normal(&self, lookups: &Lookups, sp: &SurfacePoint) -> Vec3 {
        let texel = lookups.textures[self.texture as usize].eval(sp.uv);
        let v = 2.0 * Vec3::pick(texel, self.channel) - Vec3::ONE;
        tangent_space_normal(sp, v * Vec3::new(self.scale, self.scale, 1.0))
    }
}

impl OpenPbrSurface {
    /// The BSDF at `sp` for the outgoing direction `wo`.
    pub(crate) fn bsdf(&self, lookups: &Lookups, sp: &SurfacePoint, wo: Vec3) -> Bsdf {
        let inputs = self.params.eval(lookups, &sp.site(), self.thin_walled);
        let side = side(sp, wo);
        let frame = |map: &Option<NormalMap>| {
            let n = map.map_or(sp.ns, |map| map.normal(lookups, sp));
            wo_frame(sp, n, side, wo)
        };
        let frames = ShadingFrames {
            base: frame(&self.normal),
            coat: frame(&self.coat_normal),
            ng: sp.ng * side,
            front: side > 0.0,
        };
        Bsdf::from_open_pbr(&inputs, &frames, wo)
    }

    /// Emitted radiance at `site`, W/(m^2 sr): `emission_luminance` (nits)
    /// times `emission_color`, never negative.
    pub(crate) fn emission(&self, lookups: &Lookups, site: &MeshSite) -> Vec3 {
        let p = &self.params;
        (p.emission_luminance.eval(lookups, site) * p.emission_color.eval(lookups, site))
            .max(Vec3::ZERO)
    }

    /// The interior's absorption coefficient at `site` (per scene unit;
    /// `None` where it is clear or the wall thin), from `transmission_color`
    /// and `transmission_depth` there.
    pub(crate) fn interior_absorption(&self, lookups: &Lookups, site: &MeshSite) -> Option<Vec3> {
        if self.thin_walled {
            return None;
        }
        let p = &self.params;
        let depth = p.transmission_depth.eval(lookups, site);
        interior_absorption(p.transmission_color.eval(lookups, site), depth)
    }

    /// Whether it can emit: neither `emission_luminance` nor
    /// `emission_color` is a constant zero.
    pub(crate) fn is_emissive(&self) -> bool {
        let p = &self.params;
        p.emission_luminance.constant().is_none_or(|l| l > 0.0)
            && p.emission_color
                .constant()
                .is_none_or(|c| c.max_element() > 0.0)
    }

    /// The record's OpenPBR inputs (texture indices were validated by the
    /// scene loader), primvar names given ids in `names`.
    pub(crate) fn from_record(record: &scene::Material, names: &mut PrimvarNames) -> Self {
        let map = |m: &Option<scene::NormalMap>| {
            m.as_ref().map(|m| NormalMap {
                texture: m.texture,
                channel: m.channel,
                scale: m.scale,
            })
        };
        Self {
            params: OpenPbrParams::from_record(&record.open_pbr, names),
            thin_walled: record.geometry_thin_walled,
            normal: map(&record.geometry_normal),
            coat_normal: map(&record.geometry_coat_normal),
        }
    }
}
