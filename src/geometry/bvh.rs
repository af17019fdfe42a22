//! The scene's BVHs. A mesh placed exactly once goes, in world space, into one
//! BVH over every such mesh's triangles ([`WorldMeshes`]): a ray then walks one
//! tree where the placed meshes overlap (the StandardShaderBall's twelve
//! meshes), not one tree per mesh under a top level. A mesh placed more than
//! once keeps two levels: one compressed wide BVH (obvhs `CwBvh`) per such
//! mesh, and a top level over its placed (instance, prototype mesh) pairs,
//! each leaf holding the inverse transform that takes a world ray into the
//! mesh's space. A ray tests both, the second cut to the first's hit.
//!
//! The top level is shaped by memory (`cirrus bench instances`, a million
//! instances, 250 MB budget). One obvhs build over every placed mesh peaks
//! far above that: PLOC holds 48-byte BVH2 nodes three times over (two work
//! arrays and the output, about 225 MB), and the BVH2-to-CWBVH conversion
//! adds a decision table of 7 entries per BVH2 node (112 MB). So the top level
//! ([`TopLevel`]) is built in Morton-ordered chunks, each a small CWBVH, under
//! a CWBVH over the chunks: those temporaries then only ever cover one chunk
//! per thread.

use glam::{Affine3A, Vec2, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use rayon::prelude::*;

use super::boxes::{local_ray, padded, transform_box, traversal_ray};
use super::intersect::{TriangleHit, WatertightRay};
use super::motion::MovingInstances;
use super::round_bvh::{RoundShapes, ShapeHit};
use super::round_intersect::RoundHit;
use super::surface::{MeshShading, SurfacePoint};
use super::top_level::{build_cwbvh, TopLevel};
use crate::motion::{Bracket, TransformTrack};
use crate::scene::{affine, Scene};

/// Acceleration structures over a scene's meshes, ready for closest-hit and
/// occlusion queries, with the per-vertex data that shading interpolates.
pub struct Geometry {
    /// Per scene mesh placed more than once; `None` for every other mesh
    /// (no triangles, never placed, or placed once and so in `world`).
    meshes: Vec<Option<MeshBvh>>,
    /// Per scene mesh: vertices, normals, texture coordinates, materials.
    shading: Vec<MeshShading>,
    /// The meshes placed once, in world space; `None` when there are none.
    world: Option<WorldMeshes>,
    /// Over the leaves that place a mesh placed more than once (the first
    /// ones of `leaves`); `None` when there are none.
    top: Option<TopLevel>,
    /// Every placed mesh: the top level's leaves (placements of meshes
    /// placed more than once) first, then the placements in `world`.
    leaves: Vec<PlacedMesh>,
    /// World-from-mesh tracks of the placements of moving instances (all
    /// top-level leaves), indexed by [`PlacedMesh::motion`].
    tracks: Vec<TransformTrack>,
    /// The points and curves prims; `None` when the scene places none.
    round: Option<RoundShapes>,
}

/// How a scene mesh enters the BVHs, by how often the scene places it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MeshRole {
    /// No triangles, or never placed: in no BVH.
    Unused,
    /// Placed exactly once: its world-space triangles go into [`WorldMeshes`].
    Flattened,
    /// Placed more than once, or by a moving instance: one mesh-space BVH,
    /// shared under the top level.
    Instanced,
}

/// One mesh's BVH with its triangles in BVH primitive order.
///
/// A deforming mesh's BVH bounds each triangle by the union of its boxes
/// at the keys, which holds it at every time in between (each vertex moves
/// linearly between keys, so the triangle stays in the hull of its key
/// positions), and a ray lerps the triangle's vertices to its own time.
/// obvhs builds static trees, so the alternative, refitting per time step,
/// would mean one tree per step (memory times the steps, and a ray's time
/// still between steps) or a refit per ray; the union costs one build and
/// looser boxes where triangles travel far relative to their size
/// (`cirrus bench motion`, the deforming rows, measures what it costs).
struct MeshBvh {
    bvh: CwBvh,
    /// `triangles[i]` is input triangle `bvh.primitive_indices[i]`; for a
    /// deforming mesh, every key's triangles so ordered, key-major.
    triangles: Vec<Triangle>,
    /// A deforming mesh's key times, frames; empty for a still one.
    times: Vec<f32>,
}

