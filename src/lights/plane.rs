//! The placed plane that `RectLight` and `DiskLight` share: the light's XY
//! plane under its world transform (any affine map: rotation, non-uniform
//! scale and shear keep it a plane), emitting from its front, the side its
//! local -Z points to.

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::{world_from_light, LightError};
use crate::sampling::warp::area_to_solid_angle;
use crate::scene::Light as LightRecord;

/// A light's XY plane in world space, in local coordinates `(a, b)` scaled so
/// the shape's extent is [-1, 1] along each axis.
#[derive(Clone, Debug)]
pub(crate) struct Plane {
    /// World position of local (0, 0).
    centre: Vec3,
    /// World offset of local (1, 0): the light's X axis times the half extent.
    axis_a: Vec3,
    /// World offset of local (0, 1).
    axis_b: Vec3,
    /// Dual vectors of `axis_a`, `axis_b` in the plane: local coordinates of a
    /// world offset `v` in the plane are `(v . dual_a, v . dual_b)`.
    dual_a: Vec3,
    dual_b: Vec3,
    /// Unit normal on the emitting side.
    pub normal: Vec3,
    /// World area of the parallelogram spanned by `axis_a`, `axis_b`
    /// (a quarter of the [-1, 1]^2 square's area), square scene units.
    pub unit_area: f32,
}

/// Where a ray crosses a [`Plane`] from its front.
pub(crate) struct PlaneHit {
    /// Ray parameter, scene units.
    pub t: f32,
    /// Local coordinates of the hit.
    pub local: Vec2,
}

impl Plane {
    /// World point at local coordinates `local`.
    pub fn point(&self, local: Vec2) -> Vec3 {
        self.centre + local.x * self.axis_a + local.y * self.axis_b
    }

    /// The ray (unit `direction`) crossing the plane from the front side with
    /// t in (0, t_max), and where in local coordinates.
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<PlaneHit> {
        let denom = direction.dot(self.normal);
        if denom >= 0.0 {
            return None;
        }
        let t = (self.centre - origin).dot(self.normal) / denom;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        let v = origin + t * direction - self.centre;
        Some(PlaneHit {
            t,
            local: Vec2::new(v.dot(self.dual_a), v.dot(self.dual_b)),
        })
    }

    /// Bounds of the [-1, 1]^2 parallelogram emitting `phi` from its front.
    pub fn bounds(&self, phi: f32) -> LightBounds {
        let extent = self.axis_a.abs() + self.axis_b.abs();
        LightBounds {
            min: self.centre - extent,
            max: self.centre + extent,
            phi,
            w: self.normal,
            cos_o: 1.0,
            cos_e: 0.0,
            two_sided: false,
        }
    }

    /// Solid-angle density at `point` seen from `p` along unit `wi` when
    /// points are drawn uniformly over `area`; 0 from behind the plane.
    pub fn solid_angle_pdf(&self, area: f32, distance: f32, wi: Vec3) -> f32 {
        let cos_light = -wi.dot(self.normal);
        if cos_light <= 0.0 {
            0.0
        } else {
            area_to_solid_angle(1.0 / area, distance, cos_light)
        }
    }

    /// The light's XY plane with local unit coordinates at `half_x` and
    /// `half_y` scene units along its X and Y axes, before the transform.
    pub fn from_record(record: &LightRecord, half_x: f32, half_y: f32) -> Result<Self, LightError> {
        let (linear, centre) = world_from_light(record)?;
        let axis_a = linear * Vec3::new(half_x, 0.0, 0.0);
        let axis_b = linear * Vec3::new(0.0, half_y, 0.0);
        let cross = axis_a.cross(axis_b);
        let unit_area = cross.length();
        // The front is the side of the plane the light's -Z lands on, whatever
        // the transform's handedness or shear.
        let back = linear * Vec3::Z;
        let mut normal = cross.normalize_or_zero();
        if normal.dot(back) > 0.0 {
            normal = -normal;
        }
        let (dual_a, dual_b) = if unit_area > 0.0 && unit_area.is_finite() {
            let na = axis_b.cross(normal);
            let nb = normal.cross(axis_a);
            (na / axis_a.dot(na), nb / axis_b.dot(nb))
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        Ok(Self {
            centre,
            axis_a,
            axis_b,
            dual_a,
            dual_b,
            normal,
            unit_area,
        })
    }
}
