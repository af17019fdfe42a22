//! [`Light`]'s methods: each matches over the closed set of light types and
//! forwards to the variant's own struct (one file per UsdLux type).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::bvh::LightBounds;
use super::cylinder::CylinderLight;
use super::disk::DiskLight;
use super::distant::DistantLight;
use super::dome::DomeLight;
use super::rect::RectLight;
use super::shaping::ShapedLight;
use super::sphere::SphereLight;
use super::{Emitters, Light, LightError, LightHit, LightSample};
use crate::scene::{Light as LightRecord, LightShape};

impl Light {
    /// A sample of this light from `p`, its pdf without selection.
    pub(super) fn sample(&self, emitters: Emitters, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Self::Distant(l) => Some(l.sample(u)),
            Self::Sphere(l) => l.sample(p, u),
            Self::Rect(l) => l.sample(p, u),
            Self::Disk(l) => l.sample(p, u),
            Self::Cylinder(l) => l.sample(p, u),
            Self::Dome(l) => l.sample(u),
            Self::Mesh(l) => l.sample(emitters.materials, p, u),
            Self::Volume(l) => l.sample(emitters.media, p, u, emitters.time),
            Self::Moving(l) => l.sample(emitters, p, u),
            Self::Shaped(l) => l.sample(emitters, p, u),
        }
    }

    /// The ray's front-face hit on an analytic area light (where it is at
    /// `time`, frames), pdf without selection.
    pub(super) fn intersect(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        time: f32,
    ) -> Option<LightHit> {
        match self {
            Self::Moving(l) => l.intersect(origin, direction, t_max, time),
            Self::Shaped(l) => l.intersect(origin, direction, t_max, time),
            Self::Sphere(l) => l.intersect(origin, direction, t_max),
            Self::Rect(l) => l.intersect(origin, direction, t_max),
            Self::Disk(l) => l.intersect(origin, direction, t_max),
            Self::Cylinder(l) => l.intersect(origin, direction, t_max),
            Self::Distant(_) | Self::Dome(_) | Self::Mesh(_) | Self::Volume(_) => None,
        }
    }

    /// What an escaping ray sees of an infinite light (a turning one as it
    /// is at `time`, frames), pdf without selection.
    pub(super) fn escaped(&self, direction: Vec3, time: f32) -> Option<LightHit> {
        match self {
            Self::Distant(l) => l.escaped(direction),
            Self::Dome(l) => Some(l.escaped(direction)),
            Self::Moving(l) => l.escaped(direction, time),
            _ => None,
        }
    }

    /// Position, power and emission directions for the light BVH; `None`
    /// for infinite lights.
    pub(super) fn bounds(&self) -> Option<LightBounds> {
        match self {
            Self::Sphere(l) => Some(l.bounds()),
            Self::Rect(l) => Some(l.bounds()),
            Self::Disk(l) => Some(l.bounds()),
            Self::Cylinder(l) => Some(l.bounds()),
            Self::Mesh(l) => Some(l.bounds()),
            Self::Volume(l) => Some(l.bounds()),
            Self::Moving(l) => l.bounds(),
            Self::Shaped(l) => l.bounds(),
            Self::Distant(_) | Self::Dome(_) => None,
        }
    }

    /// Luminance of the irradiance an infinite light (still or turning) delivers to a surface
    /// facing it, W/m^2 (its power is the flux through a disk of
    /// `scene_radius`, pi r^2 E, for a distant light, and 4 pi r^2 x pi L
    /// for a dome of mean radiance L, as pbrt-v4's `Phi`); 0 for bounded
    /// lights.
    pub(super) fn irradiance(&self, scene_radius: f32) -> f32 {
        let disk = PI * scene_radius * scene_radius;
        match self {
            Self::Distant(l) => l.power(scene_radius) / disk,
            Self::Dome(l) => l.power(scene_radius) / (4.0 * disk),
            Self::Moving(l) => l.frame().irradiance(scene_radius),
            _ => 0.0,
        }
    }

    /// Luminance of the emitted power (W, up to the luminance weighting);
    /// infinite lights through a disk of `scene_radius`.
    pub(super) fn power(&self, scene_radius: f32) -> f32 {
        match self {
            Self::Distant(l) => l.power(scene_radius),
            Self::Sphere(l) => l.power(),
            Self::Rect(l) => l.power(),
            Self::Disk(l) => l.power(),
            Self::Cylinder(l) => l.power(),
            Self::Dome(l) => l.power(scene_radius),
            Self::Mesh(l) => l.power(),
            Self::Volume(l) => l.power(),
            Self::Moving(l) => l.frame().power(scene_radius),
            Self::Shaped(l) => l.power(scene_radius),
        }
    }

    /// The light a manifest record describes, shaped by its `UsdLuxShapingAPI`
    /// inputs when it has them.
    pub(super) fn from_record(record: &LightRecord) -> Result<Self, LightError> {
        let light = match &record.shape {
            LightShape::Distant { angle_deg } => {
                Self::Distant(DistantLight::from_record(record, *angle_deg)?)
            }
            LightShape::Sphere {
                radius,
                treat_as_point,
            } => Self::Sphere(SphereLight::from_record(record, *radius, *treat_as_point)?),
            LightShape::Rect {
                width,
                height,
                texture,
            } => Self::Rect(RectLight::from_record(
                record,
                *width,
                *height,
                texture.as_deref(),
            )?),
            LightShape::Disk { radius } => Self::Disk(DiskLight::from_record(record, *radius)?),
            LightShape::Cylinder { radius, length } => {
                Self::Cylinder(CylinderLight::from_record(record, *radius, *length)?)
            }
            LightShape::Dome {
                texture,
                texture_format,
            } => Self::Dome(DomeLight::from_record(
                record,
                texture.as_deref(),
                *texture_format,
            )?),
        };
        Ok(ShapedLight::shape(light, record))
    }
}
