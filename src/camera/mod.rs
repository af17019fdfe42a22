//! USD cameras (`UsdGeomCamera`): perspective (pinhole or thin lens) and
//! orthographic, as docs/conventions.md, "Camera and image", defines them.
//!
//! - Frame: the camera looks down its -Z with +Y up and +X to the image's
//!   right; film positions are in pixels from the image's top-left corner,
//!   y down, so pixel (i, j)'s centre is (i + 0.5, j + 0.5).
//! - Apertures, aperture offsets and the focal length are in tenths of a scene
//!   unit (UsdGeomCamera, "Units of Measure for Camera Properties"). The
//!   horizontal field of view is 2 atan(horizontalAperture / (2 focalLength));
//!   an orthographic camera's apertures are its view size.
//! - When the image aspect differs from the aperture's, the aperture is
//!   conformed with UsdRender's default `aspectRatioConformPolicy`,
//!   "expandAperture", about the aperture's (offset) centre. The image
//!   aspect is width x `pixelAspectRatio` / height ([`Raster`]): a pixel
//!   covers `pixelAspectRatio` times more of the aperture across than down.
//! - Thin lens (pbrt-v4 §5.2.3, `PerspectiveCamera`): with `fStop` > 0 and
//!   `focusDistance` > 0, rays leave a lens of radius
//!   focalLength / (2 fStop) and every ray of one film position passes through
//!   the same point of the plane of focus.
//! - The world-from-camera transform may scale: lengths authored in camera
//!   space (clipping range, focus distance, lens radius, orthographic view)
//!   are scaled with it, like any geometry under the prim; directions are
//!   normalised and `t_min`/`t_max` are world distances.
//! - Shutter and motion (docs/rendering.md, "Motion blur"): each ray has a
//!   time in the shutter interval (frames relative to the frame rendered);
//!   a moving camera's world-from-camera transform is its keys' matrix lerp
//!   at that time ([`TransformTrack`]). The compositing matrices below are
//!   the camera's at the frame itself.
//! - For compositing, [`Camera::world_to_camera`] and [`Camera::world_to_ndc`]
//!   give the matrices of OpenEXR's `worldToCamera` and `worldToNDC`
//!   standard attributes (read by Nuke to rebuild the camera and project
//!   points), and [`Camera::depth`] the `Z` AOV: all in USD camera space
//!   (-Z forward, +Y up, +X right), so a scaling camera transform scales
//!   depths like the clipping range.

mod motion;
mod validate;
mod window;

use glam::{Affine3A, Mat4, Vec2, Vec3, Vec4};
use thiserror::Error;

pub use window::Raster;

use crate::motion::{Shutter, TransformTrack};
use crate::sampling::warp::square_to_concentric_disk;
use crate::scene;
use validate::validate;
use window::FilmWindow;

/// A camera ready to generate world-space rays for a given image resolution.
#[derive(Clone, Debug)]
pub struct Camera {
    world_from_camera: Affine3A,
    /// The inverse of `world_from_camera`.
    camera_from_world: Affine3A,
    /// Film positions to the image plane at z = -1 (perspective) or to the
    /// view rectangle at z = 0 in camera units (orthographic).
    window: FilmWindow,
    projection: Projection,
    /// Camera-space depth where rays start: the near clipping plane, or 0
    /// when that plane is negligible (see [`NEAR_PLANE_MIN_FRACTION`]).
    near: f32,
    /// Camera-space depth of the far clipping plane.
    far: f32,
    /// `pixelAspectRatio`: a pixel's width over its height.
    pixel_aspect: f32,
    /// The shutter interval rays draw their times from.
    shutter: Shutter,
    /// World-from-camera over the shutter; `None` when the camera does not move.
    motion: Option<TransformTrack>,
    /// UsdGeomCamera's linear exposure scale: every radiance the camera
    /// records is multiplied by it.
    exposure_scale: f32,
}

/// How rays leave the camera.
#[derive(Clone, Copy, Debug)]
enum Projection {
    /// All rays start at the eye.
    Pinhole,
    /// Rays start on a lens disk and focus on a plane.
    ThinLens(ThinLens),
    /// Parallel rays along -Z from the view rectangle.
    Orthographic,
}

