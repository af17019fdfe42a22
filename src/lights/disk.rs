//! `DiskLight`: a disk of `radius` in the light's XY plane, centred at its
//! origin, emitting from its front (-Z) face; sampled uniformly by area
//! (an ellipse under non-uniform scale).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::emission::area_radiance;
use super::plane::Plane;
use super::{LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::sampling::warp::square_to_concentric_disk;
use crate::scene::Light as LightRecord;

/// A disk light in world space.
#[derive(Clone, Debug)]
pub(crate) struct DiskLight {
    /// Local unit disk is the light.
    plane: Plane,
    /// World area, square scene units.
    area: f32,
    /// Radiance of the front face.
    radiance: Vec3,
}

impl DiskLight {
    /// A point uniformly over the area (concentric map), as seen from `p`;
    /// `None` when `p` is behind the emitting face.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let point = self.plane.point(square_to_concentric_disk(u));
        LightSample::one_sided_area(p, point, self.plane.normal, 1.0 / self.area, || {
            self.radiance
        })
    }

    /// The disk's centre, world space: where equiangular sampling aims.
    pub fn centre(&self) -> Vec3 {
        self.plane.point(Vec2::ZERO)
    }

    /// The ray's hit on the front face with t in (0, t_max).
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<LightHit> {
        let hit = self.plane.intersect(origin, direction, t_max)?;
        (hit.local.length_squared() <= 1.0).then(|| LightHit {
            t: hit.t,
            radiance: self.radiance,
            pdf: self.plane.solid_angle_pdf(self.area, hit.t, direction),
        })
    }

    /// Where and how it emits, for the light BVH: its front half-space.
    pub fn bounds(&self) -> LightBounds {
        self.plane.bounds(self.power())
    }

    /// Luminance of the emitted power: pi L A (one face).
    pub fn power(&self) -> f32 {
        PI * luminance(self.radiance) * self.area
    }

    /// From the record; with `normalize` the radiance is the emission over the
    /// world area (transform scale included). A zero-area disk is an error
    /// with `normalize` and emits nothing without it.
    pub fn from_record(record: &LightRecord, radius: f32) -> Result<Self, LightError> {
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(LightError::invalid(
                record,
                format!("radius {radius} is not >= 0"),
            ));
        }
        let plane = Plane::from_record(record, radius, radius)?;
        let area = PI * plane.unit_area;
        let radiance = area_radiance(record, area, "disk")?;
        Ok(Self {
            plane,
            area,
            radiance,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{
        assert_hit_consistent, assert_within_4_sigma, estimate, record, translated,
    };
    use crate::scene::LightShape;

    /// A disk of radius `r` at height `d` facing down at the origin (the
    /// light's -Z is world -Z already).
    fn disk(r: f32, d: f32, transform: Option<[f32; 12]>) -> DiskLight {
        let mut rec = record(LightShape::Disk { radius: r }, false, 2.0);
        rec.transform = transform.unwrap_or(translated(Vec3::new(0.0, 0.0, d)));
        DiskLight::from_record(&rec, r).unwrap()
    }

    /// E = pi L r^2 / (r^2 + d^2) on the axis, facing the disk.
    #[test]
    fn irradiance_on_the_axis_matches_the_analytic_disk() {
        for (r, d) in [(1.0f32, 1.0f32), (0.2, 3.0)] {
            let light = disk(r, d, None);
            let e = estimate(20_000, 6, |u| {
                let s = light.sample(Vec3::ZERO, u)?;
                Some(s.radiance.x * s.wi.z.max(0.0) / s.pdf)
            });
            assert_within_4_sigma(e, PI * 2.0 * r * r / (r * r + d * d), "disk");
        }
    }

    #[test]
    fn non_uniform_scale_gives_an_ellipse() {
        // Scale (2, 0.5, 1), translated to z = 1.
        let light = disk(
            1.0,
            0.0,
            Some([2., 0., 0., 0., 0., 0.5, 0., 0., 0., 0., 1., 1.]),
        );
        assert!((light.area - PI).abs() < 1e-5);
        assert!(light
            .intersect(Vec3::new(1.9, 0.0, 0.0), Vec3::Z, 5.0)
            .is_some());
        assert!(light
            .intersect(Vec3::new(0.0, 0.6, 0.0), Vec3::Z, 5.0)
            .is_none());
        assert_hit_consistent(
            Vec3::new(0.5, 0.2, 0.0),
            |u| light.sample(Vec3::new(0.5, 0.2, 0.0), u),
            |o, w, t| light.intersect(o, w, t),
        );
    }
}
