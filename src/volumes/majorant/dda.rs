//! The 3D DDA (Amanatides & Woo 1987, "A Fast Voxel Traversal Algorithm for
//! Ray Tracing") over a [`MajorantGrid`]: the non-empty cells a ray crosses,
//! front to back, as [`MajorantSegment`]s, as pbrt-v4's
//! `DDAMajorantIterator` does. Each segment is clipped to the box where its
//! cell's interpolated density can be non-zero (see cells.rs), so the
//! empty half of a boundary cell costs nothing. Inside a split cell
//! (`--majorant adaptive`, refine.rs) a second DDA walks its sub-cells over
//! that clipped stretch, yielding one segment per non-empty sub-cell.

use glam::{IVec3, Vec3};

use super::cells::{MajorantGrid, Refinement, SupportBox};
use crate::volumes::segment::MajorantSegment;

/// The iterator returned by [`MajorantGrid::segments`]: an Amanatides & Woo
/// DDA that yields the non-empty cells the ray crosses, front to back.
pub struct MajorantSegments<'a> {
    grid: &'a MajorantGrid,
    origin: Vec3,
    direction: Vec3,
    /// 1 / `direction` per axis (infinite where it is 0): cell crossings
    /// and support-box clips multiply by it instead of dividing.
    inv_direction: Vec3,
    /// The cell the ray is in at `t`.
    cell: IVec3,
    /// -1, 0 or +1 per axis: the sign of `direction`.
    step: IVec3,
    /// Where the ray leaves `cell` through each axis' next plane (infinity if parallel).
    t_next: Vec3,
    /// Start of the next segment.
    t: f32,
    /// End of the ray, clipped to the grid.
    t_exit: f32,
    /// The largest and smallest channel of the caller's densityScale.
    scale_max: f32,
    scale_min: f32,
    /// The walk through the sub-cells of the split cell being crossed.
    sub: Option<SubWalk>,
}

/// The DDA over one split cell's sub-cells, from `t` to `t_end` (the
/// cell's stretch, clipped to its support box).
struct SubWalk {
    split: Refinement,
    /// Index-space min corner of the cell.
    corner: Vec3,
    /// Sub-cell edge lengths, in voxels.
    size: Vec3,
    cell: IVec3,
    t_next: Vec3,
    t: f32,
    t_end: f32,
}

impl Iterator for MajorantSegments<'_> {
    type Item = MajorantSegment;

    #[inline]
    fn next(&mut self) -> Option<MajorantSegment> {
        if let Some(segment) = self.next_sub_segment() {
            return Some(segment);
        }
        while self.t < self.t_exit {
            let axis = nearest_axis(self.t_next);
            let t_min = self.t;
            // Carried over, never recomputed: consecutive segments share this exact value.
            let t_max = self.t_next[axis].min(self.t_exit).max(t_min);
            let cell = self.cell;
            let slot = self.grid.cell_slot(cell);
            let range = self.grid.cells[slot];
            self.t = t_max;
            self.cell[axis] += self.step[axis];
            if self.cell[axis] < 0 || self.cell[axis] >= self.grid.dims[axis] {
                self.t_exit = t_max;
            } else {
                self.t_next[axis] = self.grid.crossing(
                    self.origin[axis],
                    self.inv_direction[axis],
                    self.cell[axis],
                    self.step[axis],
                    axis,
                );
            }
            if range.max > 0.0 && t_max > t_min {
                let (t_min, t_max) = self.clip(cell, self.grid.supports[slot], t_min, t_max);
                let split = self.grid.refinement(slot);
                if t_max > t_min && split.level > 0 {
                    self.sub = Some(self.sub_walk(cell, split, t_min, t_max));
                    if let Some(segment) = self.next_sub_segment() {
                        return Some(segment);
                    }
                } else if t_max > t_min {
                    return Some(MajorantSegment {
                        t_min,
                        t_max,
                        sigma_maj: range.max * self.scale_max,
                        sigma_min: range.min * self.scale_min,
                    });
                }
            }
        }
        None
    }
}

