//! Placing grids in the world: f32 and f64 copies of affine maps, world
//! boxes of index-space boxes, and the longest axis of a linear map.

use glam::{Affine3A, DAffine3, Vec3};

/// The longest of `m`'s axes: world length per unit along it, at most.
pub(super) fn longest_axis(m: glam::DMat3) -> f32 {
    m.x_axis
        .length()
        .max(m.y_axis.length())
        .max(m.z_axis.length()) as f32
}

/// `a` in double precision.
pub(super) fn to_f64(a: &Affine3A) -> DAffine3 {
    DAffine3 {
        matrix3: a.matrix3.as_dmat3(),
        translation: a.translation.as_dvec3(),
    }
}

/// `a` rounded to single precision.
pub(super) fn to_f32(a: &DAffine3) -> Affine3A {
    Affine3A {
        matrix3: a.matrix3.as_mat3().into(),
        translation: a.translation.as_vec3().into(),
    }
}

/// World box of the index-space box `[lo, hi]`.
pub(super) fn world_box(world_from_index: &DAffine3, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for corner in 0..8 {
        let pick = |bit: usize, a: f64, b: f64| if corner & bit == 0 { a } else { b };
        let p = glam::DVec3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        );
        let w = world_from_index.transform_point3(p).as_vec3();
        min = min.min(w);
        max = max.max(w);
    }
    (min, max)
}
