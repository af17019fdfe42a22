//! `DomeLight`: radiance from infinitely far away in every direction,
//! constant or from a lat-long image importance-sampled through a
//! piecewise-constant 2D distribution over its texels (pbrt-v4's
//! `ImageInfiniteLight` with the equirectangular map).
//!
//! Mapping (UsdLuxDomeLight = the OpenEXR lat-long convention): in the
//! light's space +Y is the pole; image column u in [0, 1) from left to right
//! is longitude pi (1 - 2u), image row v in [0, 1) from top to bottom is
//! latitude pi (1/2 - v), and a direction at latitude lat and longitude lon
//! is (cos lat sin lon, sin lat, cos lat cos lon): the image centre looks
//! down +Z, a quarter to its left (u = 1/4) looks down +X. OpenEXR puts the
//! first and last pixel centres exactly on the +-pi seam; we let pixels cover
//! equal [i/w, (i+1)/w) cells, half a pixel apart from that.

use std::f32::consts::PI;

use glam::{Mat3, Vec2, Vec3};

use super::emission::emission;
use super::image::LightImage;
use super::{world_from_light, LightError, LightHit, LightSample};
use crate::color::luminance;
use crate::sampling::warp::square_to_uniform_sphere;
use crate::sampling::Distribution2D;
use crate::scene::Light as LightRecord;

/// A dome light: the rotation part of its transform and its radiance.
#[derive(Clone, Debug)]
pub(crate) struct DomeLight {
    /// World-from-light rotation (orthonormal; scale is meaningless at infinity).
    world_from_light: Mat3,
    /// Radiance scale: the emission, times the texel where there is an image.
    radiance: Vec3,
    /// The lat-long image and its importance map.
    map: Option<LatLongMap>,
}

/// A lat-long image with its sampling distribution.
#[derive(Clone, Debug)]
struct LatLongMap {
    image: LightImage,
    /// Over (u, v), proportional to texel luminance x sin(theta).
    distribution: Distribution2D,
}

