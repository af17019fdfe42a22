//! Shading data of a hit on a sphere (points) or a round tube piece
//! (curves): the geometric normal of the round surface, texture
//! coordinates (spheres: longitude, colatitude; tubes: `u` along the curve,
//! `v` around it) and the primvar site (a point's index; a piece's index
//! and the fraction `s` along it, so a per-vertex primvar is interpolated
//! linearly along the piece).

use std::f32::consts::{FRAC_1_PI, TAU};

use glam::{Affine3A, Vec2, Vec3, Vec3A, Vec4};

use super::frame::Frame;
use super::round_intersect::RoundHit;
use super::surface::SurfacePoint;

/// How far a ray leaving a round surface first moves off it, relative to
/// its radius in world units (2^-14): well above the few ULPs of radius the
/// shifted-origin quadratics lose, far below any visible gap.
const RADIUS_OFFSET: f32 = 1.0 / 16_384.0;

/// What a round shape's hits carry beyond the BVH: the material and, for
/// curves, where each curve's vertices start.
pub(super) struct RoundShading {
    /// Bound material, or `scene::NO_MATERIAL`.
    pub material: u32,
    /// Curves: first vertex of each curve, then the vertex count; empty
    /// for points.
    pub curve_starts: Vec<u32>,
}

impl RoundShading {
    /// The surface point of `hit` on `element` (point or piece) of a shape
    /// of spheres (`sphere(i)`: xyz centre, w radius, at the hit's time) and `pieces` (each piece's first
    /// vertex; empty for points), placed by the inverse of `shape_from_world`; `ids` = (instance,
    /// prototype part id, object index: the scene's meshes, then its
    /// points, then its curves).
    pub(super) fn surface_point(
        &self,
        (sphere, pieces): (&dyn Fn(u32) -> Vec4, &[u32]),
        shape_from_world: &Affine3A,
        element: u32,
        hit: &RoundHit,
        [instance, prototype_mesh, mesh]: [u32; 3],
    ) -> SurfacePoint {
        let n = hit.normal;
        let (centre, radius, tangent, uv) = match pieces.get(element as usize) {
            None => {
                let sphere = sphere(element);
                let longitude = n.y.atan2(n.x) / TAU + 0.5;
                let colatitude = n.z.clamp(-1.0, 1.0).acos() * FRAC_1_PI;
                let tangent = Vec3A::new(-n.y, n.x, 0.0);
                (sphere, sphere.w, tangent, Vec2::new(longitude, colatitude))
            }
            Some(&v) => {
                let (a, b) = (sphere(v), sphere(v + 1));
                let centre = a.lerp(b, hit.s);
                let tangent = Vec3A::from((b - a).truncate());
                let curve = self.curve_starts.partition_point(|&start| start <= v) - 1;
                let (first, next) = (self.curve_starts[curve], self.curve_starts[curve + 1]);
                let u = (v - first) as f32 + hit.s;
                let frame = Frame::from_normal(Vec3::from(tangent).normalize_or_zero());
                let around = frame.t.dot(n.into()).atan2(frame.s.dot(n.into()));
                let uv = Vec2::new(u / (next - first - 1) as f32, around / TAU + 0.5);
                (centre, centre.w, tangent, uv)
            }
        };
        let local = Vec3A::from(centre.truncate()) + radius * n;
        let world_from_shape = shape_from_world.inverse();
        let ng = Vec3::from(shape_from_world.matrix3.transpose() * n).normalize();
        let world_radius = world_from_shape.transform_vector3a(radius * n).length();
        let dpdu = Vec3::from(world_from_shape.transform_vector3a(tangent));
        let dpdu = if dpdu.cross(ng).length_squared() > 0.0 {
            dpdu
        } else {
            Frame::from_normal(ng).s
        };
        let on_piece = !pieces.is_empty();
        SurfacePoint {
            p: world_from_shape.transform_point3a(local).into(),
            ng,
            offset: RADIUS_OFFSET * world_radius,
            ns: ng,
            dpdu,
            uv,
            barycentrics: Vec2::new(if on_piece { hit.s } else { 0.0 }, 0.0),
            material: self.material,
            double_sided: false,
            instance,
            prototype_mesh,
            mesh,
            triangle: element,
        }
    }
}
