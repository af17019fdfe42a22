//! A `UsdPreviewSurface` record with its inputs resolved to [`Param`]s,
//! evaluated at a hit into the [`Shading`] a [`Bsdf`](super::Bsdf) is built
//! from: workflow (metallic or specular), normal map, and the shading
//! normal's correction (shared with OpenPBR: [`wo_frame`]).

use glam::Vec3;

use super::fresnel;
use super::lobes::Layers;
use super::microfacet::Ggx;
use super::param::Lookups;
pub(crate) use super::param::Param;
use super::primvars::PrimvarNames;
use crate::geometry::{Frame, MeshSite, SurfacePoint};
use crate::scene;

/// How far above the geometric surface (as a cosine) the mirror direction of
/// `wo` about a corrected shading normal is lifted (see [`bend_normal`]).
const MIN_REFLECTION_COS: f32 = 0.01;

/// Below this |ior - 1| the dielectric is index-matched: eta is taken as
/// exactly 1, so it neither reflects nor bends light, and transmission is the
/// thin sheet's straight pass-through (UsdPreviewSurface's common "opacity
/// as presence" use, ior 1).
const INDEX_MATCHED: f32 = 1e-3;

/// One `UsdPreviewSurface`: every input the BSDF and emission read.
#[derive(Clone, Debug)]
pub(crate) struct PreviewSurface {
    pub(crate) diffuse_color: Param<Vec3>,
    pub(crate) emissive_color: Param<Vec3>,
    pub(crate) metallic: Param<f32>,
    pub(crate) roughness: Param<f32>,
    pub(crate) specular_color: Param<Vec3>,
    pub(crate) use_specular_workflow: bool,
    pub(crate) ior: f32,
    pub(crate) opacity: Param<f32>,
    /// `opacityThreshold` in [0, 1]; above 0 opacity is a cut-out mask.
    pub(crate) opacity_threshold: f32,
    pub(crate) clearcoat: f32,
    pub(crate) clearcoat_roughness: f32,
    /// Tangent-space normal map: texture index.
    pub(crate) normal: Option<u32>,
}

/// A surface evaluated at one hit for one outgoing direction `wo`: what a
/// [`Bsdf`](super::Bsdf) is built from.
#[derive(Clone, Debug)]
pub(crate) struct Shading {
    /// Shading frame: the (normal-mapped) shading normal turned to `wo`'s
    /// side of the surface and bent so that `wo` lies above it.
    pub(crate) frame: Frame,
    /// Unit geometric normal on `wo`'s side.
    pub(crate) ng: Vec3,
    /// The layers' weights and parameters at the hit.
    pub(crate) layers: Layers,
}

