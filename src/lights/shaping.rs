//! `UsdLuxShapingAPI`: a sphere, rect, disk or cylinder light whose emission
//! is scaled by a function of the emission direction, as the UsdLux schema
//! defines it (usdLux/schema.usda, ShapingAPI, OpenUSD 24.11 and later; the
//! "UsdLux clarification" proposal and hdEmbree's reference). With theta the
//! angle between the emission direction and the light's axis (its -Z) and
//! phi its azimuth from +X towards +Y in the light's frame:
//! - cone: 0 beyond the cutoff theta_c = `cone:angle`, else
//!   1 - smoothstep(theta; theta_c (1 - `cone:softness`), theta_c);
//! - focus: lerp(|cos theta|^`focus`, `focusTint`, white), per channel;
//! - IES: the profile's candela at (theta_ies, phi), theta_ies = theta /
//!   `angleScale` (> 0) or (theta - pi) / -`angleScale` + pi (< 0), divided
//!   by the profile's mean intensity with `ies:normalize`.
//!
//! The factor depends on the direction only, so a shaped light samples as
//! its unshaped light does, its radiance scaled by the factor towards the
//! shading point, and a ray that hits it sees the same scaled radiance with
//! the same pdf: light sampling and BSDF sampling stay consistent under MIS.
//! For the light BVH the emission directions are bounded by the cone (and
//! the last vertical angle where the IES profile emits), so a narrow spot
//! is not picked where it cannot shine, and its power by the mean factor.

use std::f32::consts::PI;
use std::path::Path;

use glam::{Mat3, Vec2, Vec3};

use super::bvh::LightBounds;
use super::ies::IesProfile;
use super::{Emitters, Light, LightHit, LightSample, LOG_TARGET};
use crate::color::luminance;
use crate::scene::{Light as LightRecord, LightShape, LightShaping};

/// A light whose emission `shaping` scales by direction.
#[derive(Clone, Debug)]
pub(crate) struct ShapedLight {
    /// The light unshaped (sphere, rect, disk or cylinder).
    light: Box<Light>,
    shaping: Shaping,
    /// Mean of the factor's luminance over the light's emission (cosine-
    /// weighted for one-sided planes): its power over the unshaped light's.
    power_scale: f32,
}

/// The shaping inputs, checked and in radians, with the light's frame.
#[derive(Clone, Debug)]
struct Shaping {
    /// Light-from-world for directions (inverse of the transform's linear part).
    light_from_world: Mat3,
    /// The light's axis (its -Z), unit, world space.
    axis: Vec3,
    /// Whether the transform keeps angles (no non-uniform scale or shear),
    /// so the cone in the light's frame is one of the same angle in the world.
    conformal: bool,
    /// Cone cutoff theta_c, radians in [0, pi].
    cutoff: f32,
    /// Where the smoothstep starts, theta_c (1 - softness), radians.
    smooth_start: f32,
    /// `focus`, >= 0 (0: no focus).
    focus: f32,
    /// `focusTint`, linear RGB.
    focus_tint: Vec3,
    ies: Option<Ies>,
}

#[derive(Clone, Debug)]
struct Ies {
    profile: std::sync::Arc<IesProfile>,
    /// `ies:angleScale` (0: none).
    angle_scale: f32,
    /// 1, or 1 / the profile's mean intensity with `ies:normalize`.
    scale: f32,
}

impl ShapedLight {
    /// A sample of the unshaped light, its radiance scaled towards `p`;
    /// `None` where the shaping sends nothing.
    pub fn sample(&self, emitters: Emitters, p: Vec3, u: Vec2) -> Option<LightSample> {
        let mut sample = self.light.sample(emitters, p, u)?;
        let factor = self.shaping.factor(-sample.wi);
        (factor != Vec3::ZERO).then(|| {
            sample.radiance *= factor;
            sample
        })
    }

    /// The unshaped light's hit along unit `w`, its radiance scaled along `-w`.
    pub fn intersect(&self, origin: Vec3, w: Vec3, t_max: f32, time: f32) -> Option<LightHit> {
        let mut hit = self.light.intersect(origin, w, t_max, time)?;
        hit.radiance *= self.shaping.factor(-w);
        Some(hit)
    }