/// The world-space triangles of every mesh placed once, under one BVH.
struct WorldMeshes {
    mesh: MeshBvh,
    /// Per input triangle of `mesh`: where it comes from.
    sources: Vec<TriangleSource>,
}

/// A world-space triangle's placed mesh and triangle index within that mesh.
#[derive(Clone, Copy, Debug)]
struct TriangleSource {
    /// Index into [`Geometry::leaves`].
    leaf: u32,
    /// Triangle index within the scene mesh.
    triangle: u32,
}

/// One mesh of one instance: a top-level leaf.
struct PlacedMesh {
    /// At the frame itself; a moving placement's is at the ray's time.
    mesh_from_world: Affine3A,
    instance: u32,
    prototype_mesh: u32,
    mesh: u32,
    /// Index into [`Geometry::tracks`]; [`STATIC`] when it does not move.
    motion: u32,
}

/// [`PlacedMesh::motion`] of a placement that does not move.
const STATIC: u32 = u32::MAX;

/// The closest intersection of a ray with the scene's meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the world ray's direction length.
    pub t: f32,
    /// Instance index (into the scene's instance arrays).
    pub instance: u32,
    /// Which of the instance's prototype's meshes: an index into
    /// `prototypes[p].meshes`, whose `mesh` field is the scene mesh; for a
    /// points or curves prim, the mesh count plus its position among the
    /// prototype's points, then curves parts.
    pub prototype_mesh: u32,
    /// Triangle index within that mesh (point, or curve piece).
    pub triangle: u32,
    /// Weights of the triangle's second and third vertices (the first's is
    /// `1 - x - y`); on a curve piece, the fraction along it and 0.
    pub barycentrics: Vec2,
    /// The placed mesh hit (an index into `Geometry::leaves`), or the
    /// placed points or curves prim.
    leaf: u32,
    /// The sphere or tube hit, for points and curves.
    round: Option<RoundHit>,
    /// The ray's time, frames: where a moving mesh was when hit.
    time: f32,
}

/// Per triangle, resident: the BVH's triangle copy (three `Vec3A`, 48
/// bytes), its primitive index (4) and CWBVH nodes (80 bytes per node, about
/// one node per four triangles: 20).
const BVH_BYTES_PER_TRIANGLE: u64 = 48 + 4 + 20;
/// Per triangle while its mesh's BVH is built: boxes (32 bytes), the
/// triangle list (48), PLOC's three arrays of 48-byte BVH2 nodes over 2n
/// nodes (288) and the CWBVH conversion's table of 7 x 16 bytes per node (224).
const BVH_BUILD_BYTES_PER_TRIANGLE: u64 = 32 + 48 + 288 + 224;
/// Per placed mesh (instance x prototype mesh): the top-level leaf (an
/// `Affine3A` and three `u32`, 64 bytes), its box (32) and its share of the
/// chunked top-level CWBVH and its build (48).
const TOP_LEVEL_BYTES_PER_PLACEMENT: u64 = 64 + 32 + 48;

impl Geometry {
    /// Bytes [`Geometry::build`] holds at its peak for a scene of
    /// `mesh_bytes` bytes of mesh arrays (its shading copy is as large),
    /// `triangles` triangles, of which `building` are in the meshes built at
    /// once (the largest, one per worker thread), and `placements` placed
    /// meshes, points and curves prims (instance x prototype part), and
    /// `[elements, building]` points and curve pieces, `building` of them in
    /// the prims built at once, estimated from the scene alone.
    pub fn bytes_for(
        mesh_bytes: u64,
        triangles: u64,
        building: u64,
        placements: u64,
        [elements, elements_building]: [u64; 2],
    ) -> u64 {
        mesh_bytes
            + triangles * BVH_BYTES_PER_TRIANGLE
            + building * BVH_BUILD_BYTES_PER_TRIANGLE
            + placements * TOP_LEVEL_BYTES_PER_PLACEMENT
            + RoundShapes::bytes_for(elements, elements_building)
    }

    /// Bytes [`Geometry::build`] adds for motion keys under an open shutter:
    /// per triangle per key of a deforming mesh, its keyed BVH's copy and
    /// the per-key list that copy is gathered from (three `Vec3A` each, 96
    /// bytes); per vertex value per key (points, and normals where the mesh
    /// has them) the shading keys (a `Vec3`, 12); per point per key of
    /// moving points and per vertex per key of deforming curves, its sphere
    /// (a `Vec4`, 16).
    pub fn keyed_bytes_for(triangle_keys: u64, vertex_keys: u64, sphere_keys: u64) -> u64 {
        triangle_keys * (48 + 48) + vertex_keys * 12 + sphere_keys * 16
    }

