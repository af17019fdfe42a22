//! Where media overlap or a ray misses them: the per-medium majorant
//! segments of one ray merged into one list carrying their sums, and the
//! slab test that skips a medium whose box the ray misses.

use glam::Vec3;

use super::segment::MajorantSegment;

/// Merges per-medium segment lists into one list whose pieces carry the sums.
pub(super) fn merge(lists: Vec<Vec<MajorantSegment>>) -> Vec<MajorantSegment> {
    let mut cuts: Vec<f32> = lists
        .iter()
        .flatten()
        .flat_map(|s| [s.t_min, s.t_max])
        .collect();
    cuts.sort_by(f32::total_cmp);
    cuts.dedup();
    let mut out: Vec<MajorantSegment> = Vec::new();
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let mid = 0.5 * (a + b);
        let (mut maj, mut min) = (0.0, 0.0);
        for s in lists
            .iter()
            .flatten()
            .filter(|s| s.t_min <= mid && mid < s.t_max)
        {
            maj += s.sigma_maj;
            min += s.sigma_min;
        }
        if maj > 0.0 {
            out.push(MajorantSegment {
                t_min: a,
                t_max: b,
                sigma_maj: maj,
                sigma_min: min,
            });
        }
    }
    out
}

/// Whether the ray meets the box within `[0, t_max)` (slab test).
pub(super) fn box_hit(origin: Vec3, direction: Vec3, t_max: f32, lo: Vec3, hi: Vec3) -> bool {
    let inv = direction.recip();
    let (t0, t1) = ((lo - origin) * inv, (hi - origin) * inv);
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(t_max);
    near <= far
}