    /// The unshaped light's bounds, its power scaled and its emission
    /// directions narrowed to the shaping's cone.
    pub fn bounds(&self) -> Option<LightBounds> {
        let mut b = self.light.bounds()?;
        b.phi *= self.power_scale;
        let Some(theta) = self.shaping.world_cone() else {
            return Some(b);
        };
        // A hair wider: the cone's edge itself still emits (theta > theta_c is 0).
        let cos_e = (theta + 1e-4).min(PI).cos();
        let axis = self.shaping.axis;
        if b.cos_o == 1.0 && !b.two_sided && b.w.dot(axis) > 0.9999 {
            b.cos_e = b.cos_e.max(cos_e);
        } else if b.cos_o <= -1.0 {
            (b.w, b.cos_o, b.cos_e, b.two_sided) = (axis, 1.0, cos_e, false);
        }
        Some(b)
    }

    /// Luminance of the emitted power: the unshaped light's times the mean factor.
    pub fn power(&self, scene_radius: f32) -> f32 {
        self.light.power(scene_radius) * self.power_scale
    }

    /// The light unshaped.
    pub fn unshaped(&self) -> &Light {
        &self.light
    }

    /// `light` (of `record`) shaped by the record's shaping; `light` itself
    /// when it has none or the shaping changes nothing. Out-of-range inputs
    /// are clamped and an unusable IES file dropped, each with a warning
    /// naming the light and the attribute; shaping on a distant or dome light
    /// is warned about and ignored.
    pub fn shape(light: Light, record: &LightRecord) -> Light {
        let Some(inputs) = &record.shaping else {
            return light;
        };
        if matches!(
            record.shape,
            LightShape::Distant { .. } | LightShape::Dome { .. }
        ) {
            log::warn!(
                target: LOG_TARGET,
                "light {}: ShapingAPI on a {} light is not honoured (only sphere, rect, disk and \
                 cylinder lights are shaped)",
                record.path,
                record.shape.type_name()
            );
            return light;
        }
        let Some(shaping) = Shaping::new(record, inputs) else {
            return light;
        };
        let one_sided = matches!(
            record.shape,
            LightShape::Rect { .. } | LightShape::Disk { .. }
        );
        let power_scale = shaping.mean_factor(one_sided);
        Light::Shaped(Self {
            light: Box::new(light),
            shaping,
            power_scale,
        })
    }
}

impl Shaping {
    /// The checked inputs; `None` when they leave emission unchanged.
    fn new(record: &LightRecord, inputs: &LightShaping) -> Option<Self> {
        // The value clamped to [lo, hi] (`fallback` when not a number),
        // warned about naming the attribute when that changes it.
        let checked = |attribute: &str, value: f32, (lo, hi): (f32, f32), fallback: f32| {
            let used = if value.is_nan() {
                fallback
            } else {
                value.clamp(lo, hi)
            };
            if used != value {
                log::warn!(
                    target: LOG_TARGET,
                    "light {}: inputs:shaping:{attribute} = {value} is out of range [{lo}, {hi}]; \
                     using {used}",
                    record.path
                );
            }
            used
        };
        let cone_deg = checked("cone:angle", inputs.cone_angle_deg, (0.0, 180.0), 180.0);
        let soft = checked("cone:softness", inputs.cone_softness, (0.0, 1.0), 0.0);
        // Values below 0 are ignored (the schema): 0, no focus.
        let focus = checked("focus", inputs.focus, (0.0, f32::MAX), 0.0);
        let tint = inputs.focus_tint;
        let focus_tint = Vec3::from(std::array::from_fn::<f32, 3, _>(|i| {
            checked("focusTint", tint[i], (0.0, f32::MAX), 0.0)
        }));
        let ies = inputs.ies_file.as_deref().and_then(|file| {
            let angle_scale = checked(
                "ies:angleScale",
                inputs.ies_angle_scale,
                (f32::MIN, f32::MAX),
                0.0,
            );
            Ies::load(record, file, angle_scale, inputs.ies_normalize)
        });
        let (linear, _) = super::world_from_light(record).ok()?;
        let light_from_world = linear.inverse();
        let axis = (linear * -Vec3::Z).normalize();
        let lengths = Vec3::new(
            linear.x_axis.length(),
            linear.y_axis.length(),
            linear.z_axis.length(),
        );
        let orthogonal = linear.x_axis.dot(linear.y_axis).abs()
            + linear.y_axis.dot(linear.z_axis).abs()
            + linear.x_axis.dot(linear.z_axis).abs();
        let conformal = lengths.max_element() - lengths.min_element()
            <= 1e-4 * lengths.max_element()
            && orthogonal <= 1e-4 * lengths.max_element().powi(2);
        let cutoff = cone_deg.to_radians();
        let unchanged =
            cone_deg >= 180.0 && (focus == 0.0 || focus_tint == Vec3::ONE) && ies.is_none();
        (!unchanged && light_from_world.is_finite() && axis.is_finite()).then_some(Self {
            light_from_world,
            axis,
            conformal,
            cutoff,
            smooth_start: cutoff * (1.0 - soft),
            focus,
            focus_tint,
            ies,
        })
    }

