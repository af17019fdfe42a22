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

use std::ops::Range;

use glam::{Affine3A, Vec2, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ploc::morton::morton_encode_u64_unorm;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

use super::intersect::{TriangleHit, WatertightRay};
use super::motion::MovingInstances;
use super::surface::{MeshShading, SurfacePoint};
use crate::motion::TransformTrack;
use crate::scene::{affine, Scene};

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

/// Placed meshes per chunk of the top level, each chunk built on its own
/// (see [`TopLevel`]): small enough that a chunk's build temporaries are a
/// few MB, large enough that the tree over the chunks stays small.
const TOP_CHUNK: usize = 1 << 14;

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
struct MeshBvh {
    bvh: CwBvh,
    /// `triangles[i]` is input triangle `bvh.primitive_indices[i]`.
    triangles: Vec<Triangle>,
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

/// The top-level BVH over the placed meshes, in two tiers: the placed
/// meshes are sorted along a Morton curve of their box centres and cut into
/// Morton cells of at most [`TOP_CHUNK`] ([`morton_cells`]), each cell gets
/// its own CWBVH (built in parallel),
/// and one CWBVH goes over the runs' boxes. This is the Morton split of an
/// LBVH (Lauterbach et al. 2009, "Fast BVH Construction on GPUs") above PLOC
/// subtrees; a ray walks the root, then each chunk it enters.
struct TopLevel {
    /// Over the chunks' `total_aabb`s; its primitives index `chunks`.
    root: CwBvh,
    /// Each chunk's `primitive_indices` index [`Geometry::leaves`] directly.
    chunks: Vec<CwBvh>,
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
    /// `prototypes[p].meshes`, whose `mesh` field is the scene mesh.
    pub prototype_mesh: u32,
    /// Triangle index within that mesh.
    pub triangle: u32,
    /// Weights of the triangle's second and third vertices (the first's is
    /// `1 - x - y`).
    pub barycentrics: Vec2,
    /// The placed mesh hit (an index into `Geometry::leaves`).
    leaf: u32,
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
    /// meshes (instance x prototype mesh), estimated from the scene alone.
    pub fn bytes_for(mesh_bytes: u64, triangles: u64, building: u64, placements: u64) -> u64 {
        mesh_bytes
            + triangles * BVH_BYTES_PER_TRIANGLE
            + building * BVH_BUILD_BYTES_PER_TRIANGLE
            + placements * TOP_LEVEL_BYTES_PER_PLACEMENT
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
        let roles = mesh_roles(scene, &moving);
        let meshes: Vec<Option<MeshBvh>> = m
            .meshes
            .par_iter()
            .zip(&roles)
            .map(|(mesh, role)| match role {
                MeshRole::Instanced => MeshBvh::build(
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
            .map(|mesh| MeshShading::new(scene, mesh))
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
        }
    }

    /// The closest hit along `ray` within `(ray.tmin, ray.tmax)` at `time`
    /// (frames; it places the moving meshes): first in the world-space BVH,
    /// then through both levels of the instanced meshes, where each
    /// candidate instance sees the ray in its mesh's space.
    pub fn intersect(&self, ray: &Ray, time: f32) -> Option<Hit> {
        let mut ray = traversal_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        let mut closest = self.world.as_ref().and_then(|world| {
            let (index, hit) = world.mesh.intersect(&ray)?;
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
                    .and_then(|local| self.mesh(leaf).intersect(&local));
                match found {
                    Some((triangle, hit)) => {
                        closest = Some(self.hit(index as u32, triangle, hit, time));
                        hit.t
                    }
                    None => f32::INFINITY,
                }
            });
        }
        closest
    }

    /// Whether anything blocks `ray` within `(ray.tmin, ray.tmax)` at
    /// `time` (frames): a shadow ray's query, which stops at the first hit
    /// found, nearest or not.
    pub fn occluded(&self, ray: &Ray, time: f32) -> bool {
        let ray = traversal_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        self.world
            .as_ref()
            .is_some_and(|world| world.mesh.occluded(&ray))
            || self.top.as_ref().is_some_and(|top| {
                top.any(ray, |ray, index| {
                    let leaf = &self.leaves[index];
                    self.local_ray(leaf, ray, time)
                        .is_some_and(|local| self.mesh(leaf).occluded(&local))
                })
            })
    }

    /// The shading data of `hit`, a hit of `ray` (see [`SurfacePoint`]): the
    /// point from the barycentric weights of the mesh-space vertices (not the
    /// ray parameter, which is less precise far from the origin), normals and
    /// tangents through the placement's inverse transpose.
    pub fn surface_point(&self, hit: &Hit) -> SurfacePoint {
        let leaf = &self.leaves[hit.leaf as usize];
        self.shading[leaf.mesh as usize].surface_point(
            &self.mesh_from_world(leaf, hit.time),
            hit.triangle,
            hit.barycentrics,
            [hit.instance, hit.prototype_mesh, leaf.mesh],
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

    /// A world traversal ray in `leaf`'s mesh space at `time`, with the
    /// same parameterisation (`t` means the same point in both spaces);
    /// `None` when a moving placement collapses at that time.
    fn local_ray(&self, leaf: &PlacedMesh, ray: &Ray, time: f32) -> Option<Ray> {
        let mesh_from_world = self.mesh_from_world(leaf, time);
        mesh_from_world.is_finite().then(|| {
            traversal_ray(
                mesh_from_world.transform_point3a(ray.origin),
                mesh_from_world.transform_vector3a(ray.direction),
                ray.tmin,
                ray.tmax,
            )
        })
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
        Some(Self { bvh, triangles })
    }

    /// The closest triangle hit along a ray in the triangles' space, as
    /// (input triangle index, hit).
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

    /// Whether any triangle is hit along a ray in the triangles' space.
    fn occluded(&self, ray: &Ray) -> bool {
        let watertight = WatertightRay::new(ray.origin, ray.direction);
        !self.bvh.ray_traverse_miss(*ray, |ray, id| {
            let tri = &self.triangles[id];
            watertight
                .intersect(tri.v0, tri.v1, tri.v2, ray.tmin, ray.tmax)
                .map_or(f32::INFINITY, |hit| hit.t)
        })
    }
}

impl TopLevel {
    /// Builds the top level over the placed meshes' world boxes (in
    /// placement order; primitive indices refer to that order). `boxes` and
    /// the Morton codes are freed before the root is built.
    fn build(boxes: Vec<Aabb>) -> Self {
        let mut centres = Aabb::INVALID;
        for b in &boxes {
            centres.extend(b.center());
        }
        let scale = (centres.max - centres.min)
            .max(Vec3A::splat(f32::MIN_POSITIVE))
            .recip();
        let mut keyed: Vec<(u64, u32)> = boxes
            .par_iter()
            .enumerate()
            .map(|(i, b)| {
                let unit = ((b.center() - centres.min) * scale)
                    .clamp(Vec3A::ZERO, Vec3A::splat(MORTON_MAX));
                (morton_encode_u64_unorm(unit.as_dvec3()), i as u32)
            })
            .collect();
        keyed.par_sort_unstable();
        let mut runs = Vec::new();
        morton_cells(&keyed, 0..keyed.len(), &mut runs);
        let chunks: Vec<CwBvh> = runs
            .into_par_iter()
            .map(|run| {
                let ids = &keyed[run];
                let mut bvh = build_cwbvh(ids.iter().map(|&(_, i)| boxes[i as usize]).collect());
                for index in &mut bvh.primitive_indices {
                    *index = ids[*index as usize].1;
                }
                // obvhs reserves a node per primitive, about four times what
                // a chunk uses; kept for every chunk, that would be 80 MB.
                bvh.nodes.shrink_to_fit();
                bvh
            })
            .collect();
        drop((keyed, boxes));
        let root = build_cwbvh(chunks.iter().map(|chunk| chunk.total_aabb).collect());
        Self { root, chunks }
    }

    /// Calls `hit(ray, leaf)` for each top-level leaf (an index into
    /// [`Geometry::leaves`]) whose box `ray` enters, with `ray.tmax` cut to
    /// the nearest hit so far; `hit` returns its hit's `t`, or infinity for a
    /// miss, as obvhs's traversal closures do.
    fn traverse(&self, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> f32) {
        self.root.ray_traverse(ray, &mut RayHit::none(), |ray, id| {
            let chunk = &self.chunks[self.root.primitive_indices[id] as usize];
            let mut nearest = f32::INFINITY;
            chunk.ray_traverse(*ray, &mut RayHit::none(), |ray, id| {
                let t = hit(ray, chunk.primitive_indices[id] as usize);
                nearest = nearest.min(t);
                t
            });
            nearest
        });
    }

    /// Whether `hit(ray, leaf)` is true for any top-level leaf whose box
    /// `ray` enters; stops at the first.
    fn any(&self, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> bool) -> bool {
        let found = |yes: bool| if yes { 0.0 } else { f32::INFINITY };
        !self.root.ray_traverse_miss(ray, |ray, id| {
            let chunk = &self.chunks[self.root.primitive_indices[id] as usize];
            found(!chunk.ray_traverse_miss(*ray, |ray, id| {
                found(hit(ray, chunk.primitive_indices[id] as usize))
            }))
        })
    }
}

/// A CWBVH over `boxes`, as obvhs's `build_cwbvh` makes it (PLOC, the
/// reinsertion optimizer, then conversion to BVH8), minus its debug-build
/// validation, and with `boxes` freed as soon as PLOC has copied them.
fn build_cwbvh(boxes: Vec<Aabb>) -> CwBvh {
    let p = BUILD_PARAMS;
    let mut bvh2 = PlocBuilder::with_capacity(boxes.len()).build(
        p.ploc_search_distance,
        &boxes,
        (0..boxes.len() as u32).collect(),
        p.sort_precision,
        p.search_depth_threshold,
    );
    drop(boxes);
    ReinsertionOptimizer::default().run(&mut bvh2, p.reinsertion_batch_ratio, None);
    bvh2_to_cwbvh(&bvh2, p.max_prims_per_leaf.clamp(1, 3), true, false)
}

/// Splits `keyed[range]` (sorted by Morton code) into runs of at most
/// [`TOP_CHUNK`], cutting at the highest bit where the range's first and last
/// codes differ, as an LBVH splits: each run is then one cell of the Morton
/// octree, compact in space, where a fixed-size stretch of the curve can
/// jump across the scene and give its chunk a box overlapping its
/// neighbours'. Runs of one repeated code are halved by count.
fn morton_cells(keyed: &[(u64, u32)], range: Range<usize>, runs: &mut Vec<Range<usize>>) {
    if range.len() <= TOP_CHUNK {
        runs.push(range);
        return;
    }
    let (first, last) = (keyed[range.start].0, keyed[range.end - 1].0);
    let mid = if first == last {
        range.start + range.len() / 2
    } else {
        let bit = 1 << (63 - (first ^ last).leading_zeros());
        range.start + keyed[range.clone()].partition_point(|&(key, _)| key & bit == 0)
    };
    morton_cells(keyed, range.start..mid, runs);
    morton_cells(keyed, mid..range.end, runs);
}

/// Largest Morton coordinate, just below 1: obvhs's 21-bit encoding wraps
/// 1.0 around to 0.
const MORTON_MAX: f32 = 1.0 - f32::EPSILON;

/// Each scene mesh's [`MeshRole`]: how many times the instances place it,
/// counted per prototype (a placement whose transform turns out singular
/// still counts; a moving instance's counts twice, as its mesh cannot be
/// carried to world space once), and whether it has triangles.
fn mesh_roles(scene: &Scene, moving: &MovingInstances) -> Vec<MeshRole> {
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
            1 => MeshRole::Flattened,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// A top level of several chunks finds, for random rays, the same nearest
    /// box entry as testing every box: no chunk is lost and every leaf maps
    /// back to its own box.
    #[test]
    fn chunked_top_level_finds_the_nearest_box_of_all() {
        let mut rng = Pcg32::new(7, 0);
        let mut point = || Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 100.0;
        let boxes: Vec<Aabb> = (0..3 * TOP_CHUNK + 5)
            .map(|_| {
                let p = point();
                Aabb::new(p, p + Vec3A::splat(0.5))
            })
            .collect();
        let top = TopLevel::build(boxes.clone());
        for _ in 0..1000 {
            let (origin, target) = (point(), point());
            let ray = traversal_ray(origin, target - origin, 0.0, f32::INFINITY);
            let nearest = |t: f32| if t < 0.0 { 0.0 } else { t };
            let expected = boxes
                .iter()
                .map(|b| b.intersect_ray(&ray))
                .filter(|t| t.is_finite())
                .map(nearest)
                .fold(f32::INFINITY, f32::min);
            let mut found = f32::INFINITY;
            top.traverse(ray, |ray, leaf| {
                let t = boxes[leaf].intersect_ray(ray);
                if t.is_finite() {
                    found = found.min(nearest(t));
                }
                f32::INFINITY
            });
            assert_eq!(found, expected);
        }
    }
}
