//! Lights moved by their keyed transforms over the shutter (any UsdLux
//! light with a `motion` record; docs/rendering.md, "Motion blur").
//!
//! A moving light is its still light at the frame moved rigidly: at time t
//! (frames) it is turned by R(t) about a pivot (the centre of its box at
//! the frame) and the pivot carried to c(t). The keys are the exported
//! world-from-light transforms relative to the frame's, split into a
//! rotation and the pivot's position; between keys the rotation is slerped
//! and the pivot lerped, so the light never shrinks or shears (a matrix
//! lerp would, and a light's area and pdf must be those of the shape it
//! is). A query at time t goes to the frame light through the inverse
//! motion (a point p to pivot + R^-1 (p - c(t)), a direction w to R^-1 w)
//! and its answer comes back rotated; rigid motions keep distances, angles
//! and solid angles, so radiance and pdfs carry over unchanged. Keys that
//! scale or shear the light relative to the frame are refused (the light is
//! rendered still, warned). Its box for the light BVH covers the whole
//! motion: every point stays within the frame box's half diagonal of the
//! pivot, which moves on the segments between its key positions.
//!
//! A distant or dome light is infinitely far: only its rotation matters
//! (pivot at the origin, translation ignored as the still light ignores it).
//! It has no box; a sample at time t is the frame light's sample turned by
//! R(t), and a ray escaping along w at time t sees what the frame light
//! shows along R(t)^-1 w (a dome's texture lookup turned with it). Its
//! power and irradiance are the frame light's, so it is picked as the
//! still light is. Still lights keep their own variants: no per-ray
//! rotation where nothing moves.

use glam::{Affine3A, Quat, Vec2, Vec3};

use super::bvh::LightBounds;
use super::{Emitters, Light, LightHit, LightSample};
use crate::scene::CameraMotion;

/// Largest relative change of an axis length, or of an angle's cosine
/// between axes, that a key may make and still count as rigid.
const RIGID_TOLERANCE: f32 = 1e-3;

/// A light moving rigidly over the shutter.
#[derive(Clone, Debug)]
pub(crate) struct MovingLight {
    /// The light as it is at the frame.
    frame: Box<Light>,
    /// The point it turns about, world space at the frame.
    pivot: Vec3,
    /// Key times, frames, strictly increasing.
    times: Vec<f32>,
    /// Per key, the rotation from the frame pose and where the pivot is.
    poses: Vec<(Quat, Vec3)>,
    /// Its box over the whole motion, emitting in every direction; `None`
    /// for a distant or dome light.
    bounds: Option<LightBounds>,
}

impl MovingLight {
    /// `frame` (a light placed at `world_from_light`) moved by the keyed
    /// `motion`; `None` when a key scales or shears it relative to the frame.
    pub fn new(frame: Light, world_from_light: &Affine3A, motion: &CameraMotion) -> Option<Self> {
        let box_ = frame.bounds();
        let pivot = box_.map_or(Vec3::ZERO, |b| (b.min + b.max) / 2.0);
        let light_from_world = world_from_light.inverse();
        let mut poses = Vec::with_capacity(motion.times.len());
        for key in &motion.transforms {
            let delta = crate::scene::affine(key) * light_from_world;
            let rotation = rigid_rotation(&delta)?;
            poses.push((rotation, delta.transform_point3(pivot)));
        }
        let bounds = box_.map(|b| {
            let reach = Vec3::splat((b.max - b.min).length() / 2.0);
            let (min, max) = poses.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(min, max), &(_, c)| (min.min(c - reach), max.max(c + reach)),
            );
            LightBounds::omni(min, max, b.phi)
        });
        Some(Self {
            bounds,
            frame: Box::new(frame),
            pivot,
            times: motion.times.clone(),
            poses,
        })
    }

    /// The rotation and pivot position at `time`: slerp and lerp between
    /// the keys around it, the first or last key outside them.
    fn pose(&self, time: f32) -> (Quat, Vec3) {
        let after = self.times.partition_point(|&t| t <= time);
        if after == 0 {
            return self.poses[0];
        }
        if after == self.times.len() {
            return self.poses[after - 1];
        }
        let (t0, t1) = (self.times[after - 1], self.times[after]);
        let s = (time - t0) / (t1 - t0);
        let ((r0, c0), (r1, c1)) = (self.poses[after - 1], self.poses[after]);
        (r0.slerp(r1, s), c0.lerp(c1, s))
    }

    /// World point `p` at `time` where the frame light sees it, and the
    /// rotation from the frame pose to the pose then.
    fn to_frame(&self, p: Vec3, time: f32) -> (Vec3, Quat) {
        let (rotation, centre) = self.pose(time);
        (self.pivot + rotation.inverse() * (p - centre), rotation)
    }

    /// A sample of the light as it is at `emitters.time`, seen from `p`.
    pub fn sample(&self, emitters: Emitters, p: Vec3, u: Vec2) -> Option<LightSample> {
        let (p_frame, rotation) = self.to_frame(p, emitters.time);
        let mut sample = self.frame.sample(emitters, p_frame, u)?;
        sample.wi = rotation * sample.wi;
        Some(sample)
    }

    /// The ray's front-face hit on the light as it is at `time`.
    pub fn intersect(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        time: f32,
    ) -> Option<LightHit> {
        let (origin, rotation) = self.to_frame(origin, time);
        let direction = (rotation.inverse() * direction).normalize();
        self.frame.intersect(origin, direction, t_max, time)
    }

    /// What a ray escaping along unit `direction` at `time` sees of a
    /// turning distant or dome light: the frame light's answer for the
    /// direction turned back (`None` for a bounded light).
    pub fn escaped(&self, direction: Vec3, time: f32) -> Option<LightHit> {
        let (rotation, _) = self.pose(time);
        self.frame.escaped(rotation.inverse() * direction, time)
    }

    /// Its box over the whole motion, emitting in every direction; `None`
    /// for a distant or dome light.
    pub fn bounds(&self) -> Option<LightBounds> {
        self.bounds
    }

    /// The light as it is at the frame (its power, irradiance and whether
    /// escaping rays see it are those of the moving light).
    pub fn frame(&self) -> &Light {
        &self.frame
    }

    /// Where equiangular sampling aims: the centre of its motion's box;
    /// `None` for a distant or dome light.
    pub fn centre(&self) -> Option<Vec3> {
        self.bounds.map(|b| (b.min + b.max) / 2.0)
    }
}

