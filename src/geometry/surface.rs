//! What shading needs to know about a hit, and how rays leave a surface
//! without hitting it again.

use glam::{Affine3A, Vec2, Vec3, Vec3A};
use obvhs::ray::Ray;

use super::frame::Frame;
use super::motion::VertexKeys;
use crate::scene::{self, Scene};

/// A ray's hit on a mesh, in world space: the input to materials and lights.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Position, scene units.
    pub p: Vec3,
    /// Unit geometric normal on the front side (the side from which the
    /// triangle's vertices run counter-clockwise), carried to world space by
    /// the inverse transpose, so a mirroring transform keeps the front side.
    pub ng: Vec3,
    /// How far (scene units) a ray leaving the point first moves off the
    /// surface along `ng`, beyond the ULP steps of [`offset_origin`]: a bound
    /// on how far a re-intersection of this triangle can land off its plane.
    /// Watertight intersection rounds relative to the vertices' distances
    /// from the ray's origin, so that error grows with the triangle's size,
    /// not with the point's coordinates: a 2e6-unit ground near the world
    /// origin shadowed itself under an offset of 1e-5 (2^-18 of the longest
    /// world-space edge).
    pub offset: f32,
    /// Unit shading normal: the interpolated vertex normal (or `ng` where the
    /// mesh has none or it degenerates), flipped into `ng`'s hemisphere.
    pub ns: Vec3,
    /// World tangent along increasing texture `u` (any tangent when the mesh
    /// has no texture coordinates): the normal map's tangent-space x axis.
    pub dpdu: Vec3,
    /// Texture coordinates (`primvars:st`), zero when the mesh has none.
    pub uv: Vec2,
    /// Barycentric weights of the triangle's second and third vertices (the
    /// first has 1 minus both): where the mesh's primvars are interpolated.
    pub barycentrics: Vec2,
    /// Bound material index, or `scene::NO_MATERIAL`.
    pub material: u32,
    /// The mesh's `doubleSided`: emission and thin transmission from both sides.
    pub double_sided: bool,
    /// Instance index.
    pub instance: u32,
    /// Mesh index within the instance's prototype.
    pub prototype_mesh: u32,
    /// Index of the mesh in the scene's meshes.
    pub mesh: u32,
    /// Triangle index within the mesh.
    pub triangle: u32,
}

/// Where on a mesh a material input is read (a hit, or a point sampled on
/// an emissive triangle): what texture and primvar lookups need.
#[derive(Clone, Copy, Debug)]
pub struct MeshSite {
    /// Index of the mesh in the scene's meshes.
    pub mesh: u32,
    /// Instance index: where a primvar the mesh lacks is read.
    pub instance: u32,
    /// Triangle index within the mesh.
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third vertices.
    pub barycentrics: Vec2,
    /// Texture coordinates there.
    pub uv: Vec2,
}

impl SurfacePoint {
    /// Where on its mesh the point lies, for material lookups.
    pub fn site(&self) -> MeshSite {
        MeshSite {
            mesh: self.mesh,
            instance: self.instance,
            triangle: self.triangle,
            barycentrics: self.barycentrics,
            uv: self.uv,
        }
    }

    /// A ray leaving the surface along unit `direction`, its origin pushed off
    /// the surface to `direction`'s side of `ng` (see [`offset_origin`]).
    pub fn spawn_ray(&self, direction: Vec3) -> Ray {
        let origin = offset_origin(self.p, self.ng, direction, self.offset);
        Ray::new(origin.into(), direction.into(), 0.0, f32::INFINITY)
    }

    /// A shadow ray towards the point `distance` away along unit `direction`
    /// (infinite for infinite lights), stopping just short of it so the
    /// light's own surface does not shadow it: by a relative 1e-4, far above
    /// the rounding of `distance` (about 1e-7 relative).
    ///
    /// The ray runs from the offset origin to that point itself (as pbrt-v4's
    /// `SpawnRayTo`), not along `direction` for `distance`: the offset grows
    /// with this triangle's size, and a large receiver under a near emitter
    /// (a 20-unit floor 0.5 below a lamp) moved the origin further towards
    /// the light than the shortening, so every shadow ray hit the lamp
    /// itself and light sampling saw it as occluded.
    pub fn shadow_ray(&self, direction: Vec3, distance: f32) -> Ray {
        let origin = offset_origin(self.p, self.ng, direction, self.offset);
        if !distance.is_finite() {
            return shadow_ray(origin, direction, distance);
        }
        let to_light = self.p + direction * distance - origin;
        let length = to_light.length();
        shadow_ray(origin, to_light / length, length)
    }
}

