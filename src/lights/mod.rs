//! UsdLux lights and emissive meshes: sampling towards a shading point,
//! finding them along rays, and picking one per sample.
//!
//! Every UsdLux type the exporter writes is a [`Light`] variant in its own
//! file, each following docs/conventions.md, "Lights":
//! - `distant.rs`: a uniform cone of angular diameter `angle` (a delta
//!   direction at angle 0), irradiance or disk radiance by `normalize`;
//! - `sphere.rs`: sampled by subtended solid angle (pbrt-v4 `Sphere::Sample`);
//!   `treatAsPoint` = a point light of the same power;
//! - `rect.rs`, `disk.rs` (sharing `plane.rs`), `cylinder.rs`: uniformly by
//!   area, converted to solid angle;
//! - `dome.rs`: constant, or an OpenEXR lat-long image importance-sampled
//!   by a piecewise-constant 2D distribution (pbrt-v4 `ImageInfiniteLight`);
//! - `mesh.rs`: each placed mesh with emissive triangles, uniformly by area;
//! - `moving.rs`: a bounded light moving rigidly over the shutter, asked
//!   at the sample's time through its still pose at the frame;
//! - `shaping.rs`: a sphere, rect, disk or cylinder light shaped by
//!   `UsdLuxShapingAPI` (cone with softness, focus, an IES profile read by
//!   `ies.rs`), its BVH bounds narrowed to its cone;
//! - `volume.rs`: each placed volume that emits (fire), a point by power
//!   or, near it, by what it delivers (Villemin & Hery 2013), in the
//!   measure of free-flight tracking so that emission found by tracking
//!   and by light sampling combine by MIS.
//!
//! One light is picked per sample (`select.rs`): infinite lights, each
//! emitting volume and the other bounded lights by what each can deliver
//! at the shading point, infinite lights among themselves by power, the
//! other bounded lights by a light BVH (`bvh.rs`, pbrt-v4's `BVHLightSampler`) that weighs power by
//! distance and orientation from the shading point. Every pdf that leaves
//! this module is per steradian and includes that selection probability.
//!
//! Area lights are not occluders and show no back faces: a ray passes
//! through a light's back (or a one-sided light seen from behind) unseen.
//!
//! This file is the interface: the [`Light`] enum, [`LightSample`],
//! [`LightHit`] and [`Emitters`]. `container.rs` holds [`Lights`], through
//! which the integrator samples, finds and weighs lights; `dispatch.rs` the
//! match over [`Light`]'s variants behind each of its methods;
//! `validate.rs` [`LightError`] and the record checks every light shares.

mod bvh;
mod container;
mod cylinder;
mod disk;
mod dispatch;
mod distant;
mod dome;
mod emission;
mod ies;
mod image;
mod linking;
mod mesh;
mod moving;
mod plane;
mod rect;
mod select;
mod shaping;
mod sphere;
mod validate;
mod volume;

#[cfg(test)]
pub(crate) mod test_support;

pub use container::{EquiangularTarget, Lights, VolumeLightsFrom};
pub use ies::{IesError, IesProfile};
pub use linking::Receiver;
pub use validate::LightError;
pub(crate) use validate::{mean_scale, world_from_light};

use glam::Vec3;

use self::cylinder::CylinderLight;
use self::disk::DiskLight;
use self::distant::DistantLight;
use self::dome::DomeLight;
use self::mesh::MeshLight;
use self::moving::MovingLight;
use self::rect::RectLight;
use self::shaping::ShapedLight;
use self::sphere::SphereLight;
use self::volume::VolumeLight;
use crate::materials::Materials;
use crate::volumes::Media;

/// Log target of the messages [`Lights::build`] and [`mean_scale`] write:
/// this module's path, `cirrus::lights`, which users filter by and the
/// gallery's README quotes (the per-type files log under their own paths).
const LOG_TARGET: &str = module_path!();