    /// Builds the world-space BVH over the meshes placed once, one BVH per
    /// mesh placed more than once or moving (in parallel), and the
    /// top-level BVH over those meshes' placements. Placements whose
    /// transform cannot be inverted (a zero scale collapses the mesh) cover
    /// no area and are left out. Without `motion` (a shutter closed at the
    /// frame) every instance stays where it is at the frame.
    pub fn build(scene: &Scene, motion: bool) -> Self {
        let m = &scene.manifest;
        let moving = MovingInstances::new(scene, motion);
        let roles = mesh_roles(scene, &moving, motion);
        let meshes: Vec<Option<MeshBvh>> = m
            .meshes
            .par_iter()
            .zip(&roles)
            .map(|(mesh, role)| match (role, mesh.motion.as_ref()) {
                (MeshRole::Instanced, Some(keys)) if motion => MeshBvh::build_keyed(
                    keys.times.clone(),
                    scene
                        .view(&keys.points)
                        .chunks_exact(mesh.points.count as usize)
                        .map(|points| {
                            let triangles = scene.view(&mesh.triangles);
                            mesh_triangles(points, triangles, Affine3A::IDENTITY).collect()
                        })
                        .collect(),
                ),
                (MeshRole::Instanced, _) => MeshBvh::build(
                    mesh_triangles(
                        scene.view(&mesh.points),
                        scene.view(&mesh.triangles),
                        Affine3A::IDENTITY,
                    )
                    .collect(),
                ),
                _ => None,
            })
            .collect();
        let shading = m
            .meshes
            .iter()
            .map(|mesh| MeshShading::new(scene, mesh, motion))
            .collect();
        // Boxes first, leaves after the top level is built: the two are
        // never held together (32 MB and 64 MB at a million instances).
        // A moving mesh's box: the union of its boxes at the keys, which
        // bounds it at every time in between (matrix lerp).
        let boxes: Vec<Aabb> = placements(scene, &roles, MeshRole::Instanced, &moving)
            .enumerate()
            .map(|(i, (leaf, world_from_mesh))| {
                let mesh_box = &meshes[leaf.placed.mesh as usize]
                    .as_ref()
                    .expect("instanced meshes have a BVH")
                    .bvh
                    .total_aabb;
                let keys = match &leaf.track {
                    Some(track) => track.keys(),
                    None => std::slice::from_ref(&world_from_mesh),
                };
                let union = keys.iter().fold(Aabb::INVALID, |b, key| {
                    b.union(&transform_box(key, mesh_box))
                });
                padded(union, i)
            })
            .collect();
        let count = boxes.len();
        let top = (count > 0).then(|| TopLevel::build(boxes));
        // Sized exactly: a million leaves grown by doubling would briefly
        // take twice their size.
        let flattened: Vec<_> = placements(scene, &roles, MeshRole::Flattened, &moving)
            .map(|(leaf, world_from_mesh)| (leaf.placed, world_from_mesh))
            .collect();
        let mut leaves = Vec::with_capacity(count + flattened.len());
        let mut tracks = Vec::new();
        let instanced = placements(scene, &roles, MeshRole::Instanced, &moving);
        leaves.extend(instanced.map(|(mut leaf, _)| {
            if let Some(track) = leaf.track {
                leaf.placed.motion = tracks.len() as u32;
                tracks.push(track);
            }
            leaf.placed
        }));
        let world = WorldMeshes::build(scene, flattened, &mut leaves);
        Self {
            meshes,
            shading,
            world,
            top,
            leaves,
            tracks,
            round: RoundShapes::build(scene, &moving, motion),
        }
    }