    /// The factor for world emission direction `w` (unit, from the light).
    fn factor(&self, w: Vec3) -> Vec3 {
        self.factor_local((self.light_from_world * w).normalize_or_zero())
    }

    /// The factor for unit emission direction `w` in the light's frame.
    fn factor_local(&self, w: Vec3) -> Vec3 {
        let cos_theta = (-w.z).clamp(-1.0, 1.0);
        let theta = cos_theta.acos();
        if theta > self.cutoff {
            return Vec3::ZERO;
        }
        let mut f = Vec3::splat(if theta <= self.smooth_start {
            1.0
        } else {
            let t = (theta - self.smooth_start) / (self.cutoff - self.smooth_start);
            1.0 - t * t * (3.0 - 2.0 * t)
        });
        if self.focus > 0.0 {
            let focus_factor = cos_theta.abs().powf(self.focus);
            f *= self.focus_tint + focus_factor * (Vec3::ONE - self.focus_tint);
        }
        if let Some(ies) = &self.ies {
            f *= ies.candela(theta, w.y.atan2(w.x));
        }
        f
    }

    /// The largest emission angle from the axis, in the world, when below
    /// pi and the transform keeps angles; `None` otherwise.
    fn world_cone(&self) -> Option<f32> {
        let ies = self.ies.as_ref().map_or(Some(PI), Ies::max_theta);
        let theta = self.cutoff.min(ies.unwrap_or(0.0));
        (self.conformal && theta < PI).then_some(theta)
    }

    /// The mean of the factor's luminance over all directions, or over the
    /// lower hemisphere weighted by cos theta / pi for a `one_sided` plane;
    /// midpoint quadrature in (theta, phi) over the emitting cone only, so
    /// a narrow spot is not missed.
    fn mean_factor(&self, one_sided: bool) -> f32 {
        const THETA_STEPS: usize = 256;
        const PHI_STEPS: usize = 64;
        let ies_max = self.ies.as_ref().map_or(Some(PI), Ies::max_theta);
        let mut max_theta = self.cutoff.min(ies_max.unwrap_or(0.0));
        if one_sided {
            max_theta = max_theta.min(PI / 2.0);
        }
        let (d_theta, d_phi) = (max_theta / THETA_STEPS as f32, 2.0 * PI / PHI_STEPS as f32);
        let mut sum = 0.0f64;
        for i in 0..THETA_STEPS {
            let theta = (i as f32 + 0.5) * d_theta;
            let (sin, cos) = theta.sin_cos();
            let weight = if one_sided { sin * cos } else { sin };
            let ring: f32 = (0..PHI_STEPS)
                .map(|k| {
                    let phi = (k as f32 + 0.5) * d_phi;
                    luminance(self.factor_local(Vec3::new(sin * phi.cos(), sin * phi.sin(), -cos)))
                })
                .sum();
            sum += f64::from(ring * weight * d_theta * d_phi);
        }
        let total = if one_sided { PI } else { 4.0 * PI };
        (sum / f64::from(total)) as f32
    }
}

impl Ies {
    /// The profile in `file` for `record`'s light; `None`, with one warning
    /// naming the file and the light, when it cannot be used (the light is
    /// then not shaped by it). NaN, negative or huge candela are read as 0
    /// and counted in a warning.
    fn load(record: &LightRecord, file: &Path, angle_scale: f32, normalize: bool) -> Option<Self> {
        let profile = match IesProfile::read(file) {
            Ok(p) => p,
            Err(e) => {
                log::warn!(
                    target: LOG_TARGET,
                    "light {}: IES profile {} unusable ({e}); the light is not shaped by it",
                    record.path,
                    file.display()
                );
                return None;
            }
        };
        if profile.bad_values() > 0 {
            log::warn!(
                target: LOG_TARGET,
                "light {}: IES profile {}: {} NaN, infinite, negative or huge (over 1e20) candela value(s) read as 0",
                record.path,
                file.display(),
                profile.bad_values()
            );
        }
        let mean = profile.mean_intensity();
        let scale = if normalize && mean > 0.0 {
            1.0 / mean
        } else {
            1.0
        };
        Some(Self {
            profile: std::sync::Arc::new(profile),
            angle_scale,
            scale,
        })
    }

