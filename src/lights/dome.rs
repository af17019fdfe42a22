//! `DomeLight`: radiance from infinitely far away in every direction,
//! constant or from an image importance-sampled through a piecewise-constant
//! 2D distribution over its texels (pbrt-v4's `ImageInfiniteLight`), each
//! texel weighted by its luminance times the solid angle per unit image area
//! at its centre, so the density over directions is the distribution's
//! density over the image divided by that Jacobian.
//!
//! Mappings (UsdLux DomeLight `inputs:texture:format`), in the light's space
//! with image u in [0, 1) from the left edge and v in [0, 1) from the top:
//!
//! - `latlong` (the OpenEXR lat-long convention UsdLuxDomeLight names): +Y
//!   is the pole; column u is longitude pi (1 - 2u), row v is latitude
//!   pi (1/2 - v), and a direction at latitude lat and longitude lon is
//!   (cos lat sin lon, sin lat, cos lat cos lon): the image centre looks down
//!   +Z, a quarter to its left (u = 1/4) looks down +X. OpenEXR puts the
//!   first and last pixel centres exactly on the +-pi seam; we let pixels
//!   cover equal [i/w, (i+1)/w) cells, half a pixel apart from that.
//!   Jacobian d(omega)/d(u v) = 2 pi^2 sin(theta), theta from the pole.
//! - `angular` and `mirroredBall`: the image's inscribed disk, a = 2u - 1
//!   to the right, b = 1 - 2v up, r = |(a, b)| <= 1; its centre looks down +Z
//!   and, as in the lat-long image around its centre, its left is +X and its
//!   top +Y: the direction at angle theta from +Z is (-a sin theta / r,
//!   b sin theta / r, cos theta). `angular` (Debevec's light-probe angular
//!   map): r = theta / pi, Jacobian 4 pi^2 sin(theta) / theta. `mirroredBall`
//!   (a mirrored sphere seen from far away along -Z, which reflects the
//!   direction at theta from +Z at r = sin(theta / 2)): Jacobian 16, uniform.
//!   Texels outside the disk are never looked up.

use std::f32::consts::PI;

use glam::{Mat3, Vec2, Vec3};

