//! Points (spheres) and curves (linear round tubes) in their own BVHs,
//! beside the meshes'. Every points or curves prim gets one obvhs CWBVH in
//! its own space over its spheres or tube pieces (a piece is the round cone
//! between two consecutive vertices, see `round_intersect.rs`), and every
//! placement of one (instance x prototype part) is a leaf of a top level of
//! its own, built as the meshes' ([`TopLevel`]): a ray enters a prim
//! through the inverse of its placement's transform, at the ray's time for
//! a moving instance. Moving points (`points[i].motion`, under an open
//! shutter) keep their spheres at every key: a ray at time t meets each
//! sphere lerped between the two keys around t (`crate::motion::Bracket`,
//! end keys held), and the prim's BVH bounds each sphere by the union of
//! its boxes at the keys (conservative: a lerped sphere lies in the hull
//! of its key spheres). Deforming curves (`curves[i].motion`) keep their
//! vertices the same way: a piece at time t is the round cone between its
//! two lerped vertex spheres, bounded by the union of both vertices' key
//! boxes (the cone is the hull of its spheres, inside that box). Resident
//! per point: 16 bytes (centre and radius) plus 16 per key when it moves,
//! a 4-byte primitive index and about 20 bytes of BVH nodes; per curve
//! vertex 16 bytes (plus 16 per key) and per piece 4 + 4 + 20.

use glam::{Affine3A, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use rayon::prelude::*;

use super::boxes::{local_ray, padded, transform_box};
use super::motion::MovingInstances;
use super::round_intersect::{RoundHit, RoundRay};
use super::round_surface::RoundShading;
use super::surface::SurfacePoint;
use super::top_level::{build_cwbvh, TopLevel};
use crate::motion::{Bracket, TransformTrack};
use crate::scene::{affine, Array, PointsMotion, Scene, Transform};

/// Per point (or curve piece), resident: 16 bytes of centre and radius
/// (a curve's per vertex, about one per piece), 4 of primitive index, 4
/// of piece start (curves) and CWBVH nodes (about 20).
const BYTES_PER_ELEMENT: u64 = 16 + 4 + 4 + 20;
/// Per element while its prim's BVH is built: its box (32) and PLOC's and
/// the CWBVH conversion's temporaries, measured (`cirrus bench
/// points-curves`, docs/benchmarks.md): the build peaks at 201 bytes per
/// sphere and 205 per curve piece above what stays resident (the triangle
/// rate, 544, overcharged them 2.2x); 256 bounds both, within 1.2x.
const BUILD_BYTES_PER_ELEMENT: u64 = 256;

/// The points and curves prims of a scene, under their own top level.
pub(super) struct RoundShapes {
    /// Per shape (points prims, then curves prims): its BVH, `None` when
    /// it is empty or never placed.
    shapes: Vec<Option<RoundBvh>>,
    /// Per shape: material, and where its curves start.
    shading: Vec<RoundShading>,
    /// The scene's mesh count: a shape's object index is it plus the shape's.
    meshes: u32,
    /// Over `leaves`; `None` when nothing is placed.
    top: Option<TopLevel>,
    /// Every placed shape.
    leaves: Vec<PlacedShape>,
    /// World-from-shape tracks of moving placements, by [`PlacedShape::motion`].
    tracks: Vec<TransformTrack>,
}

/// One prim's spheres or tube pieces under one BVH, in the prim's space.
pub(super) struct RoundBvh {
    bvh: CwBvh,
    /// Spheres (points) or vertices (curves): xyz centre, w radius, in
    /// input order (the BVH's primitive indices name them).
    spheres: Vec<Vec4>,
    /// Curves: per piece, its first vertex (the second follows it); empty
    /// for points.
    pieces: Vec<u32>,
    /// Moving points or deforming curves: their spheres (vertices) at the
    /// keys; `None` when still.
    keys: Option<SphereKeys>,
}

/// Moving points' spheres (or deforming curves' vertices) at key times.
struct SphereKeys {
    /// Key times, frames, strictly increasing.
    times: Vec<f32>,
    /// Spheres per key, key-major (`spheres.len()` per key): xyz centre, w
    /// radius.
    spheres: Vec<Vec4>,
}

/// One shape of one instance: a top-level leaf.
struct PlacedShape {
    /// At the frame; a moving placement's is at the ray's time.
    shape_from_world: Affine3A,
    instance: u32,
    /// The id the hit reports as its prototype mesh: the prototype's mesh
    /// count plus the part's position among its points, then curves parts.
    part: u32,
    /// Index into [`RoundShapes::shapes`].
    shape: u32,
    /// Index into [`RoundShapes::tracks`]; `u32::MAX` when static.
    motion: u32,
}

/// A hit on a placed shape, in the shape's space: which leaf and piece.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ShapeHit {
    pub leaf: u32,
    /// The point, or the curve piece.
    pub element: u32,
    pub hit: RoundHit,
}