/// A thin lens in camera space, centred at the eye in the z = 0 plane.
#[derive(Clone, Copy, Debug)]
struct ThinLens {
    /// focalLength / (2 fStop), camera-space units.
    radius: f32,
    /// Depth of the plane of focus, camera-space units.
    focus_distance: f32,
}

/// A primary ray: unit `direction`, valid for `t_min < t < t_max`.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    /// World-space origin, scene units.
    pub origin: Vec3,
    /// Unit world-space direction.
    pub direction: Vec3,
    /// Start of the valid segment (the near clipping plane), scene units.
    pub t_min: f32,
    /// End of the valid segment (the far clipping plane), scene units.
    pub t_max: f32,
}

/// A camera record that cannot make rays.
#[derive(Debug, Error)]
pub enum CameraError {
    /// An attribute (or the resolution) is out of its valid range.
    #[error("{}: {message}", describe(.path))]
    Invalid {
        /// Camera prim path, or `default camera` for the one framing the scene.
        path: String,
        /// What is wrong, naming the USD attribute.
        message: String,
    },
}

/// The near clipping plane is honoured only when it exceeds this fraction of
/// the far plane (docs/conventions.md, "Camera and image"): rays start at the
/// eye unless the near plane is a noticeable share of the range. Near planes
/// exist for rasteriser depth precision, which keeps near/far small (USD's
/// fallback clipping range 1..1e6 is 1e-6); a near plane at a larger share of
/// the range is a deliberate cut.
pub const NEAR_PLANE_MIN_FRACTION: f32 = 1e-3;

impl Camera {
    /// The primary ray through `film` (pixels from the top-left corner, y
    /// down) using `u_lens` in [0,1)^2 for the thin lens (ignored otherwise),
    /// from where the camera is at `time` (frames).
    pub fn generate_ray(&self, film: Vec2, u_lens: Vec2, time: f32) -> CameraRay {
        let p = self.window.at(film);
        let (origin, direction) = match self.projection {
            Projection::Pinhole => (Vec3::ZERO, p.extend(-1.0)),
            Projection::ThinLens(lens) => {
                let on_lens = (lens.radius * square_to_concentric_disk(u_lens)).extend(0.0);
                let in_focus = p.extend(-1.0) * lens.focus_distance;
                (on_lens, in_focus - on_lens)
            }
            Projection::Orthographic => (p.extend(0.0), Vec3::NEG_Z),
        };
        let direction = direction.normalize();
        // Rays start in the z = 0 plane, so the clipping planes z = -near and
        // z = -far lie at depth / cos(angle to the view axis) along them.
        let t_per_depth = 1.0 / -direction.z;
        let world_from_camera = match &self.motion {
            Some(track) => track.at(time),
            None => self.world_from_camera,
        };
        let world_direction = world_from_camera.transform_vector3(direction);
        let world_per_camera = world_direction.length();
        let t_scale = t_per_depth * world_per_camera;
        CameraRay {
            origin: world_from_camera.transform_point3(origin),
            direction: world_direction / world_per_camera,
            t_min: self.near * t_scale,
            t_max: self.far * t_scale,
        }
    }

    /// `pixelAspectRatio`: a pixel's width over its height.
    pub fn pixel_aspect(&self) -> f32 {
        self.pixel_aspect
    }

    /// UsdGeomCamera's linear exposure scale ("Camera Exposure Model":
    /// responsivity x time x iso/100 x 2^exposure / fStop^2, 1 by default),
    /// by which the image's radiance is multiplied.
    pub fn exposure_scale(&self) -> f32 {
        self.exposure_scale
    }

    /// The shutter interval: a ray's time is drawn from it.
    pub fn shutter(&self) -> Shutter {
        self.shutter
    }

    /// The same camera with its shutter replaced (`--shutter`); a closed
    /// one ([`Shutter::blurs`] false) leaves the camera at the frame.
    pub fn with_shutter(self, shutter: Shutter) -> Self {
        let motion = self.motion.filter(|_| shutter.blurs());
        Self {
            shutter,
            motion,
            ..self
        }
    }

