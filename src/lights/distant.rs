//! `DistantLight`: light from infinitely far away, arriving from a cone of
//! angular diameter `inputs:angle` around the light's world +Z (it travels
//! along -Z). With `normalize` the emission is the irradiance on a surface
//! facing the light; without, the radiance of the disk (docs/conventions.md,
//! "Lights").

use std::f64::consts::PI;

use glam::{Vec2, Vec3};

use super::emission::emission;
use super::{world_from_light, LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::geometry::Frame;
use crate::sampling::warp::square_to_uniform_cone;
use crate::scene::Light as LightRecord;

/// A distant light: a uniform cone of directions, or a single direction
/// (a Dirac delta) when the cone is too narrow for f32 directions.
#[derive(Clone, Debug)]
pub(crate) struct DistantLight {
    /// Unit world direction towards the light (the cone's axis).
    frame: Frame,
    /// Cosine of the cone's half-angle; 1 for a delta light.
    cos_max: f32,
    /// Solid angle of the cone as sampled, 2 pi (1 - cos_max), steradians.
    solid_angle: f32,
    /// Radiance inside the cone; for a delta light, the irradiance on a
    /// surface facing the light (W/m^2).
    radiance: Vec3,
    /// Irradiance on a surface facing the light, W/m^2.
    irradiance: Vec3,
}

impl DistantLight {
    /// A direction in the cone, uniformly (pdf 1 / solid angle), or the one
    /// direction of a delta light with pdf 1 and `radiance` = irradiance on a
    /// surface facing the light, so that radiance |cos| / pdf is the
    /// irradiance at cosine cos.
    pub fn sample(&self, u: Vec2) -> LightSample {
        if self.is_delta() {
            return LightSample {
                radiance: self.radiance,
                wi: self.frame.n,
                distance: f32::INFINITY,
                pdf: 1.0,
                delta: true,
            };
        }
        let wi = self
            .frame
            .to_world(square_to_uniform_cone(u, self.cos_max))
            .normalize();
        LightSample {
            radiance: self.radiance,
            wi,
            distance: f32::INFINITY,
            pdf: 1.0 / self.solid_angle,
            delta: false,
        }
    }

    /// What a ray escaping along unit `direction` sees: the disk's radiance
    /// and the density [`Self::sample`] gives it, when inside the cone.
    pub fn escaped(&self, direction: Vec3) -> Option<LightHit> {
        (!self.is_delta() && direction.dot(self.frame.n) >= self.cos_max).then(|| LightHit {
            t: f32::INFINITY,
            radiance: self.radiance,
            pdf: 1.0 / self.solid_angle,
        })
    }

    /// True when the light is a single direction.
    pub fn is_delta(&self) -> bool {
        self.solid_angle == 0.0
    }

    /// Luminance of the power reaching a disk of radius `scene_radius`
    /// facing the light (pbrt-v4's `DistantLight::Phi`): E pi r^2.
    pub fn power(&self, scene_radius: f32) -> f32 {
        luminance(self.irradiance) * std::f32::consts::PI * scene_radius * scene_radius
    }

    /// From the record: axis = the light's world +Z. The irradiance on a
    /// surface facing the light is the emission with `normalize`, else the
    /// emission (a radiance) times pi sin^2(angle/2), the cone's projected
    /// solid angle (UsdLux's 2 pi (1 - cos(angle/2)) up to 1 + O(angle^2));
    /// the radiance is set so the f32 cone that is sampled delivers it exactly.
    /// Half-angles below about 0.02 degrees (1 - cos rounds to 0 in f32)
    /// become a delta light carrying the same irradiance.
    pub fn from_record(record: &LightRecord, angle_deg: f32) -> Result<Self, LightError> {
        if !(angle_deg.is_finite() && (0.0..360.0).contains(&angle_deg)) {
            return Err(LightError::invalid(
                record,
                format!("angle {angle_deg} degrees is outside [0, 360)"),
            ));
        }
        let (linear, _) = world_from_light(record)?;
        let axis = (linear * Vec3::Z).normalize_or_zero();
        if axis == Vec3::ZERO {
            return Err(LightError::invalid(
                record,
                "transform collapses the Z axis",
            ));
        }
        let e = emission(record)?;
        let half = f64::from(angle_deg).to_radians() / 2.0;
        // Irradiance on a surface facing the light.
        let irradiance = if record.normalize {
            e
        } else {
            if angle_deg == 0.0 {
                log::warn!(
                    "light {}: distant light of angle 0 without normalize emits nothing \
                     (its emission is the radiance of a disk of zero size)",
                    record.path
                );
            }
            // Radiance e over the cone's part above a facing surface:
            // pi sin^2(h) e, pi e once the cone covers the hemisphere.
            e * (PI * half.min(PI / 2.0).sin().powi(2)) as f32
        };
        // cos h rounded to f32 is the cone that is sampled; 1 - cos h from
        // 2 sin^2(h/2) without cancellation.
        let one_minus_cos = (2.0 * (half / 2.0).sin().powi(2)) as f32;
        let cos_max = 1.0 - one_minus_cos;
        let solid_angle = 2.0 * std::f32::consts::PI * (1.0 - cos_max);
        // Radiance whose cosine-weighted integral over that cone (above a
        // facing surface) is the irradiance: exactly UsdLux's value whatever
        // the rounding.
        let projected = if cos_max <= 0.0 {
            std::f32::consts::PI
        } else {
            std::f32::consts::PI * (1.0 - cos_max) * (1.0 + cos_max)
        };
        let radiance = if solid_angle == 0.0 {
            irradiance
        } else {
            irradiance / projected
        };
        Ok(Self {
            frame: Frame::from_normal(axis),
            cos_max: if solid_angle == 0.0 { 1.0 } else { cos_max },
            solid_angle,
            radiance,
            irradiance,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{assert_within_4_sigma, estimate, record};
    use crate::scene::LightShape;

    fn distant(angle_deg: f32, normalize: bool) -> DistantLight {
        // Rotated so the light comes from +X: +Z of the light maps to +X.
        let mut r = record(LightShape::Distant { angle_deg }, normalize, 2.0);
        r.transform = [0., 0., 1., 0., 0., 1., 0., 0., -1., 0., 0., 0.];
        DistantLight::from_record(&r, angle_deg).unwrap()
    }

    /// Irradiance on a surface whose normal is 30 degrees off the light's
    /// axis: emission x cos with normalize, radiance x cone integral of the
    /// cosine without (exact: pi sin^2(h) cos(30 deg) for a cone inside the hemisphere).
    #[test]
    fn irradiance_matches_usdlux_for_both_normalize_modes() {
        let n = Vec3::new(3f32.sqrt() / 2.0, 0.5, 0.0);
        let cos = n.dot(Vec3::X);
        for angle in [0.0, 0.53, 10.0] {
            let lit = distant(angle, true);
            let e = estimate(5_000, 3, |u| {
                let s = lit.sample(u);
                Some(s.radiance.x * s.wi.dot(n).max(0.0) / s.pdf)
            });
            assert_within_4_sigma(e, 2.0 * cos, "normalize true");
        }
        for angle in [0.53f32, 10.0] {
            let lit = distant(angle, false);
            let h = f64::from(angle).to_radians() / 2.0;
            let exact = 2.0 * PI * h.sin().powi(2) * f64::from(cos);
            let e = estimate(20_000, 4, |u| {
                let s = lit.sample(u);
                Some(s.radiance.x * s.wi.dot(n).max(0.0) / s.pdf)
            });
            assert_within_4_sigma(e, exact as f32, "normalize false");
        }
        assert_eq!(distant(0.0, false).radiance, Vec3::ZERO);
        // A cone wider than the hemisphere: the facing surface still gets the emission.
        let wide = distant(200.0, true);
        let e = estimate(20_000, 5, |u| {
            let s = wide.sample(u);
            Some(s.radiance.x * s.wi.x.max(0.0) / s.pdf)
        });
        assert_within_4_sigma(e, 2.0, "normalize true, 200 degrees");
    }

    #[test]
    fn samples_and_escaped_rays_agree() {
        let lit = distant(5.0, true);
        crate::lights::test_support::assert_escape_consistent(
            |u| Some(lit.sample(u)),
            |d| lit.escaped(d),
        );
        assert!(lit.escaped(-Vec3::X).is_none());
        assert!(distant(0.0, true).escaped(Vec3::X).is_none());
    }
}