    /// The closest hit along `ray` within `(ray.tmin, ray.tmax)` at `time`
    /// (frames; it places the moving meshes): first in the world-space BVH,
    /// then through both levels of the instanced meshes, where each
    /// candidate instance sees the ray in its mesh's space.
    pub fn intersect(&self, ray: &Ray, time: f32) -> Option<Hit> {
        let mut ray = traversal_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        let mut closest = self.world.as_ref().and_then(|world| {
            let (index, hit) = world.mesh.intersect(&ray, time)?;
            let source = world.sources[index as usize];
            Some(self.hit(source.leaf, source.triangle, hit, time))
        });
        if let Some(hit) = &closest {
            ray.tmax = hit.t;
        }
        if let Some(top) = &self.top {
            top.traverse(ray, |ray, index| {
                let leaf = &self.leaves[index];
                let found = self
                    .local_ray(leaf, ray, time)
                    .and_then(|local| self.mesh(leaf).intersect(&local, time));
                match found {
                    Some((triangle, hit)) => {
                        closest = Some(self.hit(index as u32, triangle, hit, time));
                        hit.t
                    }
                    None => f32::INFINITY,
                }
            });
        }
        if let Some(hit) = &closest {
            ray.tmax = hit.t;
        }
        let round = self.round.as_ref().and_then(|r| r.intersect(ray, time));
        round.map(|hit| self.round_hit(hit, time)).or(closest)
    }

    /// Whether anything blocks `ray` within `(ray.tmin, ray.tmax)` at
    /// `time` (frames): a shadow ray's query, which stops at the first hit
    /// found, nearest or not.
    pub fn occluded(&self, ray: &Ray, time: f32) -> bool {
        let ray = traversal_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        self.world
            .as_ref()
            .is_some_and(|world| world.mesh.occluded(&ray, time))
            || self.top.as_ref().is_some_and(|top| {
                top.any(ray, |ray, index| {
                    let leaf = &self.leaves[index];
                    self.local_ray(leaf, ray, time)
                        .is_some_and(|local| self.mesh(leaf).occluded(&local, time))
                })
            })
            || self.round.as_ref().is_some_and(|r| r.occluded(ray, time))
    }

    /// The shading data of `hit`, a hit of `ray` (see [`SurfacePoint`]): the
    /// point from the barycentric weights of the mesh-space vertices (not the
    /// ray parameter, which is less precise far from the origin), normals and
    /// tangents through the placement's inverse transpose.
    pub fn surface_point(&self, hit: &Hit) -> SurfacePoint {
        if let (Some(round), Some(on)) = (&self.round, hit.round) {
            let (leaf, element) = (hit.leaf, hit.triangle);
            return round.surface_point(
                &ShapeHit {
                    leaf,
                    element,
                    hit: on,
                },
                hit.time,
            );
        }
        let leaf = &self.leaves[hit.leaf as usize];
        self.shading[leaf.mesh as usize].surface_point(
            &self.mesh_from_world(leaf, hit.time),
            hit.triangle,
            hit.barycentrics,
            [hit.instance, hit.prototype_mesh, leaf.mesh],
            hit.time,
        )
    }

    /// The [`Hit`] of triangle `triangle` of placed mesh `leaf` at `time`.
    fn hit(&self, leaf: u32, triangle: u32, hit: TriangleHit, time: f32) -> Hit {
        let placed = &self.leaves[leaf as usize];
        Hit {
            t: hit.t,
            instance: placed.instance,
            prototype_mesh: placed.prototype_mesh,
            triangle,
            barycentrics: hit.barycentrics,
            leaf,
            round: None,
            time,
        }
    }

    /// The [`Hit`] of a points or curves hit at `time`.
    fn round_hit(&self, hit: ShapeHit, time: f32) -> Hit {
        let round = self
            .round
            .as_ref()
            .expect("round hits come from round shapes");
        let [instance, prototype_mesh, _] = round.ids(hit.leaf);
        Hit {
            t: hit.hit.t,
            instance,
            prototype_mesh,
            triangle: hit.element,
            barycentrics: Vec2::new(hit.hit.s, 0.0),
            leaf: hit.leaf,
            round: Some(hit.hit),
            time,
        }
    }

    /// `leaf`'s mesh-from-world transform at `time` (frames): its own for
    /// a static placement, the inverse of its track's for a moving one.
    fn mesh_from_world(&self, leaf: &PlacedMesh, time: f32) -> Affine3A {
        match self.tracks.get(leaf.motion as usize) {
            Some(track) => track.at(time).inverse(),
            None => leaf.mesh_from_world,
        }
    }

    /// A world traversal ray in `leaf`'s mesh space at `time` (see
    /// [`local_ray`]).
    fn local_ray(&self, leaf: &PlacedMesh, ray: &Ray, time: f32) -> Option<Ray> {
        local_ray(self.mesh_from_world(leaf, time), ray)
    }

    fn mesh(&self, leaf: &PlacedMesh) -> &MeshBvh {
        self.meshes[leaf.mesh as usize]
            .as_ref()
            .expect("instanced meshes have a BVH")
    }
}