    /// Camera-space depth of the world point `p`: its distance along the
    /// viewing axis from the eye's z = 0 plane, positive in front (-z in USD
    /// camera space). The `Z` AOV; camera-space units, which are scene
    /// units unless the camera's transform scales.
    pub fn depth(&self, p: Vec3) -> f32 {
        -self.camera_from_world.transform_point3(p).z
    }

    /// World-to-camera matrix (column vectors, `M * (p, 1)`): the inverse of
    /// the camera prim's world transform, into USD camera space (looking
    /// down -Z, +Y up, +X right). OpenEXR's `worldToCamera` attribute as
    /// RenderMan and Nuke use it; Imath's M44f multiplies row vectors, so
    /// its 16 floats in file order are this matrix's `to_cols_array()`.
    pub fn world_to_camera(&self) -> Mat4 {
        Mat4::from(self.camera_from_world)
    }

    /// World-to-NDC matrix (column vectors): for a world point `p` and
    /// `h = M * (p, 1)`, `(h.x / h.w, h.y / h.w)` is where `p` lands on the
    /// rendered image, 0 to 1 from its left to its right edge and from its
    /// TOP to its bottom edge (film position / resolution, through the same
    /// conformed and offset aperture as [`Camera::generate_ray`]).
    /// Perspective: `h.w` is the camera-space depth and `h.z = 1` (so
    /// `h.z / h.w` is inverse depth); orthographic: `h.w = 1` and `h.z` is
    /// the depth. The z row only keeps the matrix invertible. OpenEXR's
    /// `worldToNDC` attribute as RenderMan writes it and Nuke reads it
    /// (file order: `to_cols_array()`, as for [`Camera::world_to_camera`]).
    pub fn world_to_ndc(&self) -> Mat4 {
        let (top_left, extent) = self.window.corner_and_extent();
        // NDC = (plane - top_left) / extent, with plane the point's position
        // on the window's plane: (x, y) / -z for perspective, (x, y) for
        // orthographic; multiplied through by -z for perspective.
        let (scale, corner) = (extent.recip(), top_left / extent);
        let x = Vec4::new(scale.x, 0.0, 0.0, 0.0);
        let y = Vec4::new(0.0, scale.y, 0.0, 0.0);
        let ndc_from_camera = match self.projection {
            Projection::Pinhole | Projection::ThinLens(_) => {
                Mat4::from_cols(x, y, Vec4::new(corner.x, corner.y, 0.0, -1.0), Vec4::Z)
            }
            Projection::Orthographic => {
                Mat4::from_cols(x, y, Vec4::NEG_Z, Vec4::new(-corner.x, -corner.y, 0.0, 1.0))
            }
        };
        ndc_from_camera * self.world_to_camera()
    }

    /// The camera of `record` for an image of `raster`'s pixels; refuses
    /// attributes that cannot make rays (non-finite or non-positive focal
    /// length or apertures, near >= far, a singular transform, ...).
    pub fn new(record: &scene::Camera, raster: Raster) -> Result<Self, CameraError> {
        let invalid = |message: String| CameraError::Invalid {
            path: record.path.clone().unwrap_or_else(|| DEFAULT_CAMERA.into()),
            message,
        };
        validate(record, raster).map_err(invalid)?;
        let world_from_camera = scene::affine(&record.transform);
        let determinant = world_from_camera.matrix3.determinant();
        if !determinant.is_normal() {
            return Err(invalid(format!(
                "the world-from-camera transform is singular (determinant {determinant})"
            )));
        }
        let aperture = Vec2::new(record.horizontal_aperture, record.vertical_aperture);
        let offset = Vec2::new(
            record.horizontal_aperture_offset,
            record.vertical_aperture_offset,
        );
        let (projection, plane_units) = match record.projection {
            scene::Projection::Perspective => (perspective(record), record.focal_length),
            scene::Projection::Orthographic => {
                warn_ignored_lens(record, "an orthographic camera");
                (Projection::Orthographic, TENTHS_PER_UNIT)
            }
        };
        let [near, far] = record.clipping_range;
        let camera = Self {
            world_from_camera,
            camera_from_world: world_from_camera.inverse(),
            window: FilmWindow::new(aperture, offset, raster, plane_units),
            pixel_aspect: raster.pixel_aspect,
            projection,
            near: if near > NEAR_PLANE_MIN_FRACTION * far {
                near
            } else {
                0.0
            },
            far,
            shutter: Shutter::CLOSED,
            motion: motion::track(record).map_err(invalid)?,
            exposure_scale: record.exposure_scale,
        };
        Ok(camera.with_shutter(motion::shutter(record).map_err(invalid)?))
    }
}