/// The rotation of `delta` when its linear part is one (orthonormal axes,
/// no mirror, within [`RIGID_TOLERANCE`]); `None` otherwise.
fn rigid_rotation(delta: &Affine3A) -> Option<Quat> {
    let m = glam::Mat3::from(delta.matrix3);
    let axes = [m.x_axis, m.y_axis, m.z_axis];
    let unit = axes
        .iter()
        .all(|a| (a.length() - 1.0).abs() <= RIGID_TOLERANCE);
    let square = [(0, 1), (1, 2), (0, 2)]
        .iter()
        .all(|&(i, j)| axes[i].dot(axes[j]).abs() <= RIGID_TOLERANCE);
    (unit && square && m.determinant() > 0.0 && m.is_finite())
        .then(|| Quat::from_mat3(&m).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{record, scene_with, translated};
    use crate::materials::Materials;
    use crate::scene::LightShape;
    use crate::volumes::Media;

    fn sphere_moving(keys: Vec<[f32; 12]>) -> Option<MovingLight> {
        let record = record(
            LightShape::Sphere {
                radius: 0.5,
                treat_as_point: false,
            },
            false,
            1.0,
        );
        let frame = Light::from_record(&record).unwrap();
        let times = (0..keys.len()).map(|k| k as f32).collect();
        let motion = CameraMotion {
            times,
            transforms: keys,
        };
        MovingLight::new(frame, &Affine3A::IDENTITY, &motion)
    }

    /// A sphere translated from x = 0 to x = 4 over [0, 1] is hit at x = 2
    /// at t = 0.5, missed where it was at the frame, and boxed over the
    /// whole motion; a key that scales it is refused.
    #[test]
    fn a_moving_sphere_is_where_its_keys_put_it_at_the_ray_time() {
        let light = sphere_moving(vec![
            translated(Vec3::ZERO),
            translated(Vec3::new(4.0, 0.0, 0.0)),
        ])
        .unwrap();
        let from = Vec3::new(2.0, -5.0, 0.0);
        let hit = light.intersect(from, Vec3::Y, 10.0, 0.5).unwrap();
        assert!((hit.t - 4.5).abs() < 1e-5, "{}", hit.t);
        assert!(light.intersect(from, Vec3::Y, 10.0, 0.0).is_none());
        let bounds = light.bounds().unwrap();
        assert!(bounds.min.x <= -0.5 && bounds.max.x >= 4.5, "{bounds:?}");
        let mut scaled = translated(Vec3::ZERO);
        scaled[0] = 2.0;
        assert!(sphere_moving(vec![translated(Vec3::ZERO), scaled]).is_none());
    }

    /// A distant light of 5 degrees turning a quarter turn about Y over
    /// [0, 1] (its axis from +Z to +X) and carried off by a translation
    /// that does not matter: at t = 0.5 its samples lie around the axis
    /// halfway and escaping rays see it there with the samples' pdf, at
    /// t = 0 it is where the frame light is; it has no box.
    #[test]
    fn a_turning_distant_light_points_where_its_keys_turn_it_at_the_ray_time() {
        let record = record(LightShape::Distant { angle_deg: 5.0 }, true, 1.0);
        let frame = Light::from_record(&record).unwrap();
        let mut quarter = translated(Vec3::new(7.0, 0.0, -3.0));
        [quarter[0], quarter[2], quarter[8], quarter[10]] = [0.0, 1.0, -1.0, 0.0];
        let motion = CameraMotion {
            times: vec![0.0, 1.0],
            transforms: vec![translated(Vec3::ZERO), quarter],
        };
        let light = MovingLight::new(frame, &Affine3A::IDENTITY, &motion).unwrap();
        assert!(light.bounds().is_none() && light.centre().is_none());
        let halfway = Vec3::new(1.0, 0.0, 1.0).normalize();
        let scene = scene_with("turning", serde_json::json!([]), [0.0; 3], &[]);
        let (materials, media) = (Materials::build(&scene).unwrap(), Media::default());
        let emitters = Emitters {
            materials: &materials,
            media: &media,
            time: 0.5,
        };
        for i in 0..64 {
            let u = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.06);
            let sample = light.sample(emitters, Vec3::ZERO, u).unwrap();
            assert!(sample.wi.dot(halfway) > (2.5f32 + 1e-3).to_radians().cos());
            let hit = light.escaped(sample.wi, 0.5).unwrap();
            assert!((hit.pdf - sample.pdf).abs() <= 1e-3 * sample.pdf);
        }
        assert!(light.escaped(halfway, 0.0).is_none());
        assert!(light.escaped(Vec3::Z, 0.0).is_some());
        assert!(light.escaped(Vec3::X, 1.0).is_some());
    }
}
