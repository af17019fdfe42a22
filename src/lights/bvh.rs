//! A light BVH (pbrt-v4's `BVHLightSampler`, after Conty Estevez and Kulla
//! 2018, "Importance Sampling of Many Lights with Adaptive Tree Splitting"):
//! the bounded lights (sphere, rect, disk, cylinder, emissive meshes) under
//! a binary tree whose nodes bound position, emitted power and emission
//! directions, so a light is picked by a conservative estimate of its
//! contribution at the shading point, not by power alone.

use std::f32::consts::PI;

use glam::Vec3;

/// What a light (or a subtree of lights) can send where: pbrt-v4's
/// `LightBounds`. Its importance ([`ImportanceBounds::importance`]) is
/// never zero where a light may contribute.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightBounds {
    /// World box around every emitting point.
    pub min: Vec3,
    pub max: Vec3,
    /// Luminance of the emitted power.
    pub phi: f32,
    /// Axis of the cone holding every surface normal (unit).
    pub w: Vec3,
    /// Cosine of that cone's half-angle (-1: all directions).
    pub cos_o: f32,
    /// Cosine of the largest emission angle from a normal (0 for surfaces: pi/2).
    pub cos_e: f32,
    /// Surfaces emit from both sides of their normal.
    pub two_sided: bool,
}

/// A picked light and the probability of that pick.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pick {
    /// Index into the light list the BVH was built over.
    pub light: usize,
    /// Probability of picking it from the shading point.
    pub probability: f32,
}

/// The tree, nodes depth-first: an interior node's first child follows it.
#[derive(Clone, Debug)]
pub(crate) struct LightBvh {
    nodes: Vec<Node>,
    /// Per light index: the path from the root to its leaf, bit d = 1 when
    /// the second child is taken at depth d; `None` for lights not in the tree.
    trails: Vec<Option<u64>>,
}

#[derive(Clone, Debug)]
struct Node {
    /// The node's [`LightBounds`], as importance reads them.
    cone: ImportanceBounds,
    kind: NodeKind,
}

/// [`LightBounds`] with what [`Self::importance`] derives from them
/// worked out once: the tree walks evaluate it at every level of every pick
/// and every probability.
#[derive(Clone, Copy, Debug)]
struct ImportanceBounds {
    /// Centre of the box.
    centre: Vec3,
    /// Square of half the box's diagonal, scene units squared.
    radius_squared: f32,
    phi: f32,
    w: Vec3,
    cos_o: f32,
    /// Sine of the normal cone's half-angle.
    sin_o: f32,
    cos_e: f32,
    two_sided: bool,
}