use super::emission::emission;
use super::image::LightImage;
use super::{world_from_light, LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::sampling::warp::square_to_uniform_sphere;
use crate::sampling::Distribution2D;
use crate::scene::{DomeFormat, Light as LightRecord};

/// A dome light: the rotation part of its transform and its radiance.
#[derive(Clone, Debug)]
pub(crate) struct DomeLight {
    /// World-from-light rotation (orthonormal; scale is meaningless at infinity).
    world_from_light: Mat3,
    /// Radiance scale: the emission, times the texel where there is an image.
    radiance: Vec3,
    /// The image and its importance map.
    map: Option<EnvironmentMap>,
}

/// An environment image in one of the [`DomeFormat`] mappings, with its
/// sampling distribution.
#[derive(Clone, Debug)]
struct EnvironmentMap {
    image: LightImage,
    format: DomeFormat,
    /// Over (u, v), proportional to texel luminance x the mapping's
    /// relative Jacobian ([`relative_jacobian`]) at the texel centre.
    distribution: Distribution2D,
}

impl DomeLight {
    /// A direction towards the dome: uniform over the sphere when constant,
    /// else by the importance map, pdf = pdf_uv / Jacobian.
    pub fn sample(&self, u: Vec2) -> Option<LightSample> {
        let (wi, radiance, pdf) = match &self.map {
            None => (
                self.world_from_light * square_to_uniform_sphere(u),
                self.radiance,
                1.0 / (4.0 * PI),
            ),
            Some(map) => {
                let (uv, pdf_uv) = map.distribution.sample(u);
                let local = direction(map.format, uv)?;
                let jacobian = relative_jacobian(map.format, uv_angle(map.format, uv));
                if jacobian == 0.0 || pdf_uv == 0.0 {
                    return None;
                }
                let pdf = pdf_uv / (jacobian_scale(map.format) * jacobian);
                (
                    self.world_from_light * local,
                    self.radiance * map.image.texel(uv),
                    pdf,
                )
            }
        };
        Some(LightSample {
            radiance,
            wi: wi.normalize(),
            distance: f32::INFINITY,
            pdf,
            delta: false,
        })
    }

    /// The radiance a ray escaping along unit `direction` sees, and the
    /// density [`Self::sample`] gives that direction.
    pub fn escaped(&self, direction: Vec3) -> LightHit {
        let (radiance, pdf) = match &self.map {
            None => (self.radiance, 1.0 / (4.0 * PI)),
            Some(map) => {
                let local = self.world_from_light.transpose() * direction;
                let uv = image_uv(map.format, local);
                let jacobian = relative_jacobian(map.format, direction_angle(map.format, local));
                let pdf = if jacobian == 0.0 {
                    0.0
                } else {
                    map.distribution.pdf(uv) / (jacobian_scale(map.format) * jacobian)
                };
                (self.radiance * map.image.texel(uv), pdf)
            }
        };
        LightHit {
            t: f32::INFINITY,
            radiance,
            pdf,
        }
    }

    /// Whether the dome is one colour everywhere (no image): light sampling
    /// gains nothing over BSDF and phase sampling there (see `select.rs`).
    pub fn is_constant(&self) -> bool {
        self.map.is_none()
    }

    /// Luminance of the power through a disk of radius `scene_radius`
    /// (pbrt-v4's `ImageInfiniteLight::Phi`): 4 pi x pi r^2 x mean radiance
    /// over the sphere.
    pub fn power(&self, scene_radius: f32) -> f32 {
        let mean = self.map.as_ref().map_or(1.0, EnvironmentMap::mean_radiance);
        4.0 * PI * PI * scene_radius * scene_radius * luminance(self.radiance) * mean
    }

    /// From the record: the transform's rotation (axes orthonormalised, a
    /// mirror kept), the emission as radiance scale, and the texture in
    /// `format` (a missing or unreadable file warns and leaves the dome
    /// constant; an image whose aspect is not the format's is warned about
    /// and mapped as the format says).
    pub fn from_record(
        record: &LightRecord,
        texture: Option<&std::path::Path>,
        format: DomeFormat,
    ) -> Result<Self, LightError> {
        let (linear, _) = world_from_light(record)?;
        let x = linear.x_axis.normalize_or_zero();
        let y = (linear.y_axis - x * x.dot(linear.y_axis)).normalize_or_zero();
        let mut z = x.cross(y);
        if linear.determinant() < 0.0 {
            z = -z;
        }
        if z == Vec3::ZERO {
            return Err(LightError::invalid(
                record,
                "transform has no rotation (zero scale)",
            ));
        }
        let map = texture.and_then(|path| {
            let image = LightImage::load(path, &record.path)?;
            warn_of_aspect(&image, format, &record.path, path);
            Some(EnvironmentMap::new(image, format))
        });
        Ok(Self {
            world_from_light: Mat3::from_cols(x, y, z),
            radiance: emission(record)?,
            map,
        })
    }
}

/// Warns, naming the light and file, when `image` is not square under a
/// disk mapping (lat-long images of any aspect are read silently, as before).
fn warn_of_aspect(image: &LightImage, format: DomeFormat, light: &str, path: &std::path::Path) {
    let (w, h) = (image.width, image.height);
    let token = match format {
        DomeFormat::Latlong => return,
        DomeFormat::Angular => "angular",
        DomeFormat::MirroredBall => "mirroredBall",
    };
    if w != h {
        log::warn!(
            "light {light}: texture {} is {w}x{h}, not square ({token}) as its \
             texture:format says; its inscribed ellipse is mapped as the disk",
            path.display()
        );
    }
}

impl EnvironmentMap {
    fn new(image: LightImage, format: DomeFormat) -> Self {
        let (w, h) = (image.width, image.height);
        let weights: Vec<f32> = image
            .texels
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                luminance(t) * relative_jacobian(format, texel_angle(format, i % w, i / w, w, h))
            })
            .collect();
        Self {
            distribution: Distribution2D::new(&weights, w, h),
            image,
            format,
        }
    }

    /// Mean radiance luminance over the sphere: each texel's luminance times
    /// its solid angle, over 4 pi (lat-long rows exactly, the disk
    /// mappings by the Jacobian at each texel centre).
    fn mean_radiance(&self) -> f32 {
        let (w, h) = (self.image.width, self.image.height);
        let mut sum = 0.0f64;
        for row in 0..h {
            let lum = |x: usize| f64::from(luminance(self.image.texels[row * w + x]));
            if self.format == DomeFormat::Latlong {
                // Solid angle of each texel in this row.
                let top = (PI * row as f32 / h as f32).cos();
                let bottom = (PI * (row + 1) as f32 / h as f32).cos();
                let texel_sr = f64::from(2.0 * PI / w as f32 * (top - bottom));
                sum += (0..w).map(lum).sum::<f64>() * texel_sr;
                continue;
            }
            for x in 0..w {
                let jacobian = jacobian_scale(self.format)
                    * relative_jacobian(self.format, texel_angle(self.format, x, row, w, h));
                sum += lum(x) * f64::from(jacobian) / (w * h) as f64;
            }
        }
        (sum / (4.0 * std::f64::consts::PI)) as f32
    }
}