/// USD's lens and filmback attributes are in tenths of a scene unit.
const TENTHS_PER_UNIT: f32 = 10.0;

/// What a camera without a prim path is called in messages.
const DEFAULT_CAMERA: &str = "default camera";

/// A pinhole, or a thin lens when `fStop` and `focusDistance` are both set.
fn perspective(record: &scene::Camera) -> Projection {
    if record.f_stop > 0.0 && record.focus_distance > 0.0 {
        Projection::ThinLens(ThinLens {
            radius: record.focal_length / TENTHS_PER_UNIT / (2.0 * record.f_stop),
            focus_distance: record.focus_distance,
        })
    } else {
        if record.f_stop > 0.0 {
            warn_ignored_lens(record, "a focusDistance of 0");
        }
        Projection::Pinhole
    }
}

/// Warns that `fStop` is set but depth of field is off because of `why`.
fn warn_ignored_lens(record: &scene::Camera, why: &str) {
    if record.f_stop > 0.0 {
        let path = describe(record.path.as_deref().unwrap_or(DEFAULT_CAMERA));
        log::warn!("{path}: fStop {} ignored with {why}", record.f_stop);
    }
}

/// "camera /path", or the default camera's name as it is.
fn describe(path: &str) -> String {
    if path == DEFAULT_CAMERA {
        path.to_owned()
    } else {
        format!("camera {path}")
    }
}

#[cfg(test)]
mod tests {
    use std::f32::consts::FRAC_PI_2;

    use glam::{Mat4, Quat, UVec2};

    use super::*;
    use crate::sampling::Pcg32;

    const IDENTITY: scene::Transform = [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0.];

    /// A 36 x 24 filmback with a 50 focal length, pinhole, at the origin.
    fn record() -> scene::Camera {
        scene::Camera {
            path: Some("/World/cam".into()),
            transform: IDENTITY,
            projection: scene::Projection::Perspective,
            focal_length: 50.0,
            horizontal_aperture: 36.0,
            vertical_aperture: 24.0,
            horizontal_aperture_offset: 0.0,
            vertical_aperture_offset: 0.0,
            clipping_range: [1.0, 1e6],
            f_stop: 0.0,
            focus_distance: 0.0,
            exposure_scale: 1.0,
            shutter: None,
            motion: None,
        }
    }

    /// An affine map as the format's 3x4 row-major array.
    fn transform(m: Affine3A) -> scene::Transform {
        let rows = Mat4::from(m).transpose().to_cols_array();
        rows[..12].try_into().unwrap()
    }

    fn camera(record: &scene::Camera, resolution: UVec2) -> Camera {
        Camera::new(record, Raster::square(resolution)).unwrap()
    }

    fn angle_to(direction: Vec3, axis: Vec3) -> f32 {
        direction.dot(axis).clamp(-1.0, 1.0).acos()
    }

    fn assert_close(a: Vec3, b: Vec3, tolerance: f32) {
        assert!((a - b).length() <= tolerance, "{a} vs {b}");
    }

    #[test]
    fn centre_ray_of_identity_camera_looks_down_minus_z() {
        let ray = camera(&record(), UVec2::new(300, 200)).generate_ray(
            Vec2::new(150., 100.),
            Vec2::ZERO,
            0.0,
        );
        assert_eq!(ray.origin, Vec3::ZERO);
        assert_close(ray.direction, Vec3::NEG_Z, 1e-6);
        // The fallback clipping range 1..1e6 is "tiny": rays start at the eye.
        assert_eq!(ray.t_min, 0.0);
        assert!((ray.t_max - 1e6).abs() < 1.0);
    }

