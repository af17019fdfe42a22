//! The two-level BVH: one compressed wide BVH (obvhs `CwBvh`) per unique mesh,
//! and one over the placed (instance, prototype mesh) pairs, each leaf holding
//! the inverse transform that takes a world ray into the mesh's space.

use std::time::Duration;

use glam::{Affine3A, Mat3A, Vec2, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

use super::intersect::{TriangleHit, WatertightRay};
use crate::scene::{Scene, Transform};

/// Build quality for both levels: obvhs's balanced preset.
const BUILD_PARAMS: BvhBuildParams = BvhBuildParams::medium_build();

/// Largest magnitude of a traversal ray's `inv_direction`. obvhs's own
/// `Ray::new` turns direction components below `f32::EPSILON` into
/// 1/EPSILON (8.4e6), so an axis-parallel ray starting inside a slab by
/// `d` only reaches `t = d * 8.4e6` before the box test fails; 1e30 keeps
/// that reach beyond any scene while every product in obvhs's quantized
/// node test stays finite (an infinite inverse would give 0 * inf = NaN).
const MAX_INV_DIRECTION: f32 = 1e30;

/// Relative padding of every box: a ray exactly on a box face (an
/// axis-aligned ray along a mesh's border), or within rounding of it after
/// the instance transform, is then strictly inside the slab. Each box gets
/// between 1 and 2 times this, varied by its index: PLOC merges only mutual
/// nearest neighbours, and on perfectly regular input (instancer grids,
/// tessellated planes) every candidate ties, one pair merges per pass and the
/// build goes quadratic (100k instances in a row: 22 s instead of 0.1 s).
const BOX_PADDING: f32 = 1e-6;

/// Acceleration structures over a scene's meshes, ready for closest-hit queries.
pub struct Geometry {
    /// Per scene mesh; `None` for a mesh with no triangles.
    meshes: Vec<Option<MeshBvh>>,
    /// Over `leaves`; `None` when nothing is placed.
    top: Option<CwBvh>,
    leaves: Vec<PlacedMesh>,
}

/// One mesh's BVH with its triangles in BVH primitive order.
struct MeshBvh {
    bvh: CwBvh,
    /// `triangles[i]` is scene triangle `bvh.primitive_indices[i]`.
    triangles: Vec<Triangle>,
}

/// One mesh of one instance: a top-level leaf.
struct PlacedMesh {
    mesh_from_world: Affine3A,
    instance: u32,
    prototype_mesh: u32,
    mesh: u32,
}

/// The closest intersection of a ray with the scene's meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the world ray's direction length.
    pub t: f32,
    /// Instance index (into the scene's instance arrays).
    pub instance: u32,
    /// Which of the instance's prototype's meshes: an index into
    /// `prototypes[p].meshes`, whose `mesh` field is the scene mesh.
    pub prototype_mesh: u32,
    /// Triangle index within that mesh.
    pub triangle: u32,
    /// Weights of the triangle's second and third vertices (the first's is
    /// `1 - x - y`).
    pub barycentrics: Vec2,
}

impl Geometry {
    /// Builds one BVH per mesh (in parallel) and the top-level BVH over every
    /// placed mesh. Placements whose transform cannot be inverted (a zero
    /// scale collapses the mesh) cover no area and are left out.
    pub fn build(scene: &Scene) -> Self {
        let m = &scene.manifest;
        let meshes: Vec<Option<MeshBvh>> = m
            .meshes
            .par_iter()
            .map(|mesh| MeshBvh::build(scene.view(&mesh.points), scene.view(&mesh.triangles)))
            .collect();
        let mut leaves = Vec::new();
        let mut boxes = Vec::new();
        let prototypes = scene.view(&m.instances.prototype);
        for (instance, world_from_prototype) in
            scene.view(&m.instances.transform).iter().enumerate()
        {
            let world_from_prototype = affine(world_from_prototype);
            let parts = &m.prototypes[prototypes[instance] as usize].meshes;
            for (prototype_mesh, part) in parts.iter().enumerate() {
                let Some(mesh_bvh) = &meshes[part.mesh as usize] else {
                    continue;
                };
                let world_from_mesh = world_from_prototype * affine(&part.transform);
                let mesh_from_world = world_from_mesh.inverse();
                if !mesh_from_world.is_finite() {
                    continue;
                }
                let world_box = transform_box(&world_from_mesh, &mesh_bvh.bvh.total_aabb);
                boxes.push(padded(world_box, boxes.len()));
                leaves.push(PlacedMesh {
                    mesh_from_world,
                    instance: instance as u32,
                    prototype_mesh: prototype_mesh as u32,
                    mesh: part.mesh,
                });
            }
        }
        let top = (!boxes.is_empty())
            .then(|| build_cwbvh(&boxes, BUILD_PARAMS, &mut Duration::default()));
        Self {
            meshes,
            top,
            leaves,
        }
    }

