//! `SphereLight`: a sphere emitting outwards (nothing inside), sampled by the
//! solid angle it subtends (pbrt-v4's `Sphere::Sample` with a reference
//! point); `treatAsPoint` makes it a point light of the same power.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::emission::emission;
use super::{mean_scale, world_from_light, LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::geometry::Frame;
use crate::scene::Light as LightRecord;

/// A spherical light in world space, or a point light.
#[derive(Clone, Debug)]
pub(crate) struct SphereLight {
    /// Centre, world space.
    centre: Vec3,
    /// World radius, scene units (0 for a point light).
    radius: f32,
    /// Outgoing radiance of the surface (W/(m^2 sr)); for a point light, its
    /// intensity (W/sr).
    radiance: Vec3,
    /// `treatAsPoint`: a Dirac delta at the centre.
    point: bool,
}

/// Below this sin^2 of the cone's half-angle (1.5 degrees), 1 - cos loses
/// precision and the small-angle forms are used (pbrt-v4).
const SMALL_SIN2: f32 = 0.000_685_23;

impl SphereLight {
    /// Centre, world space.
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// A point on the visible cap, uniformly by solid angle (pdf 1 / cone),
    /// seen from `p`; `None` from inside the sphere (it emits outwards only).
    /// A point light gives its one direction with pdf 1 and `radiance` =
    /// intensity / d^2, the irradiance on a surface facing it.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let to_centre = self.centre - p;
        let dc2 = to_centre.length_squared();
        if self.point {
            let distance = dc2.sqrt();
            return (distance > 0.0).then(|| LightSample {
                radiance: self.radiance / dc2,
                wi: to_centre / distance,
                distance,
                pdf: 1.0,
                delta: true,
            });
        }
        let r2 = self.radius * self.radius;
        if dc2 <= r2 {
            return None;
        }
        let dc = dc2.sqrt();
        let sin2_max = r2 / dc2;
        let sin_max = sin2_max.sqrt();
        let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
        let (cos_theta, sin2_theta) = if sin2_max < SMALL_SIN2 {
            let s2 = sin2_max * u.x;
            ((1.0 - s2).sqrt(), s2)
        } else {
            let c = (cos_max - 1.0) * u.x + 1.0;
            (c, (1.0 - c * c).max(0.0))
        };
        // Angle at the centre between -w_centre and the sampled point.
        let cos_alpha =
            sin2_theta / sin_max + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let frame = Frame::from_normal(to_centre / dc);
        let normal = frame.to_world(-Vec3::new(
            sin_alpha * phi.cos(),
            sin_alpha * phi.sin(),
            cos_alpha,
        ));
        let point = self.centre + self.radius * normal;
        let offset = point - p;
        let distance = offset.length();
        Some(LightSample {
            radiance: self.radiance,
            wi: offset / distance,
            distance,
            pdf: cone_pdf(sin2_max),
            delta: false,
        })
    }

    /// The nearest hit of the ray (unit `direction`) on the outside of the
    /// sphere with t in (0, t_max); none from inside or for a point light.
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<LightHit> {
        if self.point {
            return None;
        }
        let oc = origin - self.centre;
        let r2 = self.radius * self.radius;
        let dc2 = oc.length_squared();
        if dc2 <= r2 {
            return None;
        }
        let b = oc.dot(direction);
        // r^2 - |oc - b d|^2: the discriminant without cancellation (pbrt-v4 §6.8.1).
        let disc = r2 - (oc - b * direction).length_squared();
        if disc < 0.0 || b >= 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        (t > 0.0 && t < t_max).then(|| LightHit {
            t,
            radiance: self.radiance,
            pdf: cone_pdf(r2 / dc2),
        })
    }

    /// Where and how it emits, for the light BVH: in every direction.
    pub fn bounds(&self) -> LightBounds {
        let r = Vec3::splat(self.radius);
        LightBounds::omni(self.centre - r, self.centre + r, self.power())
    }

    /// Luminance of the emitted power: pi L 4 pi r^2, or 4 pi I for a point.
    pub fn power(&self) -> f32 {
        let l = luminance(self.radiance);
        if self.point {
            4.0 * PI * l
        } else {
            PI * l * 4.0 * PI * self.radius * self.radius
        }
    }

    /// From the record. The world radius is the record's radius times the
    /// mean of the transform's three axis scales: a sphere stays a sphere,
    /// and non-uniform scale is warned about once. With `normalize` the
    /// radiance is the emission over the world area 4 pi r^2. A point light
    /// keeps the sphere's power: intensity = pi r^2 L (emission / 4 with
    /// `normalize`).
    pub fn from_record(
        record: &LightRecord,
        radius: f32,
        treat_as_point: bool,
    ) -> Result<Self, LightError> {
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(LightError::invalid(
                record,
                format!("radius {radius} is not >= 0"),
            ));
        }
        let (linear, centre) = world_from_light(record)?;
        let radius = radius * mean_scale(record, linear);
        let area = 4.0 * PI * radius * radius;
        let e = emission(record)?;
        let radiance = if record.normalize {
            if area == 0.0 && !treat_as_point {
                return Err(LightError::invalid(
                    record,
                    "normalize on a sphere of zero area",
                ));
            }
            e / area
        } else {
            e
        };
        Ok(if treat_as_point {
            let intensity = if record.normalize {
                e / 4.0
            } else {
                PI * radius * radius * e
            };
            Self {
                centre,
                radius: 0.0,
                radiance: intensity,
                point: true,
            }
        } else {
            Self {
                centre,
                radius,
                radiance,
                point: false,
            }
        })
    }
}