    #[test]
    fn rays_follow_a_rotated_translated_scaled_transform() {
        let rotation = Quat::from_rotation_y(FRAC_PI_2) * Quat::from_rotation_x(0.3);
        let translation = Vec3::new(1.0, -2.0, 3.0);
        for scale in [1.0, 2.5] {
            let m = Affine3A::from_scale_rotation_translation(
                Vec3::splat(scale),
                rotation,
                translation,
            );
            let mut r = record();
            r.transform = transform(m);
            r.clipping_range = [5.0, 100.0];
            let cam = camera(&r, UVec2::new(300, 200));
            for film in [
                Vec2::new(150., 100.),
                Vec2::new(0., 0.),
                Vec2::new(300., 37.),
            ] {
                let ray = cam.generate_ray(film, Vec2::ZERO, 0.0);
                let local =
                    camera(&record(), UVec2::new(300, 200)).generate_ray(film, Vec2::ZERO, 0.0);
                assert_close(ray.origin, translation, 1e-5);
                assert_close(ray.direction, rotation * local.direction, 1e-5);
                assert!((ray.direction.length() - 1.0).abs() < 1e-6);
                // The clipping planes are camera-space depths 5 and 100.
                let depth = |t: f32| {
                    m.inverse()
                        .transform_point3(ray.origin + t * ray.direction)
                        .z
                };
                assert!(
                    (depth(ray.t_min) + 5.0).abs() < 1e-4,
                    "{}",
                    depth(ray.t_min)
                );
                assert!(
                    (depth(ray.t_max) + 100.0).abs() < 1e-3,
                    "{}",
                    depth(ray.t_max)
                );
            }
        }
    }

    #[test]
    fn edge_and_corner_rays_make_the_half_fov_angles() {
        // Aperture aspect 36:24 = image aspect 300:200: no conforming.
        let cam = camera(&record(), UVec2::new(300, 200));
        let half_h = (18.0f32 / 50.0).atan();
        let half_v = (12.0f32 / 50.0).atan();
        let half_d = (18.0f32.hypot(12.0) / 50.0).atan();
        let cases = [
            (Vec2::new(0., 100.), half_h, Vec3::new(-1., 0., 0.)),
            (Vec2::new(300., 100.), half_h, Vec3::new(1., 0., 0.)),
            (Vec2::new(150., 0.), half_v, Vec3::new(0., 1., 0.)),
            (Vec2::new(150., 200.), half_v, Vec3::new(0., -1., 0.)),
            (Vec2::new(0., 0.), half_d, Vec3::new(-18., 12., 0.)),
            (Vec2::new(300., 200.), half_d, Vec3::new(18., -12., 0.)),
        ];
        for (film, angle, side) in cases {
            let d = cam.generate_ray(film, Vec2::ZERO, 0.0).direction;
            assert!((angle_to(d, Vec3::NEG_Z) - angle).abs() < 1e-5, "{film}");
            // The ray leans towards the expected side of the image.
            assert_close(d.truncate().normalize().extend(0.0), side.normalize(), 1e-5);
        }
    }

    #[test]
    fn expand_aperture_widens_for_wide_images_and_heightens_for_tall_ones() {
        let half_angles = |resolution: UVec2| {
            let cam = camera(&record(), resolution);
            let r = resolution.as_vec2();
            let h = cam
                .generate_ray(Vec2::new(r.x, r.y / 2.0), Vec2::ZERO, 0.0)
                .direction;
            let v = cam
                .generate_ray(Vec2::new(r.x / 2.0, 0.0), Vec2::ZERO, 0.0)
                .direction;
            (angle_to(h, Vec3::NEG_Z), angle_to(v, Vec3::NEG_Z))
        };
        // 4:1 image: the height (24) stays, the width grows to 96.
        let (h, v) = half_angles(UVec2::new(400, 100));
        assert!(
            (h - (48.0f32 / 50.0).atan()).abs() < 1e-5
                && (v - (12.0f32 / 50.0).atan()).abs() < 1e-5
        );
        // 1:2 image: the width (36) stays, the height grows to 72.
        let (h, v) = half_angles(UVec2::new(100, 200));
        assert!(
            (h - (18.0f32 / 50.0).atan()).abs() < 1e-5
                && (v - (36.0f32 / 50.0).atan()).abs() < 1e-5
        );
    }