    /// The closest hit along `ray` within `(ray.tmin, ray.tmax)`, through both
    /// levels: each candidate instance sees the ray in its mesh's space.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let top = self.top.as_ref()?;
        let mut closest = None;
        let ray = traversal_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        top.ray_traverse(ray, &mut RayHit::none(), |ray, id| {
            let leaf = &self.leaves[top.primitive_indices[id] as usize];
            let mesh = self.meshes[leaf.mesh as usize]
                .as_ref()
                .expect("placed meshes have triangles");
            let local = traversal_ray(
                leaf.mesh_from_world.transform_point3a(ray.origin),
                leaf.mesh_from_world.transform_vector3a(ray.direction),
                ray.tmin,
                ray.tmax,
            );
            match mesh.intersect(&local) {
                Some((triangle, hit)) => {
                    closest = Some(Hit {
                        t: hit.t,
                        instance: leaf.instance,
                        prototype_mesh: leaf.prototype_mesh,
                        triangle,
                        barycentrics: hit.barycentrics,
                    });
                    hit.t
                }
                None => f32::INFINITY,
            }
        });
        closest
    }
}

impl MeshBvh {
    fn build(points: &[[f32; 3]], triangles: &[[u32; 3]]) -> Option<Self> {
        if triangles.is_empty() {
            return None;
        }
        let vertex = |i: u32| Vec3A::from_array(points[i as usize]);
        let tris: Vec<Triangle> = triangles
            .iter()
            .map(|&[a, b, c]| Triangle {
                v0: vertex(a),
                v1: vertex(b),
                v2: vertex(c),
            })
            .collect();
        let boxes: Vec<Aabb> = tris
            .iter()
            .enumerate()
            .map(|(i, t)| padded(t.aabb(), i))
            .collect();
        let bvh = build_cwbvh(&boxes, BUILD_PARAMS, &mut Duration::default());
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        Some(Self { bvh, triangles })
    }

    /// The closest triangle hit along a mesh-space ray, as (scene triangle index, hit).
    fn intersect(&self, ray: &Ray) -> Option<(u32, TriangleHit)> {
        let watertight = WatertightRay::new(ray.origin, ray.direction);
        let mut closest = None;
        self.bvh.ray_traverse(*ray, &mut RayHit::none(), |ray, id| {
            let tri = &self.triangles[id];
            match watertight.intersect(tri.v0, tri.v1, tri.v2, ray.tmin, ray.tmax) {
                Some(hit) => {
                    closest = Some((self.bvh.primitive_indices[id], hit));
                    hit.t
                }
                None => f32::INFINITY,
            }
        });
        closest
    }
}

/// The format's 3x4 row-major `[R | t]` as a glam affine map.
fn affine(m: &Transform) -> Affine3A {
    Affine3A {
        matrix3: Mat3A::from_cols(
            Vec3A::new(m[0], m[4], m[8]),
            Vec3A::new(m[1], m[5], m[9]),
            Vec3A::new(m[2], m[6], m[10]),
        ),
        translation: Vec3A::new(m[3], m[7], m[11]),
    }
}

/// A box containing the image of `b` under `m` (its eight corners' bounds).
fn transform_box(m: &Affine3A, b: &Aabb) -> Aabb {
    let mut out = Aabb::INVALID;
    for corner in 0..8 {
        let pick = |bit: usize, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi };
        let p = Vec3A::new(
            pick(1, b.min.x, b.max.x),
            pick(2, b.min.y, b.max.y),
            pick(4, b.min.z, b.max.z),
        );
        out.extend(m.transform_point3a(p));
    }
    out
}

/// An obvhs ray with `inv_direction` clamped to [`MAX_INV_DIRECTION`].
fn traversal_ray(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Ray {
    let max = Vec3A::splat(MAX_INV_DIRECTION);
    Ray {
        origin,
        direction,
        inv_direction: direction.recip().clamp(-max, max),
        tmin,
        tmax,
    }
}

/// Box `index` grown on each side by 1 to 2 times [`BOX_PADDING`] of its
/// coordinates' magnitude (plus a tiny absolute amount, so a face at 0 moves
/// too); the factor is a hash of `index`, to break PLOC's ties.
fn padded(b: Aabb, index: usize) -> Aabb {
    let jitter = 1.0 + ((index as u32).wrapping_mul(0x9e37_79b9) >> 8) as f32 / (1 << 24) as f32;
    let pad = b.min.abs().max(b.max.abs()) * (BOX_PADDING * jitter) + 1e-20;
    Aabb::new(b.min - pad, b.max + pad)
}