/// What a leaf reports for a hit: (instance, prototype part id, shape).
pub(super) type LeafIds = [u32; 3];

impl RoundShapes {
    /// Bytes held at the peak of the build for `elements` points and curve
    /// pieces, `building` of them in the prims built at once.
    pub(super) fn bytes_for(elements: u64, building: u64) -> u64 {
        elements * BYTES_PER_ELEMENT + building * BUILD_BYTES_PER_ELEMENT
    }

    /// Builds every placed prim's BVH (in parallel) and the top level over
    /// the placements; `None` when the scene places no points or curves.
    /// Without `motion` (a closed shutter) moving points and deforming
    /// curves stay at the frame.
    pub(super) fn build(scene: &Scene, moving: &MovingInstances, motion: bool) -> Option<Self> {
        let m = &scene.manifest;
        let mut placed = vec![false; m.points.len() + m.curves.len()];
        for &p in scene.view(&m.instances.prototype) {
            for (shape, _) in parts(scene, p) {
                placed[shape as usize] = true;
            }
        }
        if !placed.contains(&true) {
            return None;
        }
        let points = m.points.par_iter().map(|p| {
            let spheres = spheres(scene.view(&p.points), scene.view(&p.widths));
            let keys = p.motion.as_ref().filter(|_| motion);
            let keys = keys.map(|keys| sphere_keys(scene, keys, &p.widths, spheres.len()));
            (spheres, Vec::new(), keys)
        });
        let curves = m.curves.par_iter().map(|c| {
            let spheres = spheres(scene.view(&c.points), scene.view(&c.widths));
            let keys = c.motion.as_ref().filter(|_| motion);
            let keys = keys.map(|keys| sphere_keys(scene, keys, &c.widths, spheres.len()));
            (spheres, scene.piece_starts(c), keys)
        });
        let shapes: Vec<Option<RoundBvh>> = points
            .chain(curves)
            .zip(placed.par_iter())
            .map(|((spheres, pieces, keys), &placed)| {
                placed.then(|| RoundBvh::build(spheres, pieces, keys))?
            })
            .collect();
        let boxes: Vec<Aabb> = placements(scene, moving)
            .filter(|(leaf, _, _)| shapes[leaf.shape as usize].is_some())
            .enumerate()
            .map(|(i, (leaf, world_from_shape, track))| {
                let shape_box = &shapes[leaf.shape as usize].as_ref()?.bvh.total_aabb;
                let keys = match &track {
                    Some(track) => track.keys(),
                    None => std::slice::from_ref(&world_from_shape),
                };
                let union = keys.iter().fold(Aabb::INVALID, |b, key| {
                    b.union(&transform_box(key, shape_box))
                });
                Some(padded(union, i))
            })
            .collect::<Option<_>>()?;
        let top = (!boxes.is_empty()).then(|| TopLevel::build(boxes));
        let (mut leaves, mut tracks) = (Vec::new(), Vec::new());
        let placed =
            placements(scene, moving).filter(|(l, _, _)| shapes[l.shape as usize].is_some());
        for (mut leaf, _, track) in placed {
            if let Some(track) = track {
                leaf.motion = tracks.len() as u32;
                tracks.push(track);
            }
            leaves.push(leaf);
        }
        let points = m.points.iter().map(|p| RoundShading {
            material: p.material,
            curve_starts: Vec::new(),
        });
        let curves = m.curves.iter().map(|c| RoundShading {
            material: c.material,
            curve_starts: scene.curve_starts(c),
        });
        Some(Self {
            shapes,
            shading: points.chain(curves).collect(),
            meshes: m.meshes.len() as u32,
            top,
            leaves,
            tracks,
        })
    }

    /// The nearest hit within `(ray.tmin, ray.tmax)` at `time` (frames).
    pub(super) fn intersect(&self, ray: Ray, time: f32) -> Option<ShapeHit> {
        let top = self.top.as_ref()?;
        let mut closest = None;
        top.traverse(ray, |ray, index| {
            let leaf = &self.leaves[index];
            let found = self
                .local_ray(leaf, ray, time)
                .and_then(|local| self.shape(leaf).intersect(&local, time));
            match found {
                Some((element, hit)) => {
                    let leaf = index as u32;
                    closest = Some(ShapeHit { leaf, element, hit });
                    hit.t
                }
                None => f32::INFINITY,
            }
        });
        closest
    }

