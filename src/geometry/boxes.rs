//! Boxes and rays as both BVH families (meshes, points and curves) build
//! and traverse them.

use glam::{Affine3A, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;

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

/// A box containing the image of `b` under `m` (its eight corners' bounds).
pub(super) fn transform_box(m: &Affine3A, b: &Aabb) -> Aabb {
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
pub(super) fn traversal_ray(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Ray {
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
pub(super) fn padded(b: Aabb, index: usize) -> Aabb {
    let jitter = 1.0 + ((index as u32).wrapping_mul(0x9e37_79b9) >> 8) as f32 / (1 << 24) as f32;
    let pad = b.min.abs().max(b.max.abs()) * (BOX_PADDING * jitter) + 1e-20;
    Aabb::new(b.min - pad, b.max + pad)
}

/// A world traversal ray carried into a placed shape's space by
/// `from_world`, with the same parameterisation (`t` means the same point
/// in both spaces); `None` when the transform collapses (a moving placement
/// at a time its scale is zero).
pub(super) fn local_ray(from_world: Affine3A, ray: &Ray) -> Option<Ray> {
    from_world.is_finite().then(|| {
        traversal_ray(
            from_world.transform_point3a(ray.origin),
            from_world.transform_vector3a(ray.direction),
            ray.tmin,
            ray.tmax,
        )
    })
}