impl PreviewSurface {
    /// The surface at `sp` seen from `wo`: inputs evaluated at `sp.uv`, the
    /// normal map applied, the shading frame turned to `wo`'s side of the
    /// surface and bent so that `wo` lies above it.
    ///
    /// Workflows (UsdPreviewSurface specification): metallic: F0 =
    /// lerp(((ior - 1) / (ior + 1))^2, diffuseColor, metallic), F90 =
    /// lerp(white, diffuseColor, metallic), diffuse = diffuseColor (1 -
    /// metallic); specular: F0 = specularColor, F90 white, diffuse =
    /// diffuseColor. The white part of F90 fades to black as F0 goes to 0
    /// (times min(1, 50 mean(F0)), Lagarde and de Rousiers 2014, "Moving
    /// Frostbite to PBR", §4.4): no real material has F0 below 0.02, and
    /// this keeps specularColor 0 (or ior 1) a pure Lambert surface.
    ///
    /// Transmission (weight 1 - opacity) is a thin sheet on double-sided
    /// meshes (the same from both sides) and a solid interface otherwise,
    /// entered when `wo` is on the front side of `ng` (eta = ior) and left
    /// from the back (eta = 1 / ior).
    pub(crate) fn shading<'a>(
        &self,
        lookups: impl Into<Lookups<'a>>,
        sp: &SurfacePoint,
        wo: Vec3,
    ) -> Shading {
        let lookups = &lookups.into();
        let site = &sp.site();
        let diffuse_color = self.diffuse_color.eval(lookups, site).max(Vec3::ZERO);
        let fade = |f0: Vec3| Vec3::splat((50.0 * (f0.x + f0.y + f0.z) / 3.0).min(1.0));
        // `base`: the albedo AOV's colour, diffuse blended towards F0 by metallic.
        let (diffuse, f0, f90, base) = if self.use_specular_workflow {
            let f0 = self
                .specular_color
                .eval(lookups, site)
                .clamp(Vec3::ZERO, Vec3::ONE);
            (diffuse_color, f0, fade(f0), diffuse_color)
        } else {
            let metallic = self.metallic.eval(lookups, site).clamp(0.0, 1.0);
            let dielectric = Vec3::splat(fresnel::f0_from_ior(self.ior));
            let albedo = diffuse_color.min(Vec3::ONE);
            let f0 = dielectric.lerp(albedo, metallic);
            (
                diffuse_color * (1.0 - metallic),
                f0,
                fade(dielectric).lerp(albedo, metallic),
                diffuse_color.lerp(f0, metallic),
            )
        };
        let opacity = self.opacity(lookups, site);
        let index_matched = (self.ior - 1.0).abs() < INDEX_MATCHED;

        let side = side(sp, wo);
        let ng = sp.ng * side;
        let frame = wo_frame(sp, self.mapped_normal(lookups, sp), side, wo);
        let layers = Layers {
            diffuse,
            specular_f0: f0,
            specular_f90: f90,
            specular: Ggx::from_roughness(self.roughness.eval(lookups, site)),
            clearcoat: self.clearcoat.clamp(0.0, 1.0),
            clearcoat_f0: fresnel::f0_from_ior(self.ior),
            clearcoat_ggx: Ggx::from_roughness(self.clearcoat_roughness),
            opacity,
            // A thin sheet has air on both sides: the same ior from either.
            eta: if index_matched {
                1.0
            } else if side > 0.0 || sp.double_sided {
                self.ior
            } else {
                1.0 / self.ior
            },
            thin: sp.double_sided || index_matched,
            // White where the dielectric transmits, as denoisers expect for glass.
            albedo: base * opacity + Vec3::splat(1.0 - opacity),
        };
        Shading { frame, ng, layers }
    }

    /// `opacity` at `site`, clamped to [0, 1]; under a positive
    /// `opacityThreshold` a mask (UsdPreviewSurface specification,
    /// "opacityThreshold"): 0 below the threshold, 1 at or above it.
    fn opacity(&self, lookups: &Lookups, site: &MeshSite) -> f32 {
        let opacity = self.opacity.eval(lookups, site).clamp(0.0, 1.0);
        if self.opacity_threshold <= 0.0 {
            opacity
        } else if opacity < self.opacity_threshold {
            0.0
        } else {
            1.0
        }
    }

    /// Whether `opacityThreshold` cuts the surface out at `site`: opacity
    /// below a positive threshold, where no ray sees the surface.
    pub(crate) fn is_cut_out(&self, lookups: &Lookups, site: &MeshSite) -> bool {
        self.opacity_threshold > 0.0 && self.opacity(lookups, site) == 0.0
    }

    /// The shading normal on the front side, with the tangent-space normal
    /// map applied (x along `dpdu`, z along `ns`). UsdPreviewSurface expects
    /// the texture's scale and bias to map texels to [-1, 1]; when they are
    /// left at 1 and 0 (a common authoring slip), `2 v - 1` is applied here.
    fn mapped_normal(&self, lookups: &Lookups, sp: &SurfacePoint) -> Vec3 {
        let Some(texture) = self.normal else {
            return sp.ns;
        };
        let texture = &lookups.textures[texture as usize];
        let mut v = texture.eval(sp.uv).truncate();
        if texture.keeps_stored_range() {
            v = 2.0 * v - Vec3::ONE;
        }
        tangent_space_normal(sp, v)
    }

    /// Whether the surface emits: `emissiveColor` varies or is non-black.
    pub(crate) fn is_emissive(&self) -> bool {
        self.emissive_color
            .constant()
            .is_none_or(|c| c.max_element() > 0.0)
    }

    /// UsdPreviewSurface's defaults ([`scene::Material::default`]): the look
    /// of a surface without a bound material.
    pub(crate) fn default_surface() -> Self {
        Self::from_record(&scene::Material::default(), &mut PrimvarNames::default())
    }

    /// The record's inputs (texture indices were validated by the scene
    /// loader), primvar names given ids in `names`.
    pub(crate) fn from_record(record: &scene::Material, names: &mut PrimvarNames) -> Self {
        Self {
            diffuse_color: Param::from_input(&record.diffuse_color, names),
            emissive_color: Param::from_input(&record.emissive_color, names),
            metallic: Param::from_input(&record.metallic, names),
            roughness: Param::from_input(&record.roughness, names),
            specular_color: Param::from_input(&record.specular_color, names),
            use_specular_workflow: record.use_specular_workflow,
            ior: record.ior,
            opacity: Param::from_input(&record.opacity, names),
            opacity_threshold: opacity_threshold(record),
            clearcoat: record.clearcoat,
            clearcoat_roughness: record.clearcoat_roughness,
            normal: record.normal.as_ref().map(|t| t.texture),
        }
    }
}