    /// Whether anything blocks `ray` within `(ray.tmin, ray.tmax)` at `time`.
    pub(super) fn occluded(&self, ray: Ray, time: f32) -> bool {
        self.top.as_ref().is_some_and(|top| {
            top.any(ray, |ray, index| {
                let leaf = &self.leaves[index];
                self.local_ray(leaf, ray, time)
                    .is_some_and(|local| self.shape(leaf).intersect(&local, time).is_some())
            })
        })
    }

    /// A leaf's (instance, prototype part id, object index): the object
    /// index counts the scene's meshes, then its points, then its curves.
    pub(super) fn ids(&self, leaf: u32) -> LeafIds {
        let leaf = &self.leaves[leaf as usize];
        [leaf.instance, leaf.part, self.meshes + leaf.shape]
    }

    /// The shading data of `hit` at `time` (frames).
    pub(super) fn surface_point(&self, hit: &ShapeHit, time: f32) -> SurfacePoint {
        let leaf = &self.leaves[hit.leaf as usize];
        let shape = self.shape(leaf);
        let bracket = shape.bracket(time);
        self.shading[leaf.shape as usize].surface_point(
            (&|i| shape.sphere(i, bracket.as_ref()), &shape.pieces),
            &self.shape_from_world(leaf, time),
            hit.element,
            &hit.hit,
            self.ids(hit.leaf),
        )
    }

    fn shape_from_world(&self, leaf: &PlacedShape, time: f32) -> Affine3A {
        match self.tracks.get(leaf.motion as usize) {
            Some(track) => track.at(time).inverse(),
            None => leaf.shape_from_world,
        }
    }

    /// `ray` in `leaf`'s shape space at `time` (see [`local_ray`]).
    fn local_ray(&self, leaf: &PlacedShape, ray: &Ray, time: f32) -> Option<Ray> {
        local_ray(self.shape_from_world(leaf, time), ray)
    }

    fn shape(&self, leaf: &PlacedShape) -> &RoundBvh {
        self.shapes[leaf.shape as usize]
            .as_ref()
            .expect("placed shapes have a BVH")
    }
}

impl RoundBvh {
    /// The BVH over `spheres` (points) or over the tube pieces starting at
    /// `pieces` (curves); `None` when there is nothing to hit.
    /// A moving sphere's box (a curve vertex's) is the union of its boxes
    /// at the `keys`; a piece's, the union of its two vertices' boxes.
    fn build(spheres: Vec<Vec4>, pieces: Vec<u32>, keys: Option<SphereKeys>) -> Option<Self> {
        let sphere_box = |s: Vec4| {
            let (c, r) = (Vec3A::from(s.truncate()), Vec3A::splat(s.w));
            Aabb::new(c - r, c + r)
        };
        // Each sphere's (or curve vertex's) box over the keys.
        let keyed = keys.as_ref().map_or(&[][..], |k| &k.spheres);
        let vertex_boxes = spheres.iter().enumerate().map(|(i, &s)| {
            let at_keys = keyed.iter().skip(i).step_by(spheres.len().max(1));
            at_keys.fold(sphere_box(s), |b, &k| b.union(&sphere_box(k)))
        });
        let vertex_boxes: Vec<Aabb> = vertex_boxes.collect();
        let boxes: Vec<Aabb> = if pieces.is_empty() {
            let boxes = vertex_boxes.into_iter().enumerate();
            boxes.map(|(i, b)| padded(b, i)).collect()
        } else {
            let boxes = pieces
                .iter()
                .map(|&v| vertex_boxes[v as usize].union(&vertex_boxes[v as usize + 1]));
            boxes.enumerate().map(|(i, b)| padded(b, i)).collect()
        };
        (!boxes.is_empty()).then(|| Self {
            bvh: build_cwbvh(boxes),
            spheres,
            pieces,
            keys,
        })
    }

    /// Where `time` (frames) falls among a moving prim's keys; `None` when
    /// it is still.
    fn bracket(&self, time: f32) -> Option<Bracket> {
        self.keys.as_ref().map(|k| Bracket::at(&k.times, time))
    }

    /// Sphere (or curve vertex) `i` at `bracket` (the frame's without one).
    #[inline]
    fn sphere(&self, i: u32, bracket: Option<&Bracket>) -> Vec4 {
        match (&self.keys, bracket) {
            (Some(keys), Some(b)) => {
                let (n, i) = (self.spheres.len(), i as usize);
                b.lerp(
                    keys.spheres[b.before * n + i],
                    keys.spheres[b.after * n + i],
                )
            }
            _ => self.spheres[i as usize],
        }
    }