impl MajorantSegments<'_> {
    /// The walk over split `cell`'s sub-cells for `[t_min, t_max)`.
    fn sub_walk(&self, cell: IVec3, split: Refinement, t_min: f32, t_max: f32) -> SubWalk {
        let res = split.res();
        let corner = self.grid.lo + cell.as_vec3() * self.grid.cell_size;
        let size = self.grid.cell_size / res as f32;
        let p = self.origin + self.direction * t_min;
        let sub = ((p - corner) / size)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, IVec3::splat(res - 1));
        let t_next = Vec3::from_array(std::array::from_fn(|a| {
            crossing(
                corner[a],
                size[a],
                self.origin[a],
                self.inv_direction[a],
                sub[a],
                self.step[a],
            )
        }));
        SubWalk {
            split,
            corner,
            size,
            cell: sub,
            t_next,
            t: t_min,
            t_end: t_max,
        }
    }

    /// The next non-empty sub-cell of the split cell being crossed, if any.
    #[inline]
    fn next_sub_segment(&mut self) -> Option<MajorantSegment> {
        let walk = self.sub.as_mut()?;
        let res = walk.split.res();
        while walk.t < walk.t_end {
            let axis = nearest_axis(walk.t_next);
            let t_min = walk.t;
            let t_max = walk.t_next[axis].min(walk.t_end).max(t_min);
            let c = walk.cell;
            let range = self.grid.sub_cells
                [walk.split.offset as usize + ((c.x * res + c.y) * res + c.z) as usize];
            walk.t = t_max;
            walk.cell[axis] += self.step[axis];
            if walk.cell[axis] < 0 || walk.cell[axis] >= res {
                walk.t_end = t_max;
            } else {
                walk.t_next[axis] = crossing(
                    walk.corner[axis],
                    walk.size[axis],
                    self.origin[axis],
                    self.inv_direction[axis],
                    walk.cell[axis],
                    self.step[axis],
                );
            }
            if range.max > 0.0 && t_max > t_min {
                return Some(MajorantSegment {
                    t_min,
                    t_max,
                    sigma_maj: range.max * self.scale_max,
                    sigma_min: range.min * self.scale_min,
                });
            }
        }
        self.sub = None;
        None
    }

    /// `[t_min, t_max)` narrowed to the part inside `cell`'s `support` box.
    #[inline]
    fn clip(&self, cell: IVec3, support: SupportBox, t_min: f32, t_max: f32) -> (f32, f32) {
        if support == SupportBox::FULL {
            return (t_min, t_max);
        }
        let (lo, hi) = self.grid.support_box(cell, support);
        clip_to_box(self.origin, self.inv_direction, lo, hi, t_min, t_max)
    }
}

/// The axis whose next cell plane the ray reaches first (x on ties, then y).
#[inline]
fn nearest_axis(t_next: Vec3) -> usize {
    if t_next.x <= t_next.y && t_next.x <= t_next.z {
        0
    } else if t_next.y <= t_next.z {
        1
    } else {
        2
    }
}

/// Where the ray (`o` and `inv_d` = 1 / d on one axis) leaves cell `cell`
/// of a row of cells `size` wide from `lo`, stepping by `step`; infinity if
/// it never does.
#[inline]
fn crossing(lo: f32, size: f32, o: f32, inv_d: f32, cell: i32, step: i32) -> f32 {
    if step == 0 {
        return f32::INFINITY;
    }
    let plane = lo + (cell + i32::from(step > 0)) as f32 * size;
    (plane - o) * inv_d
}

/// The part of `[t_min, t_max)` where the ray `origin + t direction` lies in
/// the box `[lo, hi)` (slab test), given `inv_direction` = 1 / direction;
/// empty, with `t_max` = -infinity, when the ray runs parallel to an axis
/// (infinite `inv_direction` there) outside the box's extent on it.
#[inline]
fn clip_to_box(
    origin: Vec3,
    inv_direction: Vec3,
    lo: Vec3,
    hi: Vec3,
    mut t_min: f32,
    mut t_max: f32,
) -> (f32, f32) {
    for a in 0..3 {
        if inv_direction[a].is_infinite() {
            if !(lo[a] <= origin[a] && origin[a] < hi[a]) {
                t_max = f32::NEG_INFINITY;
            }
        } else {
            let t0 = (lo[a] - origin[a]) * inv_direction[a];
            let t1 = (hi[a] - origin[a]) * inv_direction[a];
            t_min = t_min.max(t0.min(t1));
            t_max = t_max.min(t0.max(t1));
        }
    }
    (t_min, t_max)
}