    #[test]
    fn aperture_offset_shifts_the_centre_ray() {
        let mut r = record();
        r.horizontal_aperture_offset = 5.0;
        r.vertical_aperture_offset = -3.0;
        let d = camera(&r, UVec2::new(300, 200))
            .generate_ray(Vec2::new(150., 100.), Vec2::ZERO, 0.0)
            .direction;
        assert_close(d, Vec3::new(5.0, -3.0, -50.0).normalize(), 1e-6);
        assert!((angle_to(d, Vec3::NEG_Z) - (5.0f32.hypot(3.0) / 50.0).atan()).abs() < 1e-5);
    }

    #[test]
    fn orthographic_rays_are_parallel_over_the_aperture_in_scene_units() {
        let mut r = record();
        r.projection = scene::Projection::Orthographic;
        r.horizontal_aperture = 40.0;
        r.vertical_aperture = 20.0;
        r.horizontal_aperture_offset = 10.0;
        r.clipping_range = [2.0, 50.0];
        let cam = camera(&r, UVec2::new(200, 100));
        // The view is 4 x 2 scene units centred at x = 1.
        let cases = [
            (Vec2::new(0., 0.), Vec3::new(-1., 1., 0.)),
            (Vec2::new(200., 100.), Vec3::new(3., -1., 0.)),
            (Vec2::new(100., 50.), Vec3::new(1., 0., 0.)),
            (Vec2::new(50., 75.), Vec3::new(0., -0.5, 0.)),
        ];
        for (film, origin) in cases {
            let ray = cam.generate_ray(film, Vec2::new(0.3, 0.9), 0.0);
            assert_close(ray.origin, origin, 1e-5);
            assert_eq!(ray.direction, Vec3::NEG_Z);
            assert!((ray.t_min - 2.0).abs() < 1e-6 && (ray.t_max - 50.0).abs() < 1e-5);
        }
    }

    #[test]
    fn thin_lens_rays_meet_on_the_plane_of_focus() {
        let m = Affine3A::from_rotation_translation(
            Quat::from_rotation_z(0.4) * Quat::from_rotation_x(-0.7),
            Vec3::new(3.0, 1.0, -2.0),
        );
        let mut r = record();
        r.transform = transform(m);
        r.f_stop = 2.0;
        r.focus_distance = 10.0;
        // focalLength 50 tenths = 5 scene units; radius 5 / (2 * 2).
        let radius = 1.25;
        let cam = camera(&r, UVec2::new(300, 200));
        let eye = Vec3::from(m.translation);
        let axis = m.transform_vector3(Vec3::NEG_Z);
        let mut pinhole = r.clone();
        pinhole.f_stop = 0.0;
        let pinhole = camera(&pinhole, UVec2::new(300, 200));
        let mut rng = Pcg32::new(9, 0);
        for film in [
            Vec2::new(150., 100.),
            Vec2::new(3., 190.),
            Vec2::new(280.5, 12.25),
        ] {
            // Where the pinhole ray crosses the plane of focus.
            let sharp = pinhole.generate_ray(film, Vec2::ZERO, 0.0);
            let target = sharp.origin + sharp.direction * (10.0 / sharp.direction.dot(axis));
            let mut widest = 0.0f32;
            let edge = [Vec2::new(0.999_999, 0.5), Vec2::new(0.5, 0.0)];
            let random = (0..16).map(|_| Vec2::new(rng.next_f32(), rng.next_f32()));
            for u in edge.into_iter().chain(random) {
                let ray = cam.generate_ray(film, u, 0.0);
                let offset = ray.origin - eye;
                assert!(offset.dot(axis).abs() < 1e-5, "origin off the lens plane");
                assert!(offset.length() <= radius * (1.0 + 1e-5));
                widest = widest.max(offset.length());
                let t = (10.0 - offset.dot(axis)) / ray.direction.dot(axis);
                let hit = ray.origin + t * ray.direction;
                assert!(
                    (hit - target).length() <= 1e-4 * (target - eye).length(),
                    "{hit} vs {target}"
                );
            }
            assert!(widest > 0.999 * radius, "the lens edge is never sampled");
        }
    }