impl WorldMeshes {
    /// The BVH over `placed`, the placements of the [`MeshRole::Flattened`]
    /// meshes with their world-from-mesh transforms, their triangles carried
    /// to world space; appends those placements to `leaves`. `None` when
    /// there are none.
    fn build(
        scene: &Scene,
        placed: Vec<(PlacedMesh, Affine3A)>,
        leaves: &mut Vec<PlacedMesh>,
    ) -> Option<Self> {
        let m = &scene.manifest;
        // Sized exactly: these arrays are as large as the flattened geometry.
        let count = placed
            .iter()
            .map(|(leaf, _)| scene.view(&m.meshes[leaf.mesh as usize].triangles).len())
            .sum();
        let (mut triangles, mut sources) = (Vec::with_capacity(count), Vec::with_capacity(count));
        for (leaf, world_from_mesh) in placed {
            let mesh = &m.meshes[leaf.mesh as usize];
            let first = triangles.len();
            triangles.extend(mesh_triangles(
                scene.view(&mesh.points),
                scene.view(&mesh.triangles),
                world_from_mesh,
            ));
            let index = leaves.len() as u32;
            sources.extend(
                (0..(triangles.len() - first) as u32).map(|triangle| TriangleSource {
                    leaf: index,
                    triangle,
                }),
            );
            leaves.push(leaf);
        }
        Some(Self {
            mesh: MeshBvh::build(triangles)?,
            sources,
        })
    }
}

impl MeshBvh {
    /// The BVH over `triangles` (input order is what [`Self::intersect`]
    /// returns); `None` when there are none.
    fn build(triangles: Vec<Triangle>) -> Option<Self> {
        if triangles.is_empty() {
            return None;
        }
        let boxes: Vec<Aabb> = triangles
            .iter()
            .enumerate()
            .map(|(i, t)| padded(t.aabb(), i))
            .collect();
        let bvh = build_cwbvh(boxes);
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| triangles[i as usize])
            .collect();
        Some(Self {
            bvh,
            triangles,
            times: Vec::new(),
        })
    }

    /// The BVH of a deforming mesh with triangles `keys[k]` at key time
    /// `times[k]` (frames): over each triangle's union of key boxes (see
    /// [`MeshBvh`]); `None` when there are no triangles.
    fn build_keyed(times: Vec<f32>, keys: Vec<Vec<Triangle>>) -> Option<Self> {
        let first = keys.first().filter(|k| !k.is_empty())?;
        let boxes: Vec<Aabb> = (0..first.len())
            .map(|i| {
                let union = keys
                    .iter()
                    .fold(Aabb::INVALID, |b, key| b.union(&key[i].aabb()));
                padded(union, i)
            })
            .collect();
        let bvh = build_cwbvh(boxes);
        let triangles = keys
            .iter()
            .flat_map(|key| bvh.primitive_indices.iter().map(|&i| key[i as usize]))
            .collect();
        Some(Self {
            bvh,
            triangles,
            times,
        })
    }

    /// BVH triangle `id` at `time` (frames): a deforming mesh's lerped
    /// between the keys around it, per vertex.
    #[inline]
    fn triangle(&self, id: usize, at: Option<&Bracket>) -> Triangle {
        let Some(at) = at else {
            return self.triangles[id];
        };
        let n = self.bvh.primitive_indices.len();
        let (a, b) = (
            &self.triangles[at.before * n + id],
            &self.triangles[at.after * n + id],
        );
        Triangle {
            v0: at.lerp(a.v0, b.v0),
            v1: at.lerp(a.v1, b.v1),
            v2: at.lerp(a.v2, b.v2),
        }
    }

    /// Where `time` (frames) falls among a deforming mesh's keys.
    fn bracket(&self, time: f32) -> Option<Bracket> {
        (!self.times.is_empty()).then(|| Bracket::at(&self.times, time))
    }

    /// The closest triangle hit along a ray in the triangles' space at
    /// `time` (frames), as (input triangle index, hit).
    fn intersect(&self, ray: &Ray, time: f32) -> Option<(u32, TriangleHit)> {
        let watertight = WatertightRay::new(ray.origin, ray.direction);
        let at = self.bracket(time);
        let mut closest = None;
        self.bvh.ray_traverse(*ray, &mut RayHit::none(), |ray, id| {
            let tri = &self.triangle(id, at.as_ref());
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

    /// Whether any triangle is hit along a ray in the triangles' space at
    /// `time` (frames).
    fn occluded(&self, ray: &Ray, time: f32) -> bool {
        let watertight = WatertightRay::new(ray.origin, ray.direction);
        let at = self.bracket(time);
        !self.bvh.ray_traverse_miss(*ray, |ray, id| {
            let tri = &self.triangle(id, at.as_ref());
            watertight
                .intersect(tri.v0, tri.v1, tri.v2, ray.tmin, ray.tmax)
                .map_or(f32::INFINITY, |hit| hit.t)
        })
    }
}

/// Each scene mesh's [`MeshRole`]: how many times the instances place it,
/// counted per prototype (a placement whose transform turns out singular
/// still counts; a moving instance's counts twice, as its mesh cannot be
/// carried to world space once), and whether it has triangles. With
/// `motion`, a deforming mesh placed at all is instanced: its triangles
/// move, so they cannot be carried to world space once either.
fn mesh_roles(scene: &Scene, moving: &MovingInstances, motion: bool) -> Vec<MeshRole> {
    let m = &scene.manifest;
    let mut instances_of = vec![0u64; m.prototypes.len()];
    for (instance, &prototype) in scene.view(&m.instances.prototype).iter().enumerate() {
        instances_of[prototype as usize] += if moving.moves(instance as u32) { 2 } else { 1 };
    }
    let mut placed = vec![0u64; m.meshes.len()];
    for (prototype, &count) in m.prototypes.iter().zip(&instances_of) {
        for part in &prototype.meshes {
            placed[part.mesh as usize] += count;
        }
    }
    m.meshes
        .iter()
        .zip(placed)
        .map(|(mesh, placed)| match placed {
            _ if scene.view(&mesh.triangles).is_empty() => MeshRole::Unused,
            0 => MeshRole::Unused,
            1 if !(motion && mesh.motion.is_some()) => MeshRole::Flattened,
            _ => MeshRole::Instanced,
        })
        .collect()
}

/// The triangles of a mesh (`points` and vertex-index `triangles`), each
/// vertex carried by `to`.
fn mesh_triangles<'a>(
    points: &'a [[f32; 3]],
    triangles: &'a [[u32; 3]],
    to: Affine3A,
) -> impl Iterator<Item = Triangle> + 'a {
    let vertex = move |i: u32| to.transform_point3a(Vec3A::from_array(points[i as usize]));
    triangles.iter().map(move |&[a, b, c]| Triangle {
        v0: vertex(a),
        v1: vertex(b),
        v2: vertex(c),
    })
}