/// Relative size of [`SurfacePoint::offset`]: 2^-18 of a triangle's longest
/// edge, about 32 f32 roundings of it.
const EXTENT_OFFSET: f32 = 1.0 / 262_144.0;

/// A shadow ray from `origin` (already off any surface, or in a medium)
/// towards a point `distance` away along unit `direction`, stopping just
/// short of it: see [`SurfacePoint::shadow_ray`].
pub fn shadow_ray(origin: Vec3, direction: Vec3, distance: f32) -> Ray {
    let tmax = distance * (1.0 - SHADOW_RAY_SHORTENING);
    Ray::new(origin.into(), direction.into(), 0.0, tmax)
}

/// Relative shortening of shadow rays towards a light point, see
/// [`SurfacePoint::shadow_ray`].
const SHADOW_RAY_SHORTENING: f32 = 1e-4;

/// `p` moved off its surface along the geometric normal `ng`, to the side of
/// `w`, by a few units in the last place of each coordinate (Wächter and
/// Binder 2019, "A Fast and Robust Method for Avoiding Self-Intersection",
/// Ray Tracing Gems ch. 6): the offset scales with the coordinates' own
/// rounding error, so it works at any scene scale, unlike a fixed epsilon.
/// Near the origin, where ULPs vanish, a small absolute offset takes over.
/// `extent_offset` (scene units) moves `p` first: the part of the error that
/// grows with the triangle's size, not its position ([`SurfacePoint::offset`]).
pub fn offset_origin(p: Vec3, ng: Vec3, w: Vec3, extent_offset: f32) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if ng.dot(w) < 0.0 { -ng } else { ng };
    let p = p + n * extent_offset;
    let step = |p: f32, n: f32| {
        let of = (INT_SCALE * n) as i32;
        let moved = f32::from_bits((p.to_bits() as i32 + if p < 0.0 { -of } else { of }) as u32);
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            moved
        }
    };
    Vec3::new(step(p.x, n.x), step(p.y, n.y), step(p.z, n.z))
}

/// One scene mesh's per-vertex and per-triangle data, owned by the geometry
/// so the render state does not borrow the scene.
pub(super) struct MeshShading {
    points: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    materials: Vec<u32>,
    double_sided: bool,
    /// A deforming mesh's points and normals at its keys (with `motion`).
    keys: Option<VertexKeys>,
}

impl MeshShading {
    /// Copies `mesh`'s arrays out of the scene, with its motion keys when
    /// it deforms and `motion` is on.
    pub(super) fn new(scene: &Scene, mesh: &scene::Mesh, motion: bool) -> Self {
        let vec3s = |a: &scene::Array<[f32; 3]>| scene.view(a).iter().map(|&v| v.into()).collect();
        Self {
            points: vec3s(&mesh.points),
            triangles: scene.view(&mesh.triangles).to_vec(),
            normals: mesh.normals.as_ref().map(vec3s),
            uvs: mesh
                .uvs
                .as_ref()
                .map(|a| scene.view(a).iter().map(|&v| v.into()).collect()),
            materials: scene.view(&mesh.triangle_materials).to_vec(),
            double_sided: mesh.double_sided,
            keys: VertexKeys::new(scene, mesh, motion),
        }
    }