    /// The nearest sphere or piece hit along a ray in the prim's space at
    /// `time` (frames), as (point or piece index, hit).
    fn intersect(&self, ray: &Ray, time: f32) -> Option<(u32, RoundHit)> {
        let round = RoundRay::new(ray.origin, ray.direction);
        let bracket = self.bracket(time);
        let mut closest = None;
        self.bvh.ray_traverse(*ray, &mut RayHit::none(), |ray, id| {
            let element = self.bvh.primitive_indices[id];
            match self.element_hit(&round, element, bracket.as_ref(), ray.tmin, ray.tmax) {
                Some(hit) => {
                    closest = Some((element, hit));
                    hit.t
                }
                None => f32::INFINITY,
            }
        });
        closest
    }

    /// Point or piece `element`'s hit within `(t_min, t_max)`.
    #[inline]
    fn element_hit(
        &self,
        ray: &RoundRay,
        element: u32,
        bracket: Option<&Bracket>,
        t_min: f32,
        t_max: f32,
    ) -> Option<RoundHit> {
        match self.pieces.get(element as usize) {
            None => ray.sphere(self.sphere(element, bracket), t_min, t_max),
            Some(&v) => {
                let (a, b) = (self.sphere(v, bracket), self.sphere(v + 1, bracket));
                ray.round_cone(a, b, t_min, t_max)
            }
        }
    }
}

/// The spheres of `count` moving points (or curve vertices) at the keys of
/// `keys`, with their still `widths` where the keys hold none.
fn sphere_keys(
    scene: &Scene,
    keys: &PointsMotion,
    widths: &Array<f32>,
    count: usize,
) -> SphereKeys {
    let widths = scene.view(keys.widths.as_ref().unwrap_or(widths));
    let centres = scene.view(&keys.points);
    let n = count.max(1);
    // Keyed widths are laid out like the centres.
    let keyed = widths.len() == centres.len();
    let spheres = centres
        .chunks_exact(n)
        .enumerate()
        .flat_map(|(k, key)| spheres(key, if keyed { &widths[k * n..][..n] } else { widths }));
    SphereKeys {
        times: keys.times.clone(),
        spheres: spheres.collect(),
    }
}

/// Spheres of `centres` and diameters `widths` (one, or one per centre).
fn spheres(centres: &[[f32; 3]], widths: &[f32]) -> Vec<Vec4> {
    let width = |i: usize| widths[if widths.len() == 1 { 0 } else { i }];
    let spheres = centres.iter().enumerate();
    spheres
        .map(|(i, c)| Vec3A::from_array(*c).extend(0.5 * width(i)))
        .collect()
}

/// Prototype `p`'s points and curves parts as (shape index, transform),
/// points first.
fn parts(scene: &Scene, p: u32) -> impl Iterator<Item = (u32, &Transform)> {
    let m = &scene.manifest;
    let proto = &m.prototypes[p as usize];
    let points = proto
        .points
        .iter()
        .map(|part| (part.points, &part.transform));
    let curves = proto.curves.iter();
    let curves = curves.map(move |part| (m.points.len() as u32 + part.curves, &part.transform));
    points.chain(curves)
}

/// Every placed points or curves prim, in instance order, with its
/// world-from-shape transform at the frame and its track when it moves;
/// placements whose transform cannot be inverted are left out.
fn placements<'a>(
    scene: &'a Scene,
    moving: &'a MovingInstances,
) -> impl Iterator<Item = (PlacedShape, Affine3A, Option<TransformTrack>)> + 'a {
    let m = &scene.manifest;
    let prototypes = scene.view(&m.instances.prototype);
    let transforms = scene.view(&m.instances.transform);
    let instances = transforms.iter().zip(prototypes).enumerate();
    instances.flat_map(move |(instance, (world_from_prototype, &prototype))| {
        let meshes = m.prototypes[prototype as usize].meshes.len() as u32;
        parts(scene, prototype)
            .enumerate()
            .filter_map(move |(j, (shape, transform))| {
                let prototype_from_shape = affine(transform);
                let world_from_shape = affine(world_from_prototype) * prototype_from_shape;
                let shape_from_world = world_from_shape.inverse();
                let leaf = PlacedShape {
                    shape_from_world,
                    instance: instance as u32,
                    part: meshes + j as u32,
                    shape,
                    motion: u32::MAX,
                };
                let track = moving.mesh_track(instance as u32, prototype_from_shape);
                shape_from_world
                    .is_finite()
                    .then_some((leaf, world_from_shape, track))
            })
    })
}