    #[test]
    fn pinhole_ignores_u_lens() {
        let mut no_focus = record();
        no_focus.f_stop = 2.0;
        for r in [record(), no_focus] {
            let cam = camera(&r, UVec2::new(64, 64));
            let a = cam.generate_ray(Vec2::new(10.5, 40.5), Vec2::new(0.1, 0.2), 0.0);
            let b = cam.generate_ray(Vec2::new(10.5, 40.5), Vec2::new(0.9, 0.7), 0.0);
            assert_eq!((a.origin, a.direction), (b.origin, b.direction));
        }
    }

    #[test]
    fn a_significant_near_plane_clips_at_its_depth_on_every_ray() {
        let mut r = record();
        r.clipping_range = [5.0, 100.0];
        r.f_stop = 1.4;
        r.focus_distance = 20.0;
        let cam = camera(&r, UVec2::new(300, 200));
        for (film, u) in [
            (Vec2::new(150., 100.), Vec2::new(0.5, 0.5)),
            (Vec2::new(0., 0.), Vec2::new(0.1, 0.8)),
        ] {
            let ray = cam.generate_ray(film, u, 0.0);
            assert!(((ray.origin + ray.t_min * ray.direction).z + 5.0).abs() < 1e-5);
            assert!(((ray.origin + ray.t_max * ray.direction).z + 100.0).abs() < 1e-4);
        }
    }

    #[test]
    fn invalid_records_are_refused_naming_the_camera() {
        let broken: [fn(&mut scene::Camera); 9] = [
            |r| r.focal_length = 0.0,
            |r| r.focal_length = f32::NAN,
            |r| r.horizontal_aperture = -1.0,
            |r| r.vertical_aperture = f32::INFINITY,
            |r| r.vertical_aperture_offset = f32::NAN,
            |r| r.clipping_range = [10.0, 10.0],
            |r| r.f_stop = -2.0,
            |r| r.focus_distance = f32::NAN,
            |r| r.transform[0] = 0.0,
        ];
        for (i, breaks) in broken.iter().enumerate() {
            let mut r = record();
            breaks(&mut r);
            let message = Camera::new(&r, Raster::square(UVec2::new(8, 8)))
                .unwrap_err()
                .to_string();
            assert!(
                message.starts_with("camera /World/cam: "),
                "case {i}: {message}"
            );
            r.path = None;
            let message = Camera::new(&r, Raster::square(UVec2::new(8, 8)))
                .unwrap_err()
                .to_string();
            assert!(
                message.starts_with("default camera: "),
                "case {i}: {message}"
            );
        }
        let message = Camera::new(&record(), Raster::square(UVec2::new(0, 8)))
            .unwrap_err()
            .to_string();
        assert!(message.contains("resolution"), "{message}");
        let flat = Raster {
            pixel_aspect: 0.0,
            ..Raster::square(UVec2::new(8, 8))
        };
        let message = Camera::new(&record(), flat).unwrap_err().to_string();
        assert!(message.contains("pixelAspectRatio"), "{message}");
        // An orthographic camera does not use its focal length.
        let mut ortho = record();
        ortho.projection = scene::Projection::Orthographic;
        ortho.focal_length = 0.0;
        assert!(Camera::new(&ortho, Raster::square(UVec2::new(8, 8))).is_ok());
    }