#[derive(Clone, Copy, Debug)]
enum NodeKind {
    Leaf { light: usize },
    Interior { second: usize },
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl LightBvh {
    /// Walks from the root, at each node taking a child with probability
    /// proportional to its importance at `p`; `None` when no light in the
    /// tree can reach `p`.
    pub fn pick(&self, p: Vec3, u: f32) -> Option<Pick> {
        let (mut node, mut probability, mut u) = (0, 1.0f32, u);
        loop {
            match self.nodes[node].kind {
                NodeKind::Leaf { light } => {
                    return self.reaches(node, p).then_some(Pick { light, probability });
                }
                NodeKind::Interior { second } => {
                    let p0 = self.first_child_probability(node, second, p)?;
                    if u < p0 {
                        node += 1;
                        probability *= p0;
                        u = (u / p0).min(ONE_MINUS_EPSILON);
                    } else {
                        node = second;
                        probability *= 1.0 - p0;
                        u = ((u - p0) / (1.0 - p0)).min(ONE_MINUS_EPSILON);
                    }
                }
            }
        }
    }

    /// The root's importance at `p`: a bound on what all the bounded
    /// lights together can deliver there, in the unit of
    /// [`ImportanceBounds::importance`] (power x cos / distance^2).
    pub fn importance(&self, p: Vec3) -> f32 {
        self.nodes[0].cone.importance(p)
    }

    /// Probability that [`Self::pick`] returns `light` from `p` (0 for a
    /// light not in the tree).
    pub fn probability(&self, p: Vec3, light: usize) -> f32 {
        let Some(Some(trail)) = self.trails.get(light) else {
            return 0.0;
        };
        let (mut node, mut probability, mut depth) = (0, 1.0f32, 0);
        loop {
            match self.nodes[node].kind {
                NodeKind::Leaf { .. } => {
                    return if self.reaches(node, p) {
                        probability
                    } else {
                        0.0
                    };
                }
                NodeKind::Interior { second } => {
                    let Some(p0) = self.first_child_probability(node, second, p) else {
                        return 0.0;
                    };
                    if trail >> depth & 1 == 0 {
                        node += 1;
                        probability *= p0;
                    } else {
                        node = second;
                        probability *= 1.0 - p0;
                    }
                    depth += 1;
                }
            }
        }
    }

    fn first_child_probability(&self, node: usize, second: usize, p: Vec3) -> Option<f32> {
        let c0 = self.nodes[node + 1].cone.importance(p);
        let c1 = self.nodes[second].cone.importance(p);
        (c0 + c1 > 0.0).then(|| c0 / (c0 + c1))
    }

    /// Whether leaf `node`'s light can reach `p` (importance above 0). Only
    /// the root needs the test: a walk takes a child with probability
    /// `c / (c0 + c1)`, so it reaches a child of importance 0 with
    /// probability 0 (and [`Self::probability`] has multiplied that 0 in).
    fn reaches(&self, node: usize, p: Vec3) -> bool {
        node != 0 || self.nodes[0].cone.importance(p) > 0.0
    }

    /// A tree over `lights` (index into the caller's list, bounds), split at
    /// the median centroid along the widest axis of the centroids.
    ///
    /// # Panics
    /// If `lights` is empty.
    pub fn build(mut lights: Vec<(usize, LightBounds)>, light_count: usize) -> Self {
        assert!(!lights.is_empty());
        let mut bvh = Self {
            nodes: Vec::with_capacity(2 * lights.len()),
            trails: vec![None; light_count],
        };
        bvh.build_node(&mut lights, 0, 0);
        bvh
    }

    fn build_node(
        &mut self,
        lights: &mut [(usize, LightBounds)],
        trail: u64,
        depth: u32,
    ) -> LightBounds {
        if let [(light, bounds)] = lights {
            self.trails[*light] = Some(trail);
            self.nodes.push(Node {
                cone: ImportanceBounds::new(bounds),
                kind: NodeKind::Leaf { light: *light },
            });
            return *bounds;
        }
        let (lo, hi) = lights
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (_, b)| {
                (lo.min(b.centroid()), hi.max(b.centroid()))
            });
        let axis = (hi - lo).max_position();
        let mid = lights.len() / 2;
        lights.select_nth_unstable_by(mid, |a, b| {
            a.1.centroid()[axis].total_cmp(&b.1.centroid()[axis])
        });
        let at = self.nodes.len();
        self.nodes.push(Node {
            cone: ImportanceBounds::new(&lights[0].1),
            kind: NodeKind::Leaf { light: usize::MAX },
        });
        let (first, rest) = lights.split_at_mut(mid);
        let a = self.build_node(first, trail, depth + 1);
        let second = self.nodes.len();
        let b = self.build_node(rest, trail | 1 << depth, depth + 1);
        let bounds = a.union(&b);
        self.nodes[at] = Node {
            cone: ImportanceBounds::new(&bounds),
            kind: NodeKind::Interior { second },
        };
        bounds
    }
}

impl LightBounds {
    /// Centre of the box.
    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Bounds of both: boxes joined, powers added, normal cones merged
    /// (pbrt-v4's `DirectionCone::Union`).
    pub fn union(&self, other: &Self) -> Self {
        let (w, cos_o) = cone_union((self.w, self.cos_o), (other.w, other.cos_o));
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
            phi: self.phi + other.phi,
            w,
            cos_o,
            cos_e: self.cos_e.min(other.cos_e),
            two_sided: self.two_sided || other.two_sided,
        }
    }

    /// Its importance at `p` (see [`ImportanceBounds::importance`]).
    pub fn importance(&self, p: Vec3) -> f32 {
        ImportanceBounds::new(self).importance(p)
    }

    /// Bounds emitting in every direction from a box (spheres, cylinders).
    pub fn omni(min: Vec3, max: Vec3, phi: f32) -> Self {
        Self {
            min,
            max,
            phi,
            w: Vec3::Z,
            cos_o: -1.0,
            cos_e: 0.0,
            two_sided: false,
        }
    }
}

impl ImportanceBounds {
    /// `b` with its centre, squared radius and cone sine worked out.
    fn new(b: &LightBounds) -> Self {
        let half_diagonal = 0.5 * (b.max - b.min).length();
        Self {
            centre: b.centroid(),
            radius_squared: half_diagonal * half_diagonal,
            phi: b.phi,
            w: b.w,
            cos_o: b.cos_o,
            sin_o: (1.0 - b.cos_o * b.cos_o).max(0.0).sqrt(),
            cos_e: b.cos_e,
            two_sided: b.two_sided,
        }
    }

    /// pbrt-v4's `LightBounds::Importance` without the receiver's normal:
    /// phi x a bound on cos(angle to the nearest emitting normal) / d^2,
    /// zero when no emitting direction of the bounds can reach `p`.
    fn importance(&self, p: Vec3) -> f32 {
        let centre = self.centre;
        let r2 = self.radius_squared;
        let d2 = p.distance_squared(centre).max(r2).max(1e-12);
        let to_p = (p - centre).normalize_or_zero();
        let mut cos_w = to_p.dot(self.w);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        // Half-angle of the cone from p holding the bounds' sphere.
        let cos_b = if d2 <= r2 || to_p == Vec3::ZERO {
            -1.0
        } else {
            (1.0 - r2 / p.distance_squared(centre)).max(0.0).sqrt()
        };
        let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
        // cos(max(0, theta_w - theta_o - theta_b)).
        let (cos_x, sin_x) = cos_sin_sub_clamped(sin_w, cos_w, self.sin_o, self.cos_o);
        let (cos_p, _) = cos_sin_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_e {
            return 0.0;
        }
        self.phi * cos_p / d2
    }
}