/// Solid-angle density of uniform sampling of the cone a sphere subtends,
/// given sin^2 of its half-angle; consistent between sampling and hits.
fn cone_pdf(sin2_max: f32) -> f32 {
    let one_minus_cos = if sin2_max < SMALL_SIN2 {
        sin2_max / 2.0
    } else {
        1.0 - (1.0 - sin2_max).max(0.0).sqrt()
    };
    1.0 / (2.0 * PI * one_minus_cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{
        assert_hit_consistent, assert_within_4_sigma, estimate, record, translated,
    };
    use crate::scene::LightShape;

    fn sphere(radius: f32, at: Vec3, normalize: bool, point: bool) -> SphereLight {
        let mut r = record(
            LightShape::Sphere {
                radius,
                treat_as_point: point,
            },
            normalize,
            3.0,
        );
        r.transform = translated(at);
        SphereLight::from_record(&r, radius, point).unwrap()
    }

    /// E = pi L (r/d)^2 at a point facing the centre, sphere above the horizon.
    #[test]
    fn irradiance_matches_the_analytic_sphere() {
        for (r, d) in [(0.5f32, 2.0f32), (0.01, 5.0), (1.0, 1.2)] {
            let light = sphere(r, Vec3::new(0.0, 0.0, d), false, false);
            let e = estimate(20_000, 5, |u| {
                let s = light.sample(Vec3::ZERO, u)?;
                Some(s.radiance.x * s.wi.z.max(0.0) / s.pdf)
            });
            assert_within_4_sigma(e, PI * 3.0 * (r / d).powi(2), "sphere");
        }
        // A point light of the same power gives I / d^2 = pi r^2 L / d^2 on the axis.
        let point = sphere(0.5, Vec3::new(0.0, 0.0, 2.0), false, true);
        let s = point.sample(Vec3::ZERO, Vec2::ZERO).unwrap();
        assert!(s.delta && s.pdf == 1.0);
        assert!((s.radiance.x * s.wi.z - PI * 3.0 * 0.0625).abs() < 1e-5);
    }

    #[test]
    fn normalize_divides_by_the_scaled_area() {
        let mut r = record(
            LightShape::Sphere {
                radius: 0.5,
                treat_as_point: false,
            },
            true,
            3.0,
        );
        r.transform = [2., 0., 0., 0., 0., 2., 0., 0., 0., 0., 2., 0.];
        let light = SphereLight::from_record(&r, 0.5, false).unwrap();
        assert!((light.radius - 1.0).abs() < 1e-6);
        assert!((light.radiance.x - 3.0 / (4.0 * PI)).abs() < 1e-6);
    }

    #[test]
    fn samples_and_hits_agree() {
        for (r, d) in [(0.5f32, 2.0f32), (0.01, 5.0)] {
            let light = sphere(r, Vec3::new(0.3, -0.2, d), false, false);
            assert_hit_consistent(
                Vec3::ZERO,
                |u| light.sample(Vec3::ZERO, u),
                |o, w, t| light.intersect(o, w, t),
            );
        }
        let light = sphere(1.0, Vec3::ZERO, false, false);
        assert!(light
            .sample(Vec3::new(0.1, 0.0, 0.0), Vec2::splat(0.5))
            .is_none());
        assert!(light.intersect(Vec3::ZERO, Vec3::X, 10.0).is_none());
    }
}
