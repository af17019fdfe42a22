//! The BSDF at one shading point: eval and pdf over its lobes, in the
//! shading frame, and the probability of sampling each lobe for the `wo` it
//! was built for. Two models share this interface, as a closed enum: the
//! layered UsdPreviewSurface (its lobes in lobes.rs) and OpenPBR Surface
//! (open_pbr/). Drawing a direction is in bsdf_sample.rs.
//!
//! Light leaks: a reflected `wi` must lie on `wo`'s side of the geometric
//! normal and above the shading normal; a transmitted `wi` must cross both.

use glam::Vec3;

use super::fresnel;
use super::lobes::{Layers, LobeValues, ALL_LOBES, LOBES};
use super::open_pbr::{OpenPbr, OpenPbrInputs, ShadingFrames};
use super::preview_surface::Shading;
use super::scatter::{normalized, Side};
use crate::geometry::Frame;

/// The BSDF at one surface point: a material model's lobes with their
/// inputs evaluated, in the (possibly normal-mapped) shading frame.
#[derive(Clone, Debug)]
pub struct Bsdf {
    /// Shading frame with its normal on `wo`'s side of the surface.
    pub(super) frame: Frame,
    /// Unit geometric normal on `wo`'s side.
    pub(super) ng: Vec3,
    pub(super) model: Model,
}

/// The material model behind a [`Bsdf`].
#[derive(Clone, Debug)]
pub(super) enum Model {
    /// UsdPreviewSurface's layers (lobes.rs).
    Preview(Preview),
    /// OpenPBR Surface 1.1 (open_pbr/), boxed: it is several times the
    /// size of the preview model, which would otherwise pay for copying it.
    OpenPbr(Box<OpenPbr>),
}

/// UsdPreviewSurface's layers with their lobes' selection probabilities.
#[derive(Clone, Debug)]
pub(super) struct Preview {
    pub(super) layers: Layers,
    /// Probability of sampling each [`Lobe`](super::lobes::Lobe) for the `wo`
    /// the BSDF was built for: proportional to the lobe's estimated albedo.
    pub(super) lobe_pdf: [f32; LOBES],
}

impl Bsdf {
    /// f(wo, wi) |cos theta_i| (cosine included, per steradian of `wi`), RGB:
    /// the sum of [`Bsdf::eval_split`]'s categories.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_split(wo, wi).total()
    }

    /// [`Bsdf::eval`] split by lobe category for the compositing AOVs
    /// (diffuse, specular, transmission light passes). A sampled direction's
    /// weight splits the same way: `eval_split(wo, wi)` scaled by `1 / pdf`.
    pub fn eval_split(&self, wo: Vec3, wi: Vec3) -> LobeValues {
        let (wo_l, wi_l) = (self.frame.to_local(wo), self.frame.to_local(wi));
        if wo_l.z <= 0.0 {
            return LobeValues::default();
        }
        let Some(side) = self.side(wi, wi_l) else {
            return LobeValues::default();
        };
        match &self.model {
            Model::Preview(p) => p.eval_split(wo_l, wi_l, side),
            Model::OpenPbr(o) => o.eval_split(wo, wi, wo_l, wi_l, side),
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] draws `wi` (its
    /// non-Dirac part: the mixture of the lobes' densities).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo_l, wi_l) = (self.frame.to_local(wo), self.frame.to_local(wi));
        if wo_l.z <= 0.0 {
            return 0.0;
        }
        let Some(side) = self.side(wi, wi_l) else {
            return 0.0;
        };
        match &self.model {
            Model::Preview(p) => p.pdf(wo_l, wi_l, side),
            Model::OpenPbr(o) => o.pdf(wo, wi, wo_l, wi_l, side),
        }
    }

    /// Reflectance for the albedo AOV: for UsdPreviewSurface diffuseColor
    /// blended towards F0 by metallic where the surface is opaque, white
    /// where it transmits; for OpenPBR see [`OpenPbr::albedo`].
    pub fn albedo(&self) -> Vec3 {
        match &self.model {
            Model::Preview(p) => p.layers.albedo,
            Model::OpenPbr(o) => o.albedo(),
        }
    }

    /// True when every lobe with weight is a Dirac lobe (a surface that
    /// passes everything straight through), which light sampling can never
    /// hit: a UsdPreviewSurface thin sheet with opacity 0 and ior 1, or an
    /// OpenPBR surface with geometry_opacity 0 (or a thin wall that only
    /// passes light straight through).
    pub fn is_delta(&self) -> bool {
        match &self.model {
            Model::Preview(p) => {
                let l = &p.layers;
                l.opacity <= 0.0 && l.thin && l.eta == 1.0
            }
            Model::OpenPbr(o) => o.is_delta(),
        }
    }

    /// Where `wi` leaves relative to `wo`; `None` when it is above one of
    /// the geometric and shading surfaces and below the other.
    fn side(&self, wi: Vec3, wi_l: Vec3) -> Option<Side> {
        let g = wi.dot(self.ng);
        if g > 0.0 && wi_l.z > 0.0 {
            Some(Side::Reflect)
        } else if g < 0.0 && wi_l.z < 0.0 {
            Some(Side::Transmit)
        } else {
            None
        }
    }
}