impl DomeLight {
    /// A direction towards the dome: uniform over the sphere when constant,
    /// else by the importance map, pdf = pdf_uv / (2 pi^2 sin theta).
    pub fn sample(&self, u: Vec2) -> Option<LightSample> {
        let (wi, radiance, pdf) = match &self.map {
            None => (
                self.world_from_light * square_to_uniform_sphere(u),
                self.radiance,
                1.0 / (4.0 * PI),
            ),
            Some(map) => {
                let (uv, pdf_uv) = map.distribution.sample(u);
                let local = direction(uv);
                let sin_theta = (PI * uv.y).sin();
                if sin_theta == 0.0 || pdf_uv == 0.0 {
                    return None;
                }
                let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
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
                let uv = lat_long(local);
                // Not sqrt(1 - y^2): that cancels near the poles.
                let sin_theta = local.x.hypot(local.z);
                let pdf = if sin_theta == 0.0 {
                    0.0
                } else {
                    map.distribution.pdf(uv) / (2.0 * PI * PI * sin_theta)
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
        let mean = match &self.map {
            None => 1.0,
            Some(map) => {
                let (w, h) = (map.image.width, map.image.height);
                let mut sum = 0.0f64;
                for row in 0..h {
                    // Solid angle of each texel in this row.
                    let top = (PI * row as f32 / h as f32).cos();
                    let bottom = (PI * (row + 1) as f32 / h as f32).cos();
                    let texel_sr = f64::from(2.0 * PI / w as f32 * (top - bottom));
                    let lum: f64 = map.image.texels[row * w..(row + 1) * w]
                        .iter()
                        .map(|&t| f64::from(luminance(t)))
                        .sum();
                    sum += lum * texel_sr;
                }
                (sum / (4.0 * std::f64::consts::PI)) as f32
            }
        };
        4.0 * PI * PI * scene_radius * scene_radius * luminance(self.radiance) * mean
    }

    /// From the record: the transform's rotation (axes orthonormalised, a
    /// mirror kept), the emission as radiance scale, and the texture (a
    /// missing or unreadable file warns and leaves the dome constant).
    pub fn from_record(
        record: &LightRecord,
        texture: Option<&std::path::Path>,
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
        let map = texture
            .and_then(|path| LightImage::load(path, &record.path))
            .map(LatLongMap::new);
        Ok(Self {
            world_from_light: Mat3::from_cols(x, y, z),
            radiance: emission(record)?,
            map,
        })
    }
}

impl LatLongMap {
    fn new(image: LightImage) -> Self {
        let (w, h) = (image.width, image.height);
        let weights: Vec<f32> = image
            .texels
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let theta = PI * ((i / w) as f32 + 0.5) / h as f32;
                luminance(t) * theta.sin()
            })
            .collect();
        Self {
            distribution: Distribution2D::new(&weights, w, h),
            image,
        }
    }
}

/// Light-space unit direction of lat-long coordinates `uv` (see the module doc).
fn direction(uv: Vec2) -> Vec3 {
    let lon = PI * (1.0 - 2.0 * uv.x);
    let theta = PI * uv.y;
    let (sin_t, cos_t) = theta.sin_cos();
    Vec3::new(sin_t * lon.sin(), cos_t, sin_t * lon.cos())
}

/// Lat-long coordinates in [0, 1)^2 of a light-space unit direction.
fn lat_long(d: Vec3) -> Vec2 {
    let lon = d.x.atan2(d.z);
    let u = 0.5 * (1.0 - lon / PI);
    let v = d.y.clamp(-1.0, 1.0).acos() / PI;
    Vec2::new(
        if u >= 1.0 { 0.0 } else { u },
        v.min(1.0 - f32::EPSILON / 2.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::{
        assert_escape_consistent, assert_within_4_sigma, estimate, record,
    };
    use crate::scene::LightShape;

    fn constant() -> DomeLight {
        let r = record(LightShape::Dome { texture: None }, false, 1.5);
        DomeLight::from_record(&r, None).unwrap()
    }

    /// A 16 x 8 map with a bright patch and a dark band, rotated 90 degrees
    /// about X so the light's pole is world +Z.
    fn textured() -> DomeLight {
        let (w, h) = (16, 8);
        let texels = (0..w * h)
            .map(|i| match (i % w, i / w) {
                (3, 2) => Vec3::new(40.0, 20.0, 10.0),
                (_, 6) => Vec3::ZERO,
                (x, _) => Vec3::splat(0.1 + x as f32 * 0.05),
            })
            .collect();
        let image = LightImage {
            width: w,
            height: h,
            texels,
        };
        let mut r = record(LightShape::Dome { texture: None }, false, 2.0);
        r.transform = [1., 0., 0., 5., 0., 0., -1., 0., 0., 1., 0., 0.];
        let mut dome = DomeLight::from_record(&r, None).unwrap();
        dome.map = Some(LatLongMap::new(image));
        dome
    }

    #[test]
    fn the_mapping_follows_openexr_lat_long() {
        assert!((direction(Vec2::new(0.5, 0.5)) - Vec3::Z).length() < 1e-6);
        assert!((direction(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
        assert!((direction(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
        for uv in [
            Vec2::new(0.1, 0.3),
            Vec2::new(0.9, 0.7),
            Vec2::new(0.5, 0.05),
        ] {
            assert!((lat_long(direction(uv)) - uv).length() < 1e-5);
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
        let dome = textured();
        assert_escape_consistent(|u| dome.sample(u), |d| Some(dome.escaped(d)));
        let c = constant();
        assert_escape_consistent(|u| c.sample(u), |d| Some(c.escaped(d)));
    }

    /// The importance-sampled estimate of the radiance integrated over the
    /// sphere equals the exact sum of texel radiance x texel solid angle.
    #[test]
    fn importance_sampling_integrates_the_map() {
        let dome = textured();
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
}
