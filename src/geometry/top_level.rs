//! The top-level BVH and the CWBVH build both levels share.

use std::ops::Range;

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ploc::morton::morton_encode_u64_unorm;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::{Ray, RayHit};
use obvhs::BvhBuildParams;
use rayon::prelude::*;

/// Build quality for both levels: obvhs's balanced preset.
const BUILD_PARAMS: BvhBuildParams = BvhBuildParams::medium_build();

/// Placed meshes per chunk of the top level, each chunk built on its own
/// (see [`TopLevel`]): small enough that a chunk's build temporaries are a
/// few MB, large enough that the tree over the chunks stays small.
const TOP_CHUNK: usize = 1 << 14;

/// The top-level BVH over the placed meshes (or points and curves prims), in two tiers: the placed
/// meshes are sorted along a Morton curve of their box centres and cut into
/// Morton cells of at most [`TOP_CHUNK`] ([`morton_cells`]), each cell gets
/// its own CWBVH (built in parallel),
/// and one CWBVH goes over the runs' boxes. This is the Morton split of an
/// LBVH (Lauterbach et al. 2009, "Fast BVH Construction on GPUs") above PLOC
/// subtrees; a ray walks the root, then each chunk it enters.
pub(super) struct TopLevel {
    /// Over the chunks' `total_aabb`s; its primitives index `chunks`.
    root: CwBvh,
    /// Each chunk's `primitive_indices` index `Geometry::leaves` directly.
    chunks: Vec<CwBvh>,
}

impl TopLevel {
    /// Builds the top level over the placed meshes' world boxes (in
    /// placement order; primitive indices refer to that order). `boxes` and
    /// the Morton codes are freed before the root is built.
    pub(super) fn build(boxes: Vec<Aabb>) -> Self {
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
    /// `Geometry::leaves`) whose box `ray` enters, with `ray.tmax` cut to
    /// the nearest hit so far; `hit` returns its hit's `t`, or infinity for a
    /// miss, as obvhs's traversal closures do.
    pub(super) fn traverse(&self, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> f32) {
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
    pub(super) fn any(&self, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> bool) -> bool {
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
pub(super) fn build_cwbvh(boxes: Vec<Aabb>) -> CwBvh {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::boxes::traversal_ray;
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