impl Preview {
    fn eval_split(&self, wo_l: Vec3, wi_l: Vec3, side: Side) -> LobeValues {
        let t = 1.0 - self.layers.opacity;
        if side == Side::Reflect {
            let mut values = self.layers.opaque_reflection(wo_l, wi_l);
            values.specular += t * self.layers.dielectric_reflection(wo_l, wi_l);
            values
        } else if !self.layers.thin && t > 0.0 {
            LobeValues {
                transmission: Vec3::splat(t * self.layers.refraction(wo_l, wi_l)),
                ..LobeValues::default()
            }
        } else {
            LobeValues::default()
        }
    }

    fn pdf(&self, wo_l: Vec3, wi_l: Vec3, side: Side) -> f32 {
        let reflect = side == Side::Reflect;
        ALL_LOBES
            .iter()
            .zip(self.lobe_pdf)
            .filter(|(_, p)| *p > 0.0)
            .map(|(lobe, p)| p * self.layers.lobe_density(*lobe, wo_l, wi_l, reflect))
            .sum()
    }
}

impl Bsdf {
    /// The BSDF of a surface's `shading` (shading frame and geometric normal
    /// both on `wo`'s side), with lobe probabilities proportional to each
    /// layer's albedo estimated from its Fresnel at `wo`.
    pub(crate) fn new(shading: Shading, wo: Vec3) -> Self {
        let Shading { frame, ng, layers } = shading;
        let cos_o = frame.to_local(wo).z.clamp(0.0, 1.0);
        let l = &layers;
        let mean = |v: Vec3| (v.x + v.y + v.z) / 3.0;
        let cc = l.clearcoat_fresnel(cos_o);
        let spec = fresnel::schlick(l.specular_f0, l.specular_f90, cos_o);
        let lobe_pdf = normalized([
            l.opacity * (1.0 - cc) * mean((Vec3::ONE - spec) * l.diffuse),
            l.opacity * (1.0 - cc) * mean(spec),
            l.opacity * cc,
            1.0 - l.opacity,
        ]);
        Self {
            frame,
            ng,
            model: Model::Preview(Preview { layers, lobe_pdf }),
        }
    }
}