/// What light samples read emission from: materials for emissive meshes,
/// media for emitting volumes.
#[derive(Clone, Copy)]
pub struct Emitters<'a> {
    /// The scene's materials.
    pub materials: &'a Materials,
    /// The scene's media.
    pub media: &'a Media,
    /// The sample's time, frames relative to the frame (volumes advected
    /// by velocity fields emit where they are then).
    pub time: f32,
}

/// A light sample seen from a shading point (pbrt's `LightLiSample`).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Incident radiance along `-wi`, W/(m^2 sr). For a delta light (point,
    /// or distant of angle 0) it is the irradiance on a surface facing the
    /// light, W/m^2, so `radiance * |cos| / pdf` (or `bsdf.eval * radiance /
    /// pdf`) is the right estimator there too.
    pub radiance: Vec3,
    /// Unit world direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point, scene units; infinite for infinite lights.
    pub distance: f32,
    /// Solid-angle density, the light selection probability included; for a
    /// delta light, the selection probability alone.
    pub pdf: f32,
    /// Sampled from a Dirac distribution (point or zero-angle distant light): no MIS.
    pub delta: bool,
}

impl LightSample {
    /// The sample of `point` on a one-sided emitter whose unit `normal`
    /// points to its emitting side, drawn with area density `pdf_area` (per
    /// square scene unit), seen from `p`: the density becomes a solid-angle
    /// one, pdf_area d^2 / cos. `None` when the point faces away from `p` or
    /// the density is not finite (grazing or coincident); `radiance` is
    /// evaluated only for a sample that is kept.
    pub(crate) fn one_sided_area(
        p: Vec3,
        point: Vec3,
        normal: Vec3,
        pdf_area: f32,
        radiance: impl FnOnce() -> Vec3,
    ) -> Option<Self> {
        let offset = point - p;
        let distance = offset.length();
        let wi = offset / distance;
        let cos_light = -wi.dot(normal);
        if cos_light <= 0.0 {
            return None;
        }
        let pdf = crate::sampling::warp::area_to_solid_angle(pdf_area, distance, cos_light);
        (pdf > 0.0 && pdf.is_finite()).then(|| Self {
            radiance: radiance(),
            wi,
            distance,
            pdf,
            delta: false,
        })
    }
}

/// Where a ray meets an analytic area light.
#[derive(Clone, Copy, Debug)]
pub struct LightHit {
    /// Ray parameter of the hit, scene units along the unit direction.
    pub t: f32,
    /// Emitted radiance towards the ray origin, W/(m^2 sr).
    pub radiance: Vec3,
    /// Solid-angle density with which `Lights::sample` would pick this point
    /// from the ray origin, selection probability included.
    pub pdf: f32,
}

/// One light, by type (a closed set: UsdLux's types plus emissive meshes).
#[derive(Clone, Debug)]
pub(crate) enum Light {
    /// `DistantLight`.
    Distant(DistantLight),
    /// `SphereLight` (or a point light with `treatAsPoint`).
    Sphere(SphereLight),
    /// `RectLight`.
    Rect(RectLight),
    /// `DiskLight`.
    Disk(DiskLight),
    /// `CylinderLight`.
    Cylinder(CylinderLight),
    /// `DomeLight`.
    Dome(DomeLight),
    /// A placed mesh with emissive triangles.
    Mesh(MeshLight),
    /// A placed volume that emits.
    Volume(VolumeLight),
    /// A sphere, rect, disk or cylinder light moving over the shutter.
    Moving(MovingLight),
    /// A sphere, rect, disk or cylinder light shaped by `UsdLuxShapingAPI`.
    Shaped(ShapedLight),
}

/// `cirrus info`'s lines for the shaped lights of `scene` (in its summary's
/// layout): how many, then each light's cone, softness, focus and IES file,
/// and whether that file is usable.
pub fn shaped_lights(scene: &crate::scene::Scene) -> String {
    let lines: Vec<String> = scene
        .manifest
        .lights
        .iter()
        .filter_map(shaping::describe)
        .collect();
    let mut out = format!("  {:<12} {}\n", "shaped", lines.len());
    for line in lines {
        out += &format!("  {:<12} {line}\n", "");
    }
    out
}