/// cos and sin of max(0, a - b) from those of a and b.
fn cos_sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> (f32, f32) {
    if cos_a > cos_b {
        (1.0, 0.0)
    } else {
        (cos_a * cos_b + sin_a * sin_b, sin_a * cos_b - cos_a * sin_b)
    }
}

/// The smallest cone (axis, cos half-angle) holding both cones.
pub(crate) fn cone_union(a: (Vec3, f32), b: (Vec3, f32)) -> (Vec3, f32) {
    let theta_a = a.1.clamp(-1.0, 1.0).acos();
    let theta_b = b.1.clamp(-1.0, 1.0).acos();
    let theta_d = a.0.dot(b.0).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return a;
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return b;
    }
    let theta_o = (theta_a + theta_d + theta_b) / 2.0;
    let axis = a.0.cross(b.0);
    if theta_o >= PI || axis.length_squared() == 0.0 {
        return (Vec3::Z, -1.0);
    }
    let w = glam::Quat::from_axis_angle(axis.normalize(), theta_o - theta_a) * a.0;
    (w.normalize(), theta_o.cos())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::test_support::assert_picks_follow;

    fn omni_at(c: Vec3, phi: f32) -> LightBounds {
        LightBounds::omni(c - 0.1, c + 0.1, phi)
    }

    /// Picks follow the reported probabilities, which sum to 1; a near light
    /// is picked far more often than an equal far one; a one-sided panel
    /// facing away is never picked.
    #[test]
    fn picks_follow_their_probabilities() {
        let mut lights: Vec<(usize, LightBounds)> = (0..6)
            .map(|i| {
                (
                    i,
                    omni_at(
                        Vec3::new(i as f32 * 3.0, (i % 2) as f32, 0.0),
                        1.0 + i as f32,
                    ),
                )
            })
            .collect();
        // Light 6: a panel at x = -2 facing -X, away from the shading point.
        lights.push((
            6,
            LightBounds {
                min: Vec3::new(-2.0, -1.0, -1.0),
                max: Vec3::new(-2.0, 1.0, 1.0),
                phi: 100.0,
                w: -Vec3::X,
                cos_o: 1.0,
                cos_e: 0.0,
                two_sided: false,
            },
        ));
        let bvh = LightBvh::build(lights, 8);
        let p = Vec3::new(0.5, 0.2, 0.3);
        let probabilities: Vec<f32> = (0..8).map(|i| bvh.probability(p, i)).collect();
        assert!((probabilities.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert_eq!(probabilities[6], 0.0);
        assert_eq!(probabilities[7], 0.0, "not in the tree");
        assert!(
            probabilities[0] > 4.0 * probabilities[5],
            "{probabilities:?}"
        );
        assert_picks_follow(
            &probabilities,
            (50_000, 31),
            |u| bvh.pick(p, u).map(|k| (k.light, k.probability)),
            "tree",
        );
    }

    /// A tree of one light is a lone leaf, the one node the walks test
    /// themselves: a one-sided panel is picked with probability 1 in front
    /// and never behind.
    #[test]
    fn a_lone_light_is_picked_only_where_it_shines() {
        let panel = LightBounds {
            min: Vec3::new(-1.0, -1.0, 0.0),
            max: Vec3::new(1.0, 1.0, 0.0),
            phi: 10.0,
            w: Vec3::Z,
            cos_o: 1.0,
            cos_e: 0.0,
            two_sided: false,
        };
        let bvh = LightBvh::build(vec![(0, panel)], 1);
        let (front, behind) = (Vec3::new(0.3, 0.2, 2.0), Vec3::new(0.3, 0.2, -2.0));
        assert_eq!(bvh.probability(front, 0), 1.0);
        assert_eq!(
            bvh.pick(front, 0.7).map(|p| (p.light, p.probability)),
            Some((0, 1.0))
        );
        assert_eq!(bvh.probability(behind, 0), 0.0);
        assert!(bvh.pick(behind, 0.7).is_none());
    }

    #[test]
    fn cone_union_holds_both_cones() {
        let a = (Vec3::X, 0.9f32);
        let b = (Vec3::Y, 0.8f32);
        let (w, cos_o) = cone_union(a, b);
        for (axis, cos) in [a, b] {
            // The merged cone holds each cone: angle(w, axis) + theta <= theta_o.
            let spread = w.dot(axis).clamp(-1.0, 1.0).acos() + cos.acos();
            assert!(spread <= cos_o.acos() + 1e-4);
        }
        assert_eq!(cone_union(a, (Vec3::X, 1.0)), a);
        assert_eq!(cone_union((Vec3::X, 1.0), (-Vec3::X, 1.0)).1, -1.0);
    }
}