/// The record's `opacity_threshold` clamped to [0, 1] (NaN reads as 0, no
/// mask), with a warning naming the material when it was outside.
fn opacity_threshold(record: &scene::Material) -> f32 {
    let authored = record.opacity_threshold;
    let threshold = if authored.is_nan() {
        0.0
    } else {
        authored.clamp(0.0, 1.0)
    };
    if threshold != authored {
        log::warn!(
            "material {}: opacityThreshold {authored} is outside [0, 1]; {threshold} used",
            record.path
        );
    }
    threshold
}

/// +1 when `wo` is on the front side of `sp`'s geometric normal, else -1.
pub(crate) fn side(sp: &SurfacePoint, wo: Vec3) -> f32 {
    if sp.ng.dot(wo) >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// The shading frame of the front-side normal `n` at `sp`, seen from `wo`
/// on `side` ([`side`]): the normal turned to `wo`'s side and bent so that
/// `wo` lies above it ([`bend_normal`]), x along `dpdu`.
pub(crate) fn wo_frame(sp: &SurfacePoint, n: Vec3, side: f32, wo: Vec3) -> Frame {
    Frame::from_normal_tangent(bend_normal(n * side, sp.ng * side, wo), sp.dpdu)
}

/// The tangent-space vector `v` (x along `dpdu`, z along the shading
/// normal) as a unit world normal; the shading normal where `v` is zero.
pub(crate) fn tangent_space_normal(sp: &SurfacePoint, v: Vec3) -> Vec3 {
    let tangent_space = Frame::from_normal_tangent(sp.ns, sp.dpdu);
    let n = tangent_space.to_world(v).normalize_or_zero();
    if n == Vec3::ZERO {
        sp.ns
    } else {
        n
    }
}

/// The shading normal `n`, bent towards the geometric normal `ng` (both on
/// `wo`'s side) when the mirror direction of `wo` about it would go below the
/// surface (Keller et al. 2017, "The Iray Light Transport Simulation and
/// Rendering System", §A.3): the mirror direction is lifted to cosine
/// [`MIN_REFLECTION_COS`] above the surface and the normal becomes the half
/// vector of `wo` and it. Then `wo` is always above the shading hemisphere.
fn bend_normal(n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let r = 2.0 * n.dot(wo) * n - wo;
    let cos_r = r.dot(ng);
    if cos_r >= MIN_REFLECTION_COS {
        return n;
    }
    let lifted = (r + (MIN_REFLECTION_COS - cos_r) * ng).normalize_or(ng);
    (wo + lifted).normalize_or(ng)
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::texture::Texture;
    use super::*;
    use crate::scene::Channel;

    /// A texture without an image: every lookup reads its fallback `value`.
    pub(crate) fn constant_texture(value: [f32; 4]) -> Texture {
        Texture::constant(value)
    }

    #[test]
    fn emission_is_constant_or_textured() {
        let lamp = PreviewSurface {
            emissive_color: Param::Texture {
                texture: 0,
                channel: Channel::Rgb,
            },
            ..PreviewSurface::default_surface()
        };
        assert!(lamp.is_emissive());
        assert!(!PreviewSurface::default_surface().is_emissive());
        let glow = PreviewSurface {
            emissive_color: Param::Constant(Vec3::new(0.0, 0.5, 0.0)),
            ..PreviewSurface::default_surface()
        };
        assert!(glow.is_emissive());
    }

    /// Opposite the mirror direction a shading normal tilted 80 degrees
    /// is bent until `wo`'s mirror image sits just above the surface.
    #[test]
    fn bent_normal_keeps_wo_and_its_mirror_above_the_surface() {
        let n = Vec3::new(80f32.to_radians().sin(), 0.0, 80f32.to_radians().cos());
        for wo in [
            Vec3::new(-0.9, 0.0, 0.3).normalize(),
            Vec3::new(0.2, 0.9, 0.1).normalize(),
        ] {
            let bent = bend_normal(n, Vec3::Z, wo);
            assert!((bent.length() - 1.0).abs() < 1e-5);
            assert!(bent.dot(wo) > 0.0 && bent.z > 0.0, "{bent}");
            let mirror = 2.0 * bent.dot(wo) * bent - wo;
            assert!(mirror.z >= MIN_REFLECTION_COS * 0.9, "{mirror}");
        }
        // A normal that does not need it is left alone.
        assert_eq!(
            bend_normal(Vec3::Z, Vec3::Z, Vec3::X * 0.6 + Vec3::Z * 0.8),
            Vec3::Z
        );
    }
}