    /// `scale` x candela towards angle `theta` off the axis and azimuth `phi`.
    fn candela(&self, theta: f32, phi: f32) -> f32 {
        self.scale * self.profile.candela(self.theta_ies(theta), phi)
    }

    /// `applyAngleScale`: the profile's vertical angle for `theta`.
    fn theta_ies(&self, theta: f32) -> f32 {
        let s = self.angle_scale;
        if s > 0.0 {
            theta / s
        } else if s < 0.0 {
            (theta - PI) / -s + PI
        } else {
            theta
        }
    }

    /// The largest angle off the axis towards which the scaled profile may
    /// emit (the inverse of [`Self::theta_ies`] at the profile's last
    /// emitting vertical angle); `None` when it emits nowhere.
    fn max_theta(&self) -> Option<f32> {
        let m = self.profile.max_theta()?;
        let s = self.angle_scale;
        Some(if s > 0.0 {
            s * m
        } else if s < 0.0 {
            (PI - -s * (PI - m)).max(0.0)
        } else {
            m
        })
    }
}

/// `cirrus info`'s line for a shaped light: its cone, softness, focus and
/// IES file, and whether that file is usable; `None` without shaping.
pub(crate) fn describe(record: &LightRecord) -> Option<String> {
    let s = record.shaping.as_ref()?;
    let mut out = format!(
        "{} ({}): cone {} deg, softness {}",
        record.path,
        record.shape.type_name(),
        s.cone_angle_deg,
        s.cone_softness
    );
    if s.focus != 0.0 {
        out += &format!(", focus {} tint {:?}", s.focus, s.focus_tint);
    }
    if let Some(file) = &s.ies_file {
        out += &format!(", IES {}", file.display());
        out += &match IesProfile::read(file) {
            Ok(p) if p.bad_values() > 0 => {
                format!(" ({} bad candela value(s) read as 0)", p.bad_values())
            }
            Ok(_) => String::new(),
            Err(e) => format!(" UNUSABLE, not shaped by it: {e}"),
        };
        if s.ies_angle_scale != 0.0 || s.ies_normalize {
            out += &format!(
                ", angleScale {}, normalize {}",
                s.ies_angle_scale, s.ies_normalize
            );
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use std::f32::consts::PI;

    use glam::{Vec2, Vec3};
    use serde_json::{json, Value};

    use super::describe;
    use crate::lights::test_support::{
        assert_within_4_sigma, estimate, scene_with, sphere_json, translated,
    };
    use crate::lights::{Emitters, Lights, Receiver};
    use crate::materials::Materials;
    use crate::motion::Shutter;
    use crate::sampling::Pcg32;
    use crate::volumes::Media;

    /// `light` (a record as JSON) with `shaping` added.
    fn shaped(mut light: Value, shaping: Value) -> Value {
        light["shaping"] = shaping;
        light
    }

    /// The scene's lights and what samples read emission from.
    fn build(name: &str, lights: Value) -> (Lights, Materials, crate::scene::Scene) {
        let scene = scene_with(name, lights, [0.0; 3], &[]);
        let materials = Materials::build(&scene).unwrap();
        let lights =
            Lights::build(&scene, &materials, &Media::default(), true, Shutter::CLOSED).unwrap();
        (lights, materials, scene)
    }

    /// Irradiance at `p` on a surface facing +Z, by light sampling (the
    /// selection's pdf included), 20,000 samples.
    fn irradiance(
        lights: &Lights,
        materials: &Materials,
        p: Vec3,
        seed: u64,
    ) -> super::super::test_support::Estimate {
        let media = Media::default();
        let emitters = Emitters {
            materials,
            media: &media,
            time: 0.0,
        };
        let mut rng = Pcg32::new(seed, 7);
        estimate(20_000, seed, |u| {
            let (_, s) = lights.sample(emitters, (p, Receiver::UNNAMED), rng.next_f32(), u)?;
            Some(s.radiance.x * s.wi.z.max(0.0) / s.pdf)
        })
    }

    /// A sphere light of radiance `l` and radius `r` at `c` seen from `p`
    /// (normal +Z), fully above its horizon: E = pi L (r / d)^2 cos theta.
    fn sphere_irradiance(l: f32, r: f32, c: Vec3, p: Vec3) -> f32 {
        let to = c - p;
        PI * l * r * r / to.length_squared() * to.normalize().z
    }

    /// A spot (cone 30 degrees, softness 0, a small sphere 2 above the
    /// plane) and an omni sphere beside it: outside the spot's footprint
    /// the spot is never picked (its BVH cone is the spot's cone) and the
    /// irradiance is the omni's alone; inside, both, against the exact
    /// sphere formula within 4 sigma.
    #[test]
    fn a_hard_spot_lights_its_footprint_and_nothing_else() {
        let spot_at = Vec3::new(0.0, 0.0, 2.0);
        let omni_at = Vec3::new(5.0, 0.0, 2.0);
        let (lights, materials, _) = build(
            "hard-spot",
            json!([
                shaped(
                    sphere_json("/Spot", spot_at, 0.02, 1000.0),
                    json!({"cone_angle_deg": 30.0, "cone_softness": 0.0})
                ),
                sphere_json("/Omni", omni_at, 0.3, 1.0),
            ]),
        );
        // The footprint's edge is at 2 tan 30 = 1.155 from the axis.
        for (i, p) in [
            Vec3::ZERO,
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(1.0, 0.3, 0.0),
            Vec3::new(1.4, 0.0, 0.0),
            Vec3::new(-3.0, 0.0, 0.0),
            Vec3::new(0.0, -2.0, 0.0),
        ]
        .into_iter()
        .enumerate()
        {
            let inside = (p - spot_at).normalize().dot(-Vec3::Z) > 30f32.to_radians().cos();
            assert_eq!(
                lights.probability(p, 0, Receiver::UNNAMED) > 0.0,
                inside,
                "{p}"
            );
            let mut exact = sphere_irradiance(1.0, 0.3, omni_at, p);
            if inside {
                exact += sphere_irradiance(1000.0, 0.02, spot_at, p);
            }
            let e = irradiance(&lights, &materials, p, 40 + i as u64);
            assert_within_4_sigma(e, exact, &format!("spot at {p}"));
        }
    }

    /// Softness 0.5 on a 40 degree cone: the falloff is 1 - smoothstep from
    /// 20 to 40 degrees (the schema's formula, written out here), with the
    /// focus factor |cos|^2 on top, tinted: per channel tint + f (1 - tint).
    #[test]
    fn a_soft_spot_falls_off_by_the_schemas_smoothstep() {
        let at = Vec3::new(0.0, 0.0, 2.0);
        let (r, l) = (0.002, 1.0e5);
        let (lights, materials, _) = build(
            "soft-spot",
            json!([shaped(
                sphere_json("/Spot", at, r, l),
                json!({"cone_angle_deg": 40.0, "cone_softness": 0.5, "focus": 2.0,
                       "focus_tint": [0.25, 0.0, 0.0]})
            )]),
        );
        for (i, theta_deg) in [0.0f32, 10.0, 22.0, 27.0, 31.0, 36.0, 39.0, 43.0]
            .into_iter()
            .enumerate()
        {
            let theta = theta_deg.to_radians();
            let p = Vec3::new(2.0 * theta.tan(), 0.0, 0.0);
            let t = ((theta_deg - 20.0) / 20.0).clamp(0.0, 1.0);
            let cone = if theta_deg > 40.0 {
                0.0
            } else {
                1.0 - t * t * (3.0 - 2.0 * t)
            };
            let focus = theta.cos().powi(2);
            let red = cone * (0.25 + focus * 0.75);
            let e = irradiance(&lights, &materials, p, 60 + i as u64);
            assert_within_4_sigma(
                e,
                red * sphere_irradiance(l, r, at, p),
                &format!("{theta_deg} deg"),
            );
        }
    }

    /// An IES profile the test writes (type C, 0-90 degrees every 15,
    /// horizontal 0-360 every 90 with factors 1, 0.5, 0.25, 0.5, 1): the
    /// irradiance on a ring of points 37.5 degrees off the axis follows the
    /// table, bilinear between its rows and columns (the points lie between
    /// grid angles: at a kink of the table the small sphere's spread of
    /// directions would bias the comparison); `angleScale` 0.5 reads the
    /// profile at twice the angle; `normalize` divides by its mean.
    #[test]
    fn an_ies_profile_shapes_the_light_by_its_table() {
        let vertical = [1000.0f32, 900.0, 700.0, 400.0, 150.0, 30.0, 0.0];
        let factors = [1.0f32, 0.5, 0.25, 0.5, 1.0];
        let mut text = String::from(
            "IESNA:LM-63-2002\n[TEST] ring\nTILT=NONE\n1 -1 1 7 5 1 2 0 0 0\n1 1 50\n",
        );
        text += "0 15 30 45 60 75 90\n0 90 180 270 360\n";
        for f in factors {
            let row: Vec<String> = vertical.iter().map(|c| (c * f).to_string()).collect();
            text += &(row.join(" ") + "\n");
        }
        let dir = std::env::temp_dir().join(format!("cirrus-ies-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("ring.ies");
        std::fs::write(&file, text).unwrap();
        let at = Vec3::new(0.0, 0.0, 2.0);
        let r = 0.002;
        let light = |scale: f32, normalize: bool| {
            shaped(
                sphere_json("/Lamp", at, r, 1.0),
                json!({"ies_file": file, "ies_angle_scale": scale, "ies_normalize": normalize}),
            )
        };
        let (lights, materials, scene) = build("ies", json!([light(0.0, false),]));
        let (scaled, scaled_materials, _) = build("ies-scaled", json!([light(0.5, false)]));
        let (normalized, normalized_materials, _) =
            build("ies-normalized", json!([light(0.0, true)]));
        let mean = crate::lights::IesProfile::read(&file)
            .unwrap()
            .mean_intensity();
        let ring = 2.0 * 37.5f32.to_radians().tan();
        for (i, (phi_deg, factor)) in [
            (30.0f32, 1.0 - 0.5 / 3.0),
            (120.0, 0.5 - 0.25 / 3.0),
            (200.0, 0.25 + 0.25 * 2.0 / 9.0),
            (300.0, 0.5 + 0.5 / 3.0),
        ]
        .into_iter()
        .enumerate()
        {
            let phi = phi_deg.to_radians();
            let p = Vec3::new(ring * phi.cos(), ring * phi.sin(), 0.0);
            let unit = sphere_irradiance(1.0, r, at, p);
            let seed = 80 + i as u64;
            let e = irradiance(&lights, &materials, p, seed);
            // Between the 30 and 45 degree rows: (700 + 400) / 2.
            assert_within_4_sigma(e, 550.0 * factor * unit, &format!("ring at {phi_deg} deg"));
            let e = irradiance(&normalized, &normalized_materials, p, seed);
            assert_within_4_sigma(
                e,
                550.0 * factor / mean * unit,
                &format!("normalized, {phi_deg} deg"),
            );
            // angleScale 0.5: the point 18.75 degrees off the axis reads 37.5 degrees.
            let near =
                Vec3::new(p.x, p.y, 0.0).normalize_or_zero() * 2.0 * 18.75f32.to_radians().tan();
            let e = irradiance(&scaled, &scaled_materials, near, seed);
            let exact = 550.0 * factor * sphere_irradiance(1.0, r, at, near);
            assert_within_4_sigma(e, exact, &format!("angleScale, {phi_deg} deg"));
        }
        // Beyond 90 degrees the profile is dark: not picked at all.
        assert_eq!(
            lights.probability(Vec3::new(0.0, 0.0, 4.0), 0, Receiver::UNNAMED),
            0.0
        );
        assert!(describe(&scene.manifest.lights[0])
            .unwrap()
            .contains("ring.ies"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A shaped rect light (soft cone, tinted focus): a ray along a light
    /// sample finds the light with the sample's radiance and pdf, so light
    /// and BSDF sampling weigh each other by MIS consistently.
    #[test]
    fn samples_and_hits_of_a_shaped_light_agree() {
        let rect = json!({
            "type": "rect", "path": "/Rect", "transform": translated(Vec3::new(0.0, 0.0, 2.0)),
            "color": [1, 1, 1], "intensity": 3.0, "exposure": 0.0, "normalize": false,
            "color_temperature": null, "width": 1.0, "height": 1.0, "texture": null,
            "shaping": {"cone_angle_deg": 35.0, "cone_softness": 0.6, "focus": 3.0,
                        "focus_tint": [0.2, 0.1, 0.0]}
        });
        let (lights, materials, _) = build("rect", json!([rect]));
        let media = Media::default();
        let emitters = Emitters {
            materials: &materials,
            media: &media,
            time: 0.0,
        };
        let p = Vec3::new(0.9, 0.2, 0.0);
        let mut rng = Pcg32::new(5, 1);
        let mut checked = 0;
        for _ in 0..2000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let Some((_, s)) = lights.sample(emitters, (p, Receiver::UNNAMED), 0.5, u) else {
                continue;
            };
            let (_, hit) = lights
                .intersect((p, Receiver::UNNAMED), s.wi, f32::INFINITY, 0.0)
                .unwrap();
            assert!((hit.pdf - s.pdf).abs() <= 1e-3 * s.pdf);
            assert!(
                (hit.radiance - s.radiance).abs().max_element() <= 1e-4 * s.radiance.max_element()
            );
            // Tint (0.2, 0.1, 0) + f (1 - tint), f < 1 off the axis: red > green > blue.
            assert!(s.radiance.x > s.radiance.y && s.radiance.y > s.radiance.z);
            checked += 1;
        }
        assert!(checked > 500, "{checked}");
    }

    /// Bad input: a cone angle above 180 and a negative softness are
    /// clamped (no cone, hard edge); a missing and a malformed IES file
    /// leave the light unshaped by them, and `cirrus info` says so.
    #[test]
    fn bad_shaping_inputs_are_clamped_or_dropped() {
        let at = Vec3::new(0.0, 0.0, 2.0);
        let dir = std::env::temp_dir().join(format!("cirrus-ies-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let malformed = dir.join("malformed.ies");
        std::fs::write(&malformed, "IESNA:LM-63-2002\nTILT=NONE\n1 1 1 3 1\n").unwrap();
        let missing = dir.join("missing.ies");
        let (lights, materials, scene) = build(
            "bad-shaping",
            json!([
                shaped(
                    sphere_json("/Wide", at, 0.02, 1.0),
                    json!({"cone_angle_deg": 200.0})
                ),
                shaped(
                    sphere_json("/Missing", at + Vec3::X * 10.0, 0.02, 1.0),
                    json!({"ies_file": missing})
                ),
                shaped(
                    sphere_json("/Malformed", at - Vec3::X * 10.0, 0.02, 1.0),
                    json!({"ies_file": malformed})
                ),
                shaped(
                    sphere_json("/Hard", at + Vec3::Y * 10.0, 0.02, 1.0),
                    json!({"cone_angle_deg": 30.0, "cone_softness": -1.0})
                ),
            ]),
        );
        // Above every light (behind each axis) the clamped and unshaped ones shine.
        let above = Vec3::new(0.0, 0.0, 3.0);
        for light in 0..3 {
            assert!(
                lights.probability(above, light, Receiver::UNNAMED) > 0.0,
                "light {light}"
            );
        }
        assert_eq!(lights.probability(above, 3, Receiver::UNNAMED), 0.0);
        // The hard-edged one: full at 29 degrees, nothing at 31.
        for (theta_deg, inside) in [(29.0f32, true), (31.0, false)] {
            let p = at + Vec3::Y * 10.0 + Vec3::new(0.0, 2.0 * theta_deg.to_radians().tan(), -2.0);
            let e = irradiance(&lights, &materials, p, 3);
            let light = at + Vec3::Y * 10.0;
            let others: f32 = [at, at + Vec3::X * 10.0, at - Vec3::X * 10.0]
                .iter()
                .map(|&c| sphere_irradiance(1.0, 0.02, c, p).max(0.0))
                .sum();
            let exact = others
                + if inside {
                    sphere_irradiance(1.0, 0.02, light, p)
                } else {
                    0.0
                };
            assert_within_4_sigma(e, exact, &format!("{theta_deg} deg"));
        }
        let info: Vec<String> = scene.manifest.lights.iter().filter_map(describe).collect();
        assert!(info[1].contains("missing.ies UNUSABLE"), "{}", info[1]);
        assert!(info[2].contains("malformed.ies UNUSABLE"), "{}", info[2]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