impl MajorantGrid {
    /// The segments of the ray `origin + t * direction` (INDEX space of the
    /// grid; `direction` need not be unit) for t in `[t_min, t_max)`, front to
    /// back, found by a 3D DDA (Amanatides & Woo 1987) after clipping to the
    /// grid's bounds. Since `t` is the ray's own parameter, it is the caller's
    /// world `t` when the caller maps its world ray to index space affinely.
    /// Cells whose max density is 0 are not yielded; consecutive yielded
    /// segments share their boundary value exactly. `scale` (densityScale,
    /// per RGB channel) multiplies density into `sigma_t`: the majorant by
    /// its largest channel, the minorant by its smallest; with a unit-length
    /// world direction, `t` and `sigma_t` are in world units.
    pub fn segments(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_min: f32,
        t_max: f32,
        scale: Vec3,
    ) -> MajorantSegments<'_> {
        let hi = self.lo + self.dims.as_vec3() * self.cell_size;
        let inv_direction = direction.recip();
        let (t_enter, t_exit) = clip_to_box(origin, inv_direction, self.lo, hi, t_min, t_max);
        let p = if t_enter.is_finite() {
            origin + direction * t_enter
        } else {
            origin
        };
        let cell = ((p - self.lo) / self.cell_size)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, (self.dims - IVec3::ONE).max(IVec3::ZERO));
        // A component so small that its reciprocal overflows runs parallel.
        let step = IVec3::from_array(std::array::from_fn(|a| {
            if inv_direction[a].is_infinite() {
                0
            } else {
                Self::sign(direction[a])
            }
        }));
        let t_next = Vec3::from_array(std::array::from_fn(|a| {
            self.crossing(origin[a], inv_direction[a], cell[a], step[a], a)
        }));
        MajorantSegments {
            grid: self,
            origin,
            direction,
            inv_direction,
            cell,
            step,
            t_next,
            t: t_enter,
            t_exit,
            scale_max: scale.max_element(),
            scale_min: scale.min_element(),
            sub: None,
        }
    }

    /// Where the ray leaves cell `cell` along `axis` (of the ray's `o` and
    /// `inv_d` = 1 / d on that axis, stepping by `step`), or infinity if it
    /// never does.
    #[inline]
    fn crossing(&self, o: f32, inv_d: f32, cell: i32, step: i32, axis: usize) -> f32 {
        crossing(self.lo[axis], self.cell_size[axis], o, inv_d, cell, step)
    }

    fn sign(d: f32) -> i32 {
        if d > 0.0 {
            1
        } else if d < 0.0 {
            -1
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::volumes::grid::{GridTransform, SparseGrid};
    use crate::volumes::majorant::cells::tests::{
        assert_exact_ranges, density, split_grids, synthetic, SMOKE, TEAPOT,
    };
    use crate::volumes::majorant::cells::DensityRange;
    use crate::volumes::majorant::MajorantKind;
    use glam::DAffine3;

    /// Past the cell limit, cells double until the grid fits; they still hold
    /// their footprint's exact range and the DDA walks them as before.
    #[test]
    fn coarse_cells_keep_exact_ranges_and_valid_segments() {
        let grid = synthetic();
        let mg = MajorantGrid::build_cells(&grid, 8);
        assert_eq!(mg.cell_size, Vec3::splat(32.0));
        assert!(mg.cells.len() <= 8);
        assert!(assert_exact_ranges(&grid, &mg) > 0);
        for (o, d, t0, t1) in random_rays(&mg, 13, 100) {
            check_ray(&grid, &mg, o, d, t0, t1);
        }
    }

    /// The segments of one ray, checked against a brute-force march: they are
    /// ordered and non-empty, consecutive ones meet exactly or leave a gap of
    /// empty cells, each carries its cell's (or sub-cell's) range x `scale`,
    /// which `max_at` reports there too, and density at every marched point
    /// inside one stays under its majorant.
    fn check_ray(
        grid: &SparseGrid,
        mg: &MajorantGrid,
        o: Vec3,
        d: Vec3,
        t0: f32,
        t1: f32,
    ) -> Vec<MajorantSegment> {
        let scale = 2.5;
        let segments: Vec<MajorantSegment> =
            mg.segments(o, d, t0, t1, Vec3::splat(scale)).collect();
        for (i, s) in segments.iter().enumerate() {
            assert!(t0 <= s.t_min && s.t_min < s.t_max && s.t_max <= t1, "{s:?}");
            assert!(s.sigma_maj > 0.0 && s.sigma_min <= s.sigma_maj);
            if i > 0 {
                assert!(segments[i - 1].t_max <= s.t_min);
            }
        }
        // Reference clip in f64.
        let (lo, hi) = (
            mg.lo.as_dvec3(),
            (mg.lo + mg.dims.as_vec3() * mg.cell_size).as_dvec3(),
        );
        let (o64, d64) = (o.as_dvec3(), d.as_dvec3());
        let (mut enter, mut exit) = (t0 as f64, t1 as f64);
        for a in 0..3 {
            if d64[a] == 0.0 {
                if !(lo[a] <= o64[a] && o64[a] < hi[a]) {
                    exit = f64::NEG_INFINITY;
                }
            } else {
                let (ta, tb) = ((lo[a] - o64[a]) / d64[a], (hi[a] - o64[a]) / d64[a]);
                enter = enter.max(ta.min(tb));
                exit = exit.min(ta.max(tb));
            }
        }
        if enter >= exit {
            assert!(
                segments.is_empty(),
                "a ray missing the grid yields {segments:?}"
            );
            return segments;
        }
        let steps = 4000;
        for k in 0..steps {
            let t = enter + (exit - enter) * (k as f64 + 0.5) / steps as f64;
            let p = o64 + d64 * t;
            let u = (p - lo) / mg.cell_size.as_dvec3();
            // Too close to a plane the ray crosses (of a cell, of a one-voxel
            // sub-cell or of a support box, at eighths of a cell) for f32 to
            // tell the two cells apart.
            let near_plane = (0..3).any(|a| {
                let v = 8.0 * u[a];
                d64[a] != 0.0 && (v - v.round()).abs() < 1e-3
            });
            if near_plane {
                continue;
            }
            let c = u
                .floor()
                .as_ivec3()
                .clamp(IVec3::ZERO, mg.dims - IVec3::ONE);
            let range = mg.range_at(c, mg.cell_slot(c), p.as_vec3());
            let hit = segments
                .iter()
                .find(|s| (s.t_min as f64) <= t && t < s.t_max as f64);
            match hit {
                None => {
                    let v = grid.trilinear_index(p.as_vec3()).max(0.0);
                    assert_eq!(v, 0.0, "t = {t} in cell {c} ({range:?}) is in no segment");
                }
                Some(s) => {
                    assert_eq!(
                        (s.sigma_maj, s.sigma_min),
                        (range.max * scale, range.min * scale)
                    );
                    assert_eq!(mg.max_at(p.as_vec3()) * scale, s.sigma_maj, "t = {t}");
                    let v = grid.trilinear_index(p.as_vec3()) * scale;
                    assert!(
                        v <= s.sigma_maj * (1.0 + 1e-5),
                        "density {v} over {s:?} at t = {t}"
                    );
                }
            }
        }
        segments
    }

    /// Random rays: origins inside and outside, negative and axis-parallel
    /// directions, rays on cell planes, t_min > 0 and t_max = infinity.
    fn random_rays(mg: &MajorantGrid, seed: u64, count: usize) -> Vec<(Vec3, Vec3, f32, f32)> {
        let mut rng = Pcg32::new(seed, 0);
        let size = mg.dims.as_vec3() * mg.cell_size;
        let u3 = |rng: &mut Pcg32| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        (0..count)
            .map(|i| {
                let mut o = mg.lo - 0.5 * size + 2.0 * size * u3(&mut rng);
                let mut d = u3(&mut rng) * 2.0 - Vec3::ONE;
                match i % 4 {
                    // Axis-parallel, on a cell plane of another axis.
                    1 => {
                        let a = rng.next_u32() as usize % 3;
                        d = Vec3::ZERO;
                        d[a] = if rng.next_u32() & 1 == 0 { 3.0 } else { -0.5 };
                        let b = (a + 1) % 3;
                        o[b] = mg.lo[b]
                            + (rng.next_u32() % mg.dims[b] as u32) as f32 * mg.cell_size[b];
                    }
                    // In a coordinate plane, through cell corners.
                    2 => {
                        d[rng.next_u32() as usize % 3] = 0.0;
                        o = mg.lo + (u3(&mut rng) * mg.dims.as_vec3()).floor() * mg.cell_size;
                        d = d.signum();
                    }
                    _ => {}
                }
                let t0 = if i % 3 == 0 {
                    0.0
                } else {
                    rng.next_f32() * 10.0
                };
                let t1 = if i % 2 == 0 {
                    f32::INFINITY
                } else {
                    t0 + rng.next_f32() * 2.0 * size.max_element()
                };
                (o, d, t0, t1)
            })
            .collect()
    }

    #[test]
    fn dda_segments_tile_the_clipped_ray_and_bound_density() {
        for grid in [synthetic(), density(TEAPOT)] {
            let mg = MajorantGrid::build(&grid, MajorantKind::Grid);
            let mut yielded = 0;
            for (o, d, t0, t1) in random_rays(&mg, 3, 300) {
                yielded += check_ray(&grid, &mg, o, d, t0, t1).len();
            }
            // Empty parts of cells yield nothing: 33 on the synthetic grid.
            assert!(yielded > 25, "{yielded} segments");
        }
    }

    /// The same through split cells (`Adaptive`, refine.rs) of the ramp,
    /// the smoke and the teapot cloud: the sub-cell walk tiles each cell's
    /// clipped stretch exactly and every segment carries its sub-cell's
    /// range. Split cells yield more segments than whole ones.
    #[test]
    fn dda_walks_split_cells_exactly() {
        for (name, grid, mg) in split_grids() {
            let whole = MajorantGrid::build(&grid, MajorantKind::Grid);
            let (mut split, mut unsplit) = (0, 0);
            for (o, d, t0, t1) in random_rays(&mg, 21, 150) {
                split += check_ray(&grid, &mg, o, d, t0, t1).len();
                unsplit += whole.segments(o, d, t0, t1, Vec3::ONE).count();
            }
            println!("{name}: {split} segments split, {unsplit} whole");
            assert!(split > unsplit, "{name}: {split} vs {unsplit}");
        }
    }

    /// One positive voxel at (3, 4, 5) in an otherwise empty leaf:
    /// interpolation feels it within one voxel, so a ray along x through it
    /// gets one segment over x in [2, 4], and a ray along x two voxels off it
    /// (the same cells) gets none.
    #[test]
    fn segments_are_clipped_to_where_density_can_be_non_zero() {
        let mut values = vec![0.0; 512];
        // OpenVDB's voxel order: x slowest, z fastest.
        values[(3 * 8 + 4) * 8 + 5] = 1.0;
        let identity = GridTransform::new(DAffine3::IDENTITY).unwrap();
        let grid = SparseGrid::build(0.0, &[IVec3::ZERO], values, &[], identity).unwrap();
        let mg = MajorantGrid::build(&grid, MajorantKind::Grid);
        let along_x = |y: f32, z: f32| -> Vec<MajorantSegment> {
            mg.segments(
                Vec3::new(-20.0, y, z),
                Vec3::X,
                0.0,
                f32::INFINITY,
                Vec3::ONE,
            )
            .collect()
        };
        let through = along_x(4.0, 5.0);
        assert_eq!(through.len(), 1, "{through:?}");
        assert_eq!((through[0].t_min, through[0].t_max), (22.0, 24.0));
        assert_eq!(through[0].sigma_maj, 1.0);
        assert!(along_x(6.0, 5.0).is_empty());
        assert!(along_x(4.0, 2.5).is_empty());
        // Inside the support but off the voxel's line: still one segment.
        assert_eq!(along_x(4.5, 5.5).len(), 1);
    }

    #[test]
    fn rays_missing_the_grid_yield_nothing() {
        let grid = synthetic();
        let mg = MajorantGrid::build(&grid, MajorantKind::Grid);
        let hi = mg.lo + mg.dims.as_vec3() * mg.cell_size;
        let beside = Vec3::new(hi.x + 1.0, mg.lo.y + 3.0, mg.lo.z + 3.0);
        let away = mg.lo - Vec3::ONE;
        for (o, d, t0, t1) in [
            (beside, Vec3::Y, 0.0, f32::INFINITY),
            (beside, Vec3::new(1.0, 0.2, 0.1), 0.0, f32::INFINITY),
            (away, -Vec3::ONE, 0.0, f32::INFINITY),
            (away, Vec3::ONE, 0.0, 0.5),
            (away, Vec3::ONE, 1e6, f32::INFINITY),
            // On the open upper face.
            (
                Vec3::new(hi.x, mg.lo.y + 3.0, mg.lo.z + 3.0),
                Vec3::Y,
                0.0,
                f32::INFINITY,
            ),
        ] {
            assert_eq!(
                mg.segments(o, d, t0, t1, Vec3::ONE).count(),
                0,
                "{o} {d} [{t0}, {t1})"
            );
        }
        // And a non-empty grid is hit at all: this ray goes through the first leaf.
        assert!(
            mg.segments(
                Vec3::new(-20.0, 3.5, 3.5),
                Vec3::X,
                0.0,
                f32::INFINITY,
                Vec3::ONE
            )
            .count()
                > 0
        );
    }

    #[test]
    fn global_yields_one_segment_over_the_clipped_range() {
        let grid = density(TEAPOT);
        let mg = MajorantGrid::build(&grid, MajorantKind::Global);
        assert_eq!(mg.cells.len(), 1);
        let max = grid.stats().max_value;
        assert_eq!(mg.cells[0], DensityRange { max, min: 0.0 });
        let mut hits = 0;
        for (o, d, t0, t1) in random_rays(&mg, 5, 200) {
            let segments = check_ray(&grid, &mg, o, d, t0, t1);
            assert!(segments.len() <= 1);
            hits += segments.len();
        }
        assert!(hits > 50, "{hits} hits");
    }

    /// The point of the grid: along random rays through each shared VDB, the
    /// majorant's optical depth (sum of sigma_maj x length, the expected
    /// number of tentative collisions) is several times smaller than the
    /// global majorant's. The teapot cloud is dense (50 inside): even the
    /// true optical depth is only 2.85x below the global one there.
    #[test]
    fn grid_majorant_is_much_tighter_than_global() {
        for (path, min_ratio) in [(TEAPOT, 2.0), (SMOKE, 10.0)] {
            let grid = density(path);
            let local = MajorantGrid::build(&grid, MajorantKind::Grid);
            let global = MajorantGrid::build(&grid, MajorantKind::Global);
            let optical_depth = |mg: &MajorantGrid, o: Vec3, d: Vec3| -> f64 {
                mg.segments(o, d, 0.0, f32::INFINITY, Vec3::ONE)
                    .map(|s| s.sigma_maj as f64 * (s.t_max - s.t_min) as f64)
                    .sum()
            };
            let mut rng = Pcg32::new(9, 0);
            let (lo, size) = (global.lo, global.cell_size);
            let (mut sum_local, mut sum_global) = (0.0, 0.0);
            for _ in 0..2000 {
                let mut u3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let o = lo + size * u3();
                let d = (lo + size * u3() - o).normalize_or(Vec3::X);
                // Back out of the bounds along -d, so the whole chord counts.
                let o = o - d * 2.0 * size.length();
                sum_local += optical_depth(&local, o, d);
                sum_global += optical_depth(&global, o, d);
            }
            let ratio = sum_global / sum_local;
            println!("{path}: global / grid majorant optical depth {ratio:.2}");
            assert!(ratio > min_ratio, "{ratio}");
        }
    }
}