    /// A rotated, translated and scaled world-from-camera transform.
    fn moved() -> Affine3A {
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(1.7),
            Quat::from_rotation_z(0.4) * Quat::from_rotation_x(-0.7),
            Vec3::new(3.0, 1.0, -2.0),
        )
    }

    #[test]
    fn world_to_ndc_projects_ray_points_back_to_their_film_position() {
        let mut rng = Pcg32::new(10, 0);
        let perspective = |offset: Vec2, f_stop: f32| {
            let mut r = record();
            r.transform = transform(moved());
            r.horizontal_aperture_offset = offset.x;
            r.vertical_aperture_offset = offset.y;
            r.f_stop = f_stop;
            r.focus_distance = 7.0;
            r
        };
        let mut ortho = perspective(Vec2::new(10.0, -4.0), 0.0);
        ortho.projection = scene::Projection::Orthographic;
        let cases = [
            (perspective(Vec2::ZERO, 0.0), "perspective"),
            (perspective(Vec2::new(5.0, -3.0), 0.0), "offset perspective"),
            (perspective(Vec2::new(-2.0, 6.0), 2.0), "offset thin lens"),
            (ortho, "offset orthographic"),
        ];
        // 300 x 200 matches the 36 x 24 aperture; the others conform it.
        let resolutions = [
            UVec2::new(300, 200),
            UVec2::new(400, 100),
            UVec2::new(100, 200),
        ];
        for (r, name) in cases {
            for resolution in resolutions {
                let cam = camera(&r, resolution);
                let m = cam.world_to_ndc();
                for _ in 0..200 {
                    let film = Vec2::new(rng.next_f32(), rng.next_f32()) * resolution.as_vec2();
                    let u_lens = Vec2::new(rng.next_f32(), rng.next_f32());
                    let ray = cam.generate_ray(film, u_lens, 0.0);
                    // Any point of a pinhole or orthographic ray; the point
                    // on the plane of focus of a thin-lens ray.
                    let t = if r.f_stop > 0.0 {
                        let depth_0 = cam.depth(ray.origin);
                        let per_t = cam.depth(ray.origin + ray.direction) - depth_0;
                        (r.focus_distance - depth_0) / per_t
                    } else {
                        0.1 + 50.0 * rng.next_f32()
                    };
                    let p = ray.origin + t * ray.direction;
                    let h = m * p.extend(1.0);
                    let ndc = Vec2::new(h.x, h.y) / h.w;
                    let expected = film / resolution.as_vec2();
                    assert!(
                        (ndc - expected).abs().max_element() < 1e-4,
                        "{name} {resolution}: {ndc} vs {expected}"
                    );
                    let w = if r.projection == scene::Projection::Orthographic {
                        1.0
                    } else {
                        cam.depth(p)
                    };
                    assert!((h.w - w).abs() <= 1e-5 * w, "{name}: w {} vs {w}", h.w);
                }
                assert!(m.determinant().is_normal(), "{name}: singular");
            }
        }
    }

    #[test]
    fn world_to_camera_inverts_the_camera_transform() {
        let mut r = record();
        r.transform = transform(moved());
        let cam = camera(&r, UVec2::new(30, 20));
        let m = cam.world_to_camera() * Mat4::from(moved());
        assert!(
            m.abs_diff_eq(Mat4::IDENTITY, 1e-5),
            "world_to_camera * world_from_camera = {m}"
        );
        // The eye maps to the origin and the view direction to -Z.
        let eye = Vec3::from(moved().translation);
        let ahead = eye + moved().transform_vector3(Vec3::NEG_Z);
        assert_close(
            cam.world_to_camera().transform_point3(eye),
            Vec3::ZERO,
            1e-5,
        );
        assert_close(
            cam.world_to_camera().transform_point3(ahead),
            Vec3::NEG_Z,
            1e-5,
        );
    }

    #[test]
    fn depth_is_the_distance_along_the_view_axis() {
        let m = Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.8) * Quat::from_rotation_x(0.3),
            Vec3::new(-1.0, 4.0, 2.0),
        );
        let mut r = record();
        r.transform = transform(m);
        for projection in [
            scene::Projection::Perspective,
            scene::Projection::Orthographic,
        ] {
            r.projection = projection;
            let cam = camera(&r, UVec2::new(64, 48));
            let eye = Vec3::from(m.translation);
            let (right, up, ahead) = (
                m.transform_vector3(Vec3::X),
                m.transform_vector3(Vec3::Y),
                m.transform_vector3(Vec3::NEG_Z),
            );
            for d in [0.5f32, 3.0, 40.0] {
                let centre = eye + d * ahead;
                assert!((cam.depth(centre) - d).abs() < 1e-5 * d.max(1.0));
                for (a, b) in [(1.0, 0.0), (-2.5, 3.0), (7.0, -0.2)] {
                    let off_axis = centre + a * right + b * up;
                    assert!((cam.depth(off_axis) - d).abs() < 1e-4 * d.max(1.0));
                }
                assert!((cam.depth(eye - d * ahead) + d).abs() < 1e-4 * d.max(1.0));
            }
        }
    }
}