/// The constant factor of a mapping's Jacobian d(omega)/d(u v) (see the
/// module doc): 2 pi^2 lat-long, 4 pi^2 angular, 16 mirrored ball.
fn jacobian_scale(format: DomeFormat) -> f32 {
    match format {
        DomeFormat::Latlong => 2.0 * PI * PI,
        DomeFormat::Angular => 4.0 * PI * PI,
        DomeFormat::MirroredBall => 16.0,
    }
}

/// The varying factor of a mapping's Jacobian, from the sine and angle
/// `(sin theta, theta)` of the direction ([`uv_angle`], [`direction_angle`];
/// theta from +Y for lat-long, from +Z for the disks): sin theta lat-long,
/// sin theta / theta angular (1 at theta = 0), 1 mirrored ball; 0 where
/// the image holds no direction.
fn relative_jacobian(format: DomeFormat, (sin_theta, theta): (f32, f32)) -> f32 {
    match format {
        DomeFormat::Latlong => sin_theta,
        DomeFormat::Angular if theta > 1e-6 => sin_theta / theta,
        DomeFormat::Angular => 1.0,
        DomeFormat::MirroredBall => 1.0,
    }
}

/// `(sin theta, theta)` at image point `uv` (inside the disk for the disk
/// mappings: `direction` is `Some` there).
fn uv_angle(format: DomeFormat, uv: Vec2) -> (f32, f32) {
    let theta = match format {
        DomeFormat::Latlong => PI * uv.y,
        _ => disk_angle(format, disk_radius(uv)),
    };
    (theta.sin(), theta)
}

/// [`uv_angle`] at the centre of texel `(x, y)` of a `w` x `h` image,
/// clamped into the disk for the disk mappings, so texels the disk's edge
/// crosses keep a positive weight.
fn texel_angle(format: DomeFormat, x: usize, y: usize, w: usize, h: usize) -> (f32, f32) {
    let theta = if format == DomeFormat::Latlong {
        PI * (y as f32 + 0.5) / h as f32
    } else {
        let centre = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
        disk_angle(format, disk_radius(centre).min(1.0))
    };
    (theta.sin(), theta)
}

/// `(sin theta, theta)` of a light-space unit direction (not sqrt(1 - c^2):
/// that cancels near the poles).
fn direction_angle(format: DomeFormat, d: Vec3) -> (f32, f32) {
    let (sin_theta, cos_theta) = match format {
        DomeFormat::Latlong => (d.x.hypot(d.z), d.y),
        _ => (d.x.hypot(d.y), d.z),
    };
    (sin_theta, sin_theta.atan2(cos_theta))
}

/// Distance of `uv` from the image centre in disk units (1 at the
/// inscribed circle).
fn disk_radius(uv: Vec2) -> f32 {
    (2.0 * uv.x - 1.0).hypot(1.0 - 2.0 * uv.y)
}

/// The angle from +Z at disk radius `r` (NaN beyond 1).
fn disk_angle(format: DomeFormat, r: f32) -> f32 {
    if r > 1.0 {
        return f32::NAN;
    }
    match format {
        DomeFormat::MirroredBall => 2.0 * r.asin(),
        _ => PI * r,
    }
}

/// Light-space unit direction of image coordinates `uv` (see the module
/// doc); `None` outside the disk of the disk mappings.
fn direction(format: DomeFormat, uv: Vec2) -> Option<Vec3> {
    if format == DomeFormat::Latlong {
        let lon = PI * (1.0 - 2.0 * uv.x);
        let theta = PI * uv.y;
        let (sin_t, cos_t) = theta.sin_cos();
        return Some(Vec3::new(sin_t * lon.sin(), cos_t, sin_t * lon.cos()));
    }
    let (a, b) = (2.0 * uv.x - 1.0, 1.0 - 2.0 * uv.y);
    let r = a.hypot(b);
    let theta = disk_angle(format, r);
    if theta.is_nan() {
        return None;
    }
    if r == 0.0 {
        return Some(Vec3::Z);
    }
    let (sin_t, cos_t) = theta.sin_cos();
    Some(Vec3::new(-a / r * sin_t, b / r * sin_t, cos_t))
}

