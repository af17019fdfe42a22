//! `CylinderLight`: the side of a cylinder along the light's X axis,
//! centred at its origin, emitting outwards (no end caps, as UsdLux says);
//! sampled uniformly by area.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::emission::area_radiance;
use super::{world_from_light, LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::geometry::Frame;
use crate::sampling::warp::area_to_solid_angle;
use crate::scene::Light as LightRecord;

/// A cylinder light in world space.
#[derive(Clone, Debug)]
pub(crate) struct CylinderLight {
    /// Centre, world space.
    centre: Vec3,
    /// `n` is the unit axis (the light's X), `s` and `t` span the cross-section.
    frame: Frame,
    /// World radius, scene units.
    radius: f32,
    /// Half the world length, scene units.
    half_length: f32,
    /// Radiance of the outer surface.
    radiance: Vec3,
}

impl CylinderLight {
    /// A point uniformly over the side's area, as seen from `p`; `None` when
    /// it faces away from `p`.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let phi = 2.0 * PI * u.y;
        let normal = self.frame.to_world(Vec3::new(phi.cos(), phi.sin(), 0.0));
        let along = (2.0 * u.x - 1.0) * self.half_length;
        let point = self.centre + along * self.frame.n + self.radius * normal;
        LightSample::one_sided_area(p, point, normal, 1.0 / self.area(), || self.radiance)
    }

    /// The ray's nearest hit on the outside of the side with t in (0, t_max).
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<LightHit> {
        // In the frame, the side is x^2 + y^2 = r^2 for |z| <= half_length.
        let o = self.frame.to_local(origin - self.centre);
        let d = self.frame.to_local(direction);
        let a = d.x * d.x + d.y * d.y;
        let b = o.x * d.x + o.y * d.y;
        let c = o.x * o.x + o.y * o.y - self.radius * self.radius;
        // b^2 - a c as a (r^2 - |o - (b/a) d|^2) in the cross-section: no
        // cancellation for rays near the silhouette (pbrt-v4 §6.8.1).
        let closest = Vec2::new(o.x, o.y) - (b / a) * Vec2::new(d.x, d.y);
        let disc = a * (self.radius * self.radius - closest.length_squared());
        // From inside (c <= 0) only the inner face is visible: nothing.
        if c <= 0.0 || a == 0.0 || disc < 0.0 || b >= 0.0 {
            return None;
        }
        let t = c / (-b + disc.sqrt());
        let hit = o + t * d;
        if !(t > 0.0 && t < t_max && hit.z.abs() <= self.half_length) {
            return None;
        }
        // The cosine at the hit is sqrt(disc) / r exactly (|o + t d| = r and
        // (o + t d) . d = -sqrt(disc) there), and stable where the hit
        // point's normal would not be: near the silhouette.
        Some(LightHit {
            t,
            radiance: self.radiance,
            pdf: self.solid_angle_pdf(t, disc.sqrt() / self.radius),
        })
    }

    /// Where and how it emits, for the light BVH: in every direction from
    /// its box (the axis' extent plus r sqrt(1 - axis_i^2) per coordinate).
    pub fn bounds(&self) -> LightBounds {
        let n = self.frame.n;
        let extent = n.abs() * self.half_length
            + (Vec3::ONE - n * n).max(Vec3::ZERO).powf(0.5) * self.radius;
        LightBounds::omni(self.centre - extent, self.centre + extent, self.power())
    }

    /// Luminance of the emitted power: pi L A.
    pub fn power(&self) -> f32 {
        PI * luminance(self.radiance) * self.area()
    }

    fn area(&self) -> f32 {
        2.0 * PI * self.radius * 2.0 * self.half_length
    }

    /// Solid-angle density of a point drawn uniformly by area, `distance`
    /// away at cosine `cos_light` to its normal; 0 when it faces away.
    fn solid_angle_pdf(&self, distance: f32, cos_light: f32) -> f32 {
        if cos_light <= 0.0 {
            0.0
        } else {
            area_to_solid_angle(1.0 / self.area(), distance, cos_light)
        }
    }

    /// From the record. The world length scales with the transform's X axis;
    /// the radius with the mean of its Y and Z scales (a circular
    /// cross-section, warned about when they differ). With `normalize` the
    /// radiance is the emission over the world side area 2 pi r l.
    pub fn from_record(record: &LightRecord, radius: f32, length: f32) -> Result<Self, LightError> {
        if !(radius.is_finite() && length.is_finite() && radius >= 0.0 && length >= 0.0) {
            return Err(LightError::invalid(
                record,
                format!("radius {radius} and length {length} are not finite and non-negative"),
            ));
        }
        let (linear, centre) = world_from_light(record)?;
        let (x, y, z) = (linear.x_axis, linear.y_axis, linear.z_axis);
        let (sy, sz) = (y.length(), z.length());
        if (sy - sz).abs() > 1e-3 * sy.max(sz) {
            log::warn!(
                "light {}: cylinder cross-section scaled by {sy} and {sz}; using a circle of their mean",
                record.path
            );
        }
        let axis = x.normalize_or_zero();
        let mut light = Self {
            centre,
            frame: Frame::from_normal_tangent(if axis == Vec3::ZERO { Vec3::X } else { axis }, y),
            radius: radius * (sy + sz) / 2.0,
            half_length: length * x.length() / 2.0,
            radiance: Vec3::ZERO,
        };
        light.radiance = area_radiance(record, light.area(), "cylinder")?;
        Ok(light)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{assert_hit_consistent, estimate, record};
    use crate::scene::LightShape;

    fn cylinder(transform: [f32; 12], normalize: bool) -> CylinderLight {
        let mut r = record(
            LightShape::Cylinder {
                radius: 0.25,
                length: 2.0,
            },
            normalize,
            2.0,
        );
        r.transform = transform;
        CylinderLight::from_record(&r, 0.25, 2.0).unwrap()
    }

    /// Axis along world Y (light X -> world Y), at (1, 0, 3).
    const TILTED: [f32; 12] = [0., -1., 0., 1., 1., 0., 0., 0., 0., 0., 1., 3.];

    #[test]
    fn samples_and_hits_agree() {
        let light = cylinder(TILTED, false);
        assert_hit_consistent(
            Vec3::ZERO,
            |u| light.sample(Vec3::ZERO, u),
            |o, w, t| light.intersect(o, w, t),
        );
        // From inside and past the end caps nothing is seen.
        assert!(light
            .intersect(Vec3::new(1.0, 0.0, 3.0), Vec3::X, 10.0)
            .is_none());
        assert!(light
            .intersect(Vec3::new(1.0, 5.0, 3.0), -Vec3::Y, 10.0)
            .is_none());
    }

    /// A finite cylinder's irradiance has no short closed form, so compare
    /// with an independent estimator of the same integral: uniform
    /// directions over the sphere, each traced with `intersect`.
    #[test]
    fn irradiance_matches_direction_sampling_through_intersect() {
        let light = cylinder(TILTED, true);
        let n = Vec3::new(0.3, 0.0, 1.0).normalize();
        let by_area = estimate(40_000, 8, |u| {
            let s = light.sample(Vec3::ZERO, u)?;
            Some(s.radiance.x * s.wi.dot(n).max(0.0) / s.pdf)
        });
        let by_direction = estimate(400_000, 9, |u| {
            let w = crate::sampling::warp::square_to_uniform_sphere(u);
            let hit = light.intersect(Vec3::ZERO, w, f32::INFINITY)?;
            Some(hit.radiance.x * w.dot(n).max(0.0) * 4.0 * PI)
        });
        let diff = by_area.mean - by_direction.mean;
        let sigma = (by_area.sigma.powi(2) + by_direction.sigma.powi(2)).sqrt();
        assert!(diff.abs() < 4.0 * sigma, "{by_area:?} vs {by_direction:?}");
    }
}