/// A placed mesh as [`placements`] finds it: the leaf, and the track of a
/// moving one (its `motion` index is set when the track is stored).
struct Placement {
    placed: PlacedMesh,
    track: Option<TransformTrack>,
}

/// Every placed mesh of `scene` whose role is `role`, in instance order,
/// with its world-from-mesh transform at the frame, except placements whose
/// transform at the frame cannot be inverted (a zero scale collapses the
/// mesh, which then covers no area).
fn placements<'a>(
    scene: &'a Scene,
    roles: &'a [MeshRole],
    role: MeshRole,
    moving: &'a MovingInstances,
) -> impl Iterator<Item = (Placement, Affine3A)> + 'a {
    let m = &scene.manifest;
    let prototypes = scene.view(&m.instances.prototype);
    let transforms = scene.view(&m.instances.transform);
    transforms.iter().zip(prototypes).enumerate().flat_map(
        move |(instance, (world_from_prototype, &prototype))| {
            let parts = &m.prototypes[prototype as usize].meshes;
            parts
                .iter()
                .enumerate()
                .filter(move |(_, part)| roles[part.mesh as usize] == role)
                .filter_map(move |(prototype_mesh, part)| {
                    let prototype_from_mesh = affine(&part.transform);
                    let world_from_mesh = affine(world_from_prototype) * prototype_from_mesh;
                    let mesh_from_world = world_from_mesh.inverse();
                    let placed = PlacedMesh {
                        mesh_from_world,
                        instance: instance as u32,
                        prototype_mesh: prototype_mesh as u32,
                        mesh: part.mesh,
                        motion: STATIC,
                    };
                    let track = moving.mesh_track(instance as u32, prototype_from_mesh);
                    mesh_from_world
                        .is_finite()
                        .then_some((Placement { placed, track }, world_from_mesh))
                })
        },
    )
}