    /// The surface point at `barycentrics` on `triangle`, placed by the
    /// inverse of `mesh_from_world`; `ids` = (instance, prototype mesh,
    /// scene mesh). A deforming mesh's triangle is the one at `time`
    /// (frames): vertices and normals lerped between the keys around it.
    pub(super) fn surface_point(
        &self,
        mesh_from_world: &Affine3A,
        triangle: u32,
        barycentrics: Vec2,
        [instance, prototype_mesh, mesh]: [u32; 3],
        time: f32,
    ) -> SurfacePoint {
        let [a, b, c] = self.triangles[triangle as usize].map(|i| i as usize);
        let w = Vec3::new(
            1.0 - barycentrics.x - barycentrics.y,
            barycentrics.x,
            barycentrics.y,
        );
        let mix3 = |v: [Vec3; 3]| v[0] * w.x + v[1] * w.y + v[2] * w.z;
        let keyed = self.keys.as_ref().map(|k| (k, k.bracket(time)));
        let [p0, p1, p2] = match &keyed {
            Some((keys, at)) => keys.points(at, [a, b, c]),
            None => [self.points[a], self.points[b], self.points[c]],
        };
        let vertex_normals = match &keyed {
            Some((keys, at)) => keys.normals(at, [a, b, c]),
            None => self.normals.as_ref().map(|n| [n[a], n[b], n[c]]),
        };
        let world_from_mesh = mesh_from_world.inverse();
        // Normals go through the inverse transpose of world-from-mesh.
        let normal_to_world =
            |n: Vec3| Vec3::from(mesh_from_world.matrix3.transpose() * Vec3A::from(n));
        let vector_to_world = |v: Vec3| world_from_mesh.transform_vector3(v);
        let (e1, e2) = (p1 - p0, p2 - p0);
        let ng = normal_to_world(e1.cross(e2)).normalize();
        let [w1, w2] = [e1, e2].map(vector_to_world);
        let longest_edge = w1.length().max(w2.length()).max((w2 - w1).length());
        let ns = vertex_normals
            .map(|n| normal_to_world(mix3(n)).normalize_or_zero())
            .filter(|n| *n != Vec3::ZERO)
            .map_or(ng, |n| if n.dot(ng) < 0.0 { -n } else { n });
        let (uv, dpdu) = match &self.uvs {
            Some(uvs) => {
                let [t0, t1, t2] = [uvs[a], uvs[b], uvs[c]];
                let uv = t0 * w.x + t1 * w.y + t2 * w.z;
                (uv, tangent_u(e1, e2, t1 - t0, t2 - t0))
            }
            None => (Vec2::ZERO, None),
        };
        let dpdu = dpdu
            .map(vector_to_world)
            .filter(|t| t.cross(ns).length_squared() > 0.0)
            .unwrap_or_else(|| Frame::from_normal(ns).s);
        SurfacePoint {
            p: world_from_mesh.transform_point3(mix3([p0, p1, p2])),
            ng,
            offset: EXTENT_OFFSET * longest_edge,
            ns,
            dpdu,
            uv,
            barycentrics,
            material: self.materials[triangle as usize],
            double_sided: self.double_sided,
            instance,
            prototype_mesh,
            mesh,
            triangle,
        }
    }
}

/// dp/du of a triangle with edges `e1`, `e2` and texture-coordinate edges
/// `d1`, `d2` (pbrt-v4 §6.5.3), or `None` when the UV map is degenerate.
fn tangent_u(e1: Vec3, e2: Vec3, d1: Vec2, d2: Vec2) -> Option<Vec3> {
    let det = d1.x * d2.y - d1.y * d2.x;
    let dpdu = (e1 * d2.y - e2 * d1.y) / det;
    (det.abs() > 1e-12 && dpdu.is_finite()).then_some(dpdu)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Offsets move every coordinate to the side of `w` and grow with the
    /// coordinates' magnitude, so a point far from the origin still leaves
    /// its plane.
    #[test]
    fn offset_leaves_the_plane_at_every_scale() {
        for scale in [1e-3f32, 1.0, 1e3, 1e6] {
            let p = Vec3::new(0.3, -0.7, 0.5) * scale;
            let n = Vec3::new(0.2, 0.3, 0.9).normalize();
            for w in [n, -n] {
                let o = offset_origin(p, n, w, 0.0);
                let side = (o - p).dot(w);
                assert!(side > 0.0, "scale {scale}: offset {side} not towards w");
                // The plane through p, evaluated in f32 as a ray would: still clear.
                assert!((o.dot(n) - p.dot(n)) * w.dot(n).signum() > 0.0);
                assert!((o - p).length() < 1e-4 * scale.max(1.0));
            }
        }
    }
}