impl Bsdf {
    /// The BSDF of an OpenPBR surface with `inputs` in `frames` (base and
    /// coat frames, geometric normal, all on `wo`'s side), for the outgoing
    /// direction `wo` (world, unit).
    pub(crate) fn from_open_pbr(inputs: &OpenPbrInputs, frames: &ShadingFrames, wo: Vec3) -> Bsdf {
        Bsdf {
            frame: frames.base,
            ng: frames.ng,
            model: Model::OpenPbr(Box::new(OpenPbr::new(inputs, frames, wo))),
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use std::f32::consts::FRAC_1_PI;

    use glam::Vec2;

    use super::*;
    use crate::geometry::SurfacePoint;
    use crate::materials::preview_surface::tests::constant_texture;
    use crate::materials::preview_surface::{Param, PreviewSurface};
    use crate::materials::test_support::{
        configurations, directions, point, random_surface, surface, white_lambert,
    };
    use crate::materials::texture::Texture;
    use crate::sampling::{warp, Pcg32};

    /// Builds the BSDF of a [`PreviewSurface`] directly, as
    /// [`Materials::bsdf`](crate::materials::Materials::bsdf) does for a
    /// material index.
    pub(in crate::materials) trait SurfaceBsdf {
        /// The BSDF at `sp` for the outgoing direction `wo`.
        fn bsdf(&self, textures: &[Texture], sp: &SurfacePoint, wo: Vec3) -> Bsdf;
    }

    impl SurfaceBsdf for PreviewSurface {
        fn bsdf(&self, textures: &[Texture], sp: &SurfacePoint, wo: Vec3) -> Bsdf {
            Bsdf::new(self.shading(textures, sp, wo), wo)
        }
    }

    /// [`point`] (one-sided) at texture coordinates (0.5, 0.5).
    fn textured_point() -> SurfacePoint {
        SurfacePoint {
            uv: Vec2::new(0.5, 0.5),
            ..point(false)
        }
    }

    #[test]
    fn reflection_is_reciprocal() {
        let mut rng = Pcg32::new(5, 0);
        for (name, s, double_sided) in configurations() {
            let wo = directions(&[0.6])[0];
            let bsdf = s.bsdf(&[], &point(double_sided), wo);
            for _ in 0..1000 {
                let mut a =
                    warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let mut b =
                    warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                a.z = a.z.abs().max(1e-3);
                b.z = b.z.abs().max(1e-3);
                let (a, b) = (a.normalize(), b.normalize());
                let ab = bsdf.eval(a, b) / b.z;
                let ba = bsdf.eval(b, a) / a.z;
                assert!(
                    (ab - ba).abs().max_element() <= 1e-3 * ab.max_element().max(1e-3),
                    "{name}: {ab} vs {ba}"
                );
            }
        }
    }

    #[test]
    fn eval_split_sums_to_eval_over_random_materials_and_directions() {
        let mut rng = Pcg32::new(10, 0);
        let (mut diffuse, mut specular, mut transmission) = (0, 0, 0);
        for _ in 0..200 {
            let (s, double_sided) = random_surface(&mut rng);
            let wo = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let bsdf = s.bsdf(&[], &point(double_sided), wo);
            for _ in 0..50 {
                let wi = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let split = bsdf.eval_split(wo, wi);
                let f = bsdf.eval(wo, wi);
                let sum = split.diffuse + split.specular + split.transmission;
                assert!(
                    (sum - f).abs().max_element() <= 1e-6 * f.abs().max_element(),
                    "{split:?} vs {f}"
                );
                for v in [split.diffuse, split.specular, split.transmission] {
                    assert!(v.is_finite() && v.min_element() >= 0.0, "{split:?}");
                }
                if wi.z * wo.z > 0.0 {
                    assert_eq!(split.transmission, Vec3::ZERO);
                } else {
                    assert_eq!(split.diffuse + split.specular, Vec3::ZERO);
                }
                diffuse += usize::from(split.diffuse.max_element() > 0.0);
                specular += usize::from(split.specular.max_element() > 0.0);
                transmission += usize::from(split.transmission.max_element() > 0.0);
            }
        }
        // Every category is exercised.
        assert!(
            diffuse > 100 && specular > 100 && transmission > 100,
            "{diffuse} {specular} {transmission}"
        );
    }

    #[test]
    fn lambert_is_all_diffuse_and_metal_has_no_diffuse() {
        let mut rng = Pcg32::new(11, 0);
        let metal = surface(|s| {
            s.diffuse_color = Param::Constant(Vec3::new(0.9, 0.6, 0.2));
            s.metallic = Param::Constant(1.0);
            s.roughness = Param::Constant(0.4);
            s.clearcoat = 0.5;
        });
        for wo in directions(&[0.9, 0.4, 0.1]) {
            let lambert = white_lambert().bsdf(&[], &point(false), wo);
            let metal = metal.bsdf(&[], &point(false), wo);
            for _ in 0..200 {
                let wi =
                    warp::square_to_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let l = lambert.eval_split(wo, wi);
                assert!(l.diffuse.min_element() > 0.0, "{l:?}");
                assert_eq!((l.specular, l.transmission), (Vec3::ZERO, Vec3::ZERO));
                assert!((l.diffuse - Vec3::splat(wi.z * FRAC_1_PI)).length() < 1e-6);
                let m = metal.eval_split(wo, wi);
                assert!(m.specular.min_element() > 0.0, "{m:?}");
                assert_eq!((m.diffuse, m.transmission), (Vec3::ZERO, Vec3::ZERO));
            }
        }
    }

    /// Without a clearcoat the diffuse category integrates to exactly what
    /// the specular layer lets through (Kelemen and Szirmay-Kalos 2001):
    /// opacity * diffuse * (1 - F(cos_o)), estimated with cosine sampling.
    #[test]
    fn diffuse_category_reflects_what_the_specular_layer_lets_through() {
        let mut rng = Pcg32::new(13, 0);
        let n = 4000;
        for _ in 0..20 {
            let (mut s, _) = random_surface(&mut rng);
            s.clearcoat = 0.0;
            let wo = directions(&[0.05 + 0.95 * rng.next_f32()])[0];
            let bsdf = s.bsdf(&[], &point(false), wo);
            let Model::Preview(Preview { layers: l, .. }) = &bsdf.model else {
                unreachable!("a PreviewSurface builds a Preview model")
            };
            let expected = l.opacity
                * l.diffuse
                * (Vec3::ONE - fresnel::schlick(l.specular_f0, l.specular_f90, wo.z));
            let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
            for _ in 0..n {
                let wi =
                    warp::square_to_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let v = bsdf.eval_split(wo, wi).diffuse / warp::cosine_hemisphere_pdf(wi.z);
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f32;
            let sigma = ((sum2 / n as f32 - mean * mean).max(Vec3::ZERO) / n as f32).sqrt();
            assert!(
                (mean - expected).abs().cmple(4.0 * sigma + 1e-5).all(),
                "{mean} +- {sigma} vs {expected}"
            );
        }
    }

    /// Glass from either side: reflection directions carry no transmission
    /// and refraction directions nothing else.
    #[test]
    fn glass_splits_into_specular_reflection_and_transmission() {
        let mut rng = Pcg32::new(12, 0);
        let glass = surface(|s| {
            s.opacity = Param::Constant(0.0);
            s.roughness = Param::Constant(0.5);
        });
        for wo in directions(&[0.7, -0.6]) {
            let bsdf = glass.bsdf(&[], &point(false), wo);
            let (mut reflected, mut refracted) = (0, 0);
            for _ in 0..500 {
                let wi = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let split = bsdf.eval_split(wo, wi);
                assert_eq!(split.diffuse, Vec3::ZERO);
                if wi.z * wo.z > 0.0 {
                    assert_eq!(split.transmission, Vec3::ZERO);
                    reflected += usize::from(split.specular.x > 0.0);
                } else {
                    assert_eq!(split.specular, Vec3::ZERO);
                    refracted += usize::from(split.transmission.x > 0.0);
                }
            }
            // From inside, total internal reflection leaves few refracting
            // directions (44 of the 500 here).
            assert!(reflected > 100 && refracted > 20, "{reflected} {refracted}");
        }
    }

    /// A [0, 1]-encoded normal map texel (0.75, 0.5, 1) is (0.5, 0, 1) in
    /// tangent space: the Lambert lobe peaks along it, tilted towards dpdu.
    #[test]
    fn normal_map_tilts_the_shading_normal_along_dpdu() {
        let textures = [constant_texture([0.75, 0.5, 1.0, 1.0])];
        let surface = PreviewSurface {
            normal: Some(0),
            ..white_lambert()
        };
        let wo = Vec3::Z;
        let bsdf = surface.bsdf(&textures, &textured_point(), wo);
        let n = Vec3::new(0.5, 0.0, 1.0).normalize();
        assert!(
            (bsdf.eval(wo, n) - Vec3::splat(FRAC_1_PI))
                .abs()
                .max_element()
                < 1e-5
        );
        let along_ng = bsdf.eval(wo, Vec3::Z).x;
        assert!((along_ng - n.z * FRAC_1_PI).abs() < 1e-5, "{along_ng}");
        // Scale and bias that already map to [-1, 1] are trusted as they are.
        let signed = [constant_texture([0.5, 0.0, 1.0, 1.0])];
        let bsdf = surface.bsdf(&signed, &textured_point(), wo);
        assert!(
            (bsdf.eval(wo, n) - Vec3::splat(FRAC_1_PI))
                .abs()
                .max_element()
                > 1e-3
        );
    }

    /// Metallic workflow: F0 blends from the ior's reflectance to
    /// diffuseColor, and the albedo AOV from diffuseColor to F0.
    #[test]
    fn metallic_workflow_blends_f0_and_albedo() {
        let red = Vec3::new(0.9, 0.1, 0.1);
        for metallic in [0.0f32, 0.5, 1.0] {
            let surface = PreviewSurface {
                diffuse_color: Param::Constant(red),
                metallic: Param::Constant(metallic),
                ..PreviewSurface::default_surface()
            };
            let bsdf = surface.bsdf(&[], &textured_point(), Vec3::Z);
            let f0 = Vec3::splat(0.04).lerp(red, metallic);
            let albedo = red.lerp(f0, metallic);
            assert!(
                (bsdf.albedo() - albedo).abs().max_element() < 1e-6,
                "{metallic}"
            );
            // Normal incidence and exit: the specular term is F0 times a grey
            // factor, the diffuse term (1 - metallic) red (1 - F0)^2 /
            // (1 - F_avg) / pi, with F90 = lerp(white, red, metallic).
            let f = bsdf.eval(Vec3::Z, Vec3::Z);
            let f90 = Vec3::ONE.lerp(red, metallic);
            let through = (Vec3::ONE - f0) * (Vec3::ONE - f0)
                / (Vec3::ONE - fresnel::schlick_average(f0, f90));
            let diffuse = red * (1.0 - metallic) * through * FRAC_1_PI;
            let spec = f - diffuse;
            assert!(
                (spec / f0 - Vec3::splat(spec.x / f0.x)).abs().max_element() < 1e-3,
                "{spec}"
            );
        }
    }
}