/// Image coordinates in [0, 1)^2 of a light-space unit direction.
fn image_uv(format: DomeFormat, d: Vec3) -> Vec2 {
    if format == DomeFormat::Latlong {
        let lon = d.x.atan2(d.z);
        let u = 0.5 * (1.0 - lon / PI);
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        return Vec2::new(
            if u >= 1.0 { 0.0 } else { u },
            v.min(1.0 - f32::EPSILON / 2.0),
        );
    }
    let (sin_theta, theta) = direction_angle(format, d);
    let r = match format {
        DomeFormat::MirroredBall => (0.5 * theta).sin(),
        _ => theta / PI,
    };
    // The unit vector towards (-x, y) in the disk, +a where x is 0 and y is 0.
    let (a, b) = if sin_theta > 0.0 {
        (-d.x / sin_theta * r, d.y / sin_theta * r)
    } else {
        (r, 0.0)
    };
    let top = 1.0 - f32::EPSILON / 2.0;
    Vec2::new(
        (0.5 * (a + 1.0)).clamp(0.0, top),
        (0.5 * (1.0 - b)).clamp(0.0, top),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{
        assert_escape_consistent, assert_within_4_sigma, estimate, record,
    };
    use crate::scene::LightShape;

    fn dome_shape() -> LightShape {
        LightShape::Dome {
            texture: None,
            texture_format: DomeFormat::Latlong,
        }
    }

    fn constant() -> DomeLight {
        let r = record(dome_shape(), false, 1.5);
        DomeLight::from_record(&r, None, DomeFormat::Latlong).unwrap()
    }

    /// A 16 x 8 map (16 x 16 for the disk mappings, black beyond radius
    /// 0.85 so every lit texel lies inside the disk) with a bright patch and
    /// a dark band, rotated 90 degrees about X so the light's +Y is world +Z.
    fn textured(format: DomeFormat) -> DomeLight {
        let (w, h) = if format == DomeFormat::Latlong {
            (16, 8)
        } else {
            (16, 16)
        };
        let outside = |x: usize, y: usize| {
            let centre = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            format != DomeFormat::Latlong && disk_radius(centre) > 0.85
        };
        let texels = (0..w * h)
            .map(|i| match (i % w, i / w) {
                (x, y) if outside(x, y) => Vec3::ZERO,
                (3, 2) | (5, 4) => Vec3::new(40.0, 20.0, 10.0),
                (_, 6) => Vec3::ZERO,
                (x, _) => Vec3::splat(0.1 + x as f32 * 0.05),
            })
            .collect();
        let image = LightImage {
            width: w,
            height: h,
            texels,
        };
        let mut r = record(dome_shape(), false, 2.0);
        r.transform = [1., 0., 0., 5., 0., 0., -1., 0., 0., 1., 0., 0.];
        let mut dome = DomeLight::from_record(&r, None, DomeFormat::Latlong).unwrap();
        dome.map = Some(EnvironmentMap::new(image, format));
        dome
    }

    #[test]
    fn the_mapping_follows_openexr_lat_long() {
        assert!(
            (direction(DomeFormat::Latlong, Vec2::new(0.5, 0.5)).unwrap() - Vec3::Z).length()
                < 1e-6
        );
        assert!(
            (direction(DomeFormat::Latlong, Vec2::new(0.25, 0.5)).unwrap() - Vec3::X).length()
                < 1e-6
        );
        assert!(
            (direction(DomeFormat::Latlong, Vec2::new(0.3, 0.0)).unwrap() - Vec3::Y).length()
                < 1e-6
        );
        for uv in [
            Vec2::new(0.1, 0.3),
            Vec2::new(0.9, 0.7),
            Vec2::new(0.5, 0.05),
        ] {
            let d = direction(DomeFormat::Latlong, uv).unwrap();
            assert!((image_uv(DomeFormat::Latlong, d) - uv).length() < 1e-5);
        }
    }

    /// E = pi L on a surface facing up, estimated with the cosine.
    #[test]
    fn constant_dome_gives_pi_l() {
        let dome = constant();
        let e = estimate(20_000, 10, |u| {
            let s = dome.sample(u)?;
            Some(s.radiance.x * s.wi.z.max(0.0) / s.pdf)
        });
        assert_within_4_sigma(e, PI * 1.5, "constant dome");
    }

    #[test]
    fn samples_and_escaped_rays_agree() {
        let dome = textured(DomeFormat::Latlong);
        assert_escape_consistent(|u| dome.sample(u), |d| Some(dome.escaped(d)));
        let c = constant();
        assert_escape_consistent(|u| c.sample(u), |d| Some(c.escaped(d)));
    }

    /// The importance-sampled estimate of the radiance integrated over the
    /// sphere equals the exact sum of texel radiance x texel solid angle.
    #[test]
    fn importance_sampling_integrates_the_map() {
        let dome = textured(DomeFormat::Latlong);
        let map = dome.map.as_ref().unwrap();
        let exact = dome.power(1.0) / (4.0 * PI * PI) * 4.0 * PI;
        let e = estimate(20_000, 11, |u| {
            let s = dome.sample(u)?;
            Some(luminance(s.radiance) / s.pdf)
        });
        assert_within_4_sigma(e, exact, "textured dome");
        // The rotation puts the light's pole on world +Z.
        // Just off the pole towards world +X: row 0, longitude pi/2 (u = 1/4).
        let up = dome.escaped(Vec3::new(0.01, 0.0, 1.0).normalize());
        assert_eq!(up.radiance, 2.0 * map.image.texels[4]);
        // Zero texels are never sampled.
        for i in 0..1000 {
            let u = Vec2::new((i % 40) as f32 / 40.0, (i / 40) as f32 / 25.0);
            if let Some(s) = dome.sample(u) {
                assert!(s.radiance != Vec3::ZERO);
            }
        }
    }

    /// Angular and mirrored-ball maps: the centre looks down +Z, left +X,
    /// top +Y, and directions map back to where they came from; samples and
    /// escaped rays agree on the density; the importance-sampled integral of
    /// the radiance equals a fine midpoint sum of texel radiance x the
    /// mapping's Jacobian (64 points per texel).
    #[test]
    fn disk_mappings_sample_and_integrate_their_maps() {
        for format in [DomeFormat::Angular, DomeFormat::MirroredBall] {
            let at = |u: f32, v: f32| direction(format, Vec2::new(u, v)).unwrap();
            assert!((at(0.5, 0.5) - Vec3::Z).length() < 1e-6);
            let edge = if format == DomeFormat::Angular {
                0.25
            } else {
                0.5 - 0.5 * 0.5f32.sqrt()
            };
            assert!((at(edge, 0.5) - Vec3::X).length() < 1e-5, "{format:?}");
            assert!((at(0.5, edge) - Vec3::Y).length() < 1e-5, "{format:?}");
            assert!(direction(format, Vec2::new(0.02, 0.02)).is_none());
            for uv in [
                Vec2::new(0.1, 0.4),
                Vec2::new(0.8, 0.7),
                Vec2::new(0.5, 0.05),
            ] {
                assert!(
                    (image_uv(format, at(uv.x, uv.y)) - uv).length() < 1e-4,
                    "{format:?} {uv}"
                );
            }
            let dome = textured(format);
            assert_escape_consistent(|u| dome.sample(u), |d| Some(dome.escaped(d)));
            let map = dome.map.as_ref().unwrap();
            let (w, h, n) = (map.image.width, map.image.height, 8);
            let mut sum = 0.0f64;
            for (i, &t) in map.image.texels.iter().enumerate() {
                for k in 0..n * n {
                    let uv = Vec2::new(
                        ((i % w) as f32 + (k % n) as f32 / n as f32 + 0.5 / n as f32) / w as f32,
                        ((i / w) as f32 + (k / n) as f32 / n as f32 + 0.5 / n as f32) / h as f32,
                    );
                    if direction(format, uv).is_some() {
                        let jacobian = jacobian_scale(format)
                            * relative_jacobian(format, uv_angle(format, uv));
                        sum += f64::from(luminance(t) * jacobian) / (w * h * n * n) as f64;
                    }
                }
            }
            let exact = luminance(dome.radiance) * sum as f32;
            let e = estimate(20_000, 12, |u| {
                let s = dome.sample(u)?;
                Some(luminance(s.radiance) / s.pdf)
            });
            assert_within_4_sigma(e, exact, &format!("{format:?} dome"));
        }
    }
}
