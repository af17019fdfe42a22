//! `RectLight`: a `width` x `height` rectangle in the light's XY plane,
//! centred at its origin, emitting from its front (-Z) face, optionally
//! modulated by `inputs:texture:file`; sampled uniformly by area.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::emission::area_radiance;
use super::image::LightImage;
use super::plane::Plane;
use super::{LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::scene::Light as LightRecord;

/// A rectangle light in world space (a parallelogram under shear).
#[derive(Clone, Debug)]
pub(crate) struct RectLight {
    /// Local [-1, 1]^2 is the rectangle.
    plane: Plane,
    /// World area, square scene units.
    area: f32,
    /// Radiance of the front face (times the texture where there is one).
    radiance: Vec3,
    /// The texture stretched over the rectangle: u along +X, v from +Y (the
    /// image's top row) to -Y, as seen looking at the light's back (+Z side).
    texture: Option<LightImage>,
}

impl RectLight {
    /// A point uniformly over the area, as seen from `p`; `None` when `p` is
    /// behind the emitting face.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let local = 2.0 * u - Vec2::ONE;
        let point = self.plane.point(local);
        LightSample::one_sided_area(p, point, self.plane.normal, 1.0 / self.area, || {
            self.radiance_at(local)
        })
    }

    /// The rectangle's centre, world space: where equiangular sampling aims.
    pub fn centre(&self) -> Vec3 {
        self.plane.point(Vec2::ZERO)
    }

    /// The ray's hit on the front face with t in (0, t_max).
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<LightHit> {
        let hit = self.plane.intersect(origin, direction, t_max)?;
        (hit.local.abs().max_element() <= 1.0).then(|| LightHit {
            t: hit.t,
            radiance: self.radiance_at(hit.local),
            pdf: self.plane.solid_angle_pdf(self.area, hit.t, direction),
        })
    }

    /// Where and how it emits, for the light BVH: its front half-space.
    pub fn bounds(&self) -> LightBounds {
        self.plane.bounds(self.power())
    }

    /// Luminance of the emitted power: pi L A (one face; mean texel luminance).
    pub fn power(&self) -> f32 {
        let tint = self
            .texture
            .as_ref()
            .map_or(1.0, LightImage::mean_luminance);
        PI * luminance(self.radiance) * tint * self.area
    }

    fn radiance_at(&self, local: Vec2) -> Vec3 {
        match &self.texture {
            Some(t) => self.radiance * t.texel(Vec2::new(local.x + 1.0, 1.0 - local.y) / 2.0),
            None => self.radiance,
        }
    }

    /// From the record; with `normalize` the radiance is the emission over the
    /// world area (transform scale included). A zero-area rectangle is an
    /// error with `normalize` and emits nothing without it.
    pub fn from_record(
        record: &LightRecord,
        width: f32,
        height: f32,
        texture: Option<&std::path::Path>,
    ) -> Result<Self, LightError> {
        if !(width.is_finite() && height.is_finite() && width >= 0.0 && height >= 0.0) {
            return Err(LightError::invalid(
                record,
                format!("size {width} x {height} is not finite and non-negative"),
            ));
        }
        let plane = Plane::from_record(record, width / 2.0, height / 2.0)?;
        let area = 4.0 * plane.unit_area;
        let radiance = area_radiance(record, area, "rectangle")?;
        Ok(Self {
            plane,
            area,
            radiance,
            texture: texture.and_then(|path| LightImage::load(path, &record.path)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{assert_hit_consistent, record};
    use crate::scene::LightShape;

    /// A 2 x 1 rectangle scaled by (1.5, 0.5) in its plane and placed at
    /// y = 3 with its front looking down -Y at the origin.
    fn rect(normalize: bool) -> RectLight {
        let mut r = record(
            LightShape::Rect {
                width: 2.0,
                height: 1.0,
                texture: None,
            },
            normalize,
            4.0,
        );
        // Light X -> world 1.5 X, light Y -> world 0.5 Z, light Z -> world Y
        // (so -Z, the front, faces -Y towards the origin).
        r.transform = [1.5, 0., 0., 0.1, 0., 0., 1., 3., 0., -0.5, 0., 0.2];
        RectLight::from_record(&r, 2.0, 1.0, None).unwrap()
    }

    #[test]
    fn area_and_front_face_follow_the_transform() {
        let light = rect(true);
        assert!((light.area - 1.5).abs() < 1e-6);
        assert!((light.radiance.x - 4.0 / 1.5).abs() < 1e-5);
        assert!((light.plane.normal - -Vec3::Y).length() < 1e-6);
        // From above (behind) nothing is seen or sampled.
        let above = Vec3::new(0.0, 5.0, 0.0);
        assert!(light.sample(above, Vec2::splat(0.3)).is_none());
        assert!(light.intersect(above, -Vec3::Y, 10.0).is_none());
        assert!(light.intersect(Vec3::ZERO, Vec3::Y, 10.0).is_some());
    }

    #[test]
    fn samples_and_hits_agree() {
        let light = rect(false);
        assert_hit_consistent(
            Vec3::new(0.2, 0.0, -0.1),
            |u| light.sample(Vec3::new(0.2, 0.0, -0.1), u),
            |o, w, t| light.intersect(o, w, t),
        );
    }

    #[test]
    fn the_texture_spans_the_rectangle_from_its_top_left() {
        let mut light = rect(false);
        // 2 x 2 texels: row 0 (top, light +Y) then row 1.
        let texels = [1.0, 2.0, 3.0, 4.0].map(Vec3::splat).to_vec();
        light.texture = Some(LightImage {
            width: 2,
            height: 2,
            texels,
        });
        assert!((light.power() - PI * 4.0 * 2.5 * 1.5).abs() < 1e-3);
        // Light +Y is world -Z here: local (0.5, 0.5) is world (0.75, 3, -0.125) + centre.
        let at = |x: f32, z: f32| {
            let o = Vec3::new(0.1 + x, 0.0, 0.2 + z);
            light.intersect(o, Vec3::Y, 10.0).unwrap().radiance.x / 4.0
        };
        assert_eq!(at(0.75, -0.125), 2.0, "top right");
        assert_eq!(at(-0.75, -0.125), 1.0, "top left");
        assert_eq!(at(-0.75, 0.125), 3.0, "bottom left");
        assert_hit_consistent(
            Vec3::ZERO,
            |u| light.sample(Vec3::ZERO, u),
            |o, w, t| light.intersect(o, w, t),
        );
    }
}
