//! `MajorantGrid`: bounds on density over coarse cells of a [`SparseGrid`],
//! walked along a ray by a 3D DDA (Amanatides & Woo 1987), so null-collision
//! trackers (Novák et al. 2018, §4) sample against a tight local majorant and
//! skip empty space, as pbrt-v4's `MajorantGrid`/`DDAMajorantIterator` do.
//!
//! Cells follow the VDB's own blocks: one cell per 8^3 leaf block (index-space
//! box `[8c, 8c + 8)`), so a cell's bounds come straight from one apron brick,
//! constant tile or empty block. A trilinear lookup inside the box reads the
//! voxels `8c ..= 8c + 8` on each axis (docs/conventions.md, "Voxel centres":
//! values sit at integer index points), so each cell stores the max and min
//! over that 9^3 footprint: a conservative bound for every interpolated value,
//! the background included wherever the footprint leaves the stored data.
//!
//! Each cell also keeps the box, in eighths of its edge, outside which its
//! interpolated density is zero (a voxel value is felt within one voxel of
//! it), and the DDA clips its segment to that box. Boundary cells of a dense
//! cloud, half empty, then cost nothing over their empty half: without the
//! box, their majorant (the cloud's density) drew tentative collisions all
//! over it, every one null (docs/volumes.md).
//!
//! Memory: 14 bytes per cell, dense over the block bounds of the data plus one
//! cell on the low side of each axis (whose footprint reaches the data's first
//! voxel layer). A 1000^3-voxel grid takes 2M cells = 28 MB. Grids so large
//! that this would pass [`MAX_CELLS`] get coarser cells (16^3, 32^3, ...
//! voxels) instead.
//!
//! Negative densities are treated as zero: both bounds are clamped to >= 0,
//! so consumers must clamp `sigma_t` to >= 0 as well. The majorant covers only
//! the stored data: a non-zero background beyond it (a medium of infinite
//! extent) is not represented.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use super::SparseGrid;

/// Voxels per cell edge, log2, at the finest resolution (one OpenVDB leaf).
const BLOCK_LOG2: i32 = 3;
/// Most cells kept (14 bytes each: 224 MiB); larger grids get coarser cells.
const MAX_CELLS: u64 = 1 << 24;

/// One stretch of a ray over which extinction is bounded:
/// `sigma_min <= sigma_t(t) <= sigma_maj` for t in `[t_min, t_max)`.
/// Extinctions are per unit of `t` along the caller's direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MajorantSegment {
    /// Start of the stretch, in the caller's ray parameter.
    pub t_min: f32,
    /// End of the stretch (exclusive); the next segment starts exactly here
    /// unless empty cells or a cell's empty part were skipped.
    pub t_max: f32,
    /// Majorant of `sigma_t` (density max x scale) over the stretch, grey:
    /// it bounds every RGB channel of a chromatic extinction.
    pub sigma_maj: f32,
    /// Minorant of `sigma_t` (density min x scale, >= 0) in every channel,
    /// the control extinction of residual ratio tracking (Novák et al. 2014).
    pub sigma_min: f32,
}

/// A cell of a [`MajorantGrid`] whose density can be non-zero.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OccupiedCell {
    /// Its slot in the grid's cell array.
    pub slot: u32,
    /// Its coordinates in the grid (see [`MajorantGrid::cell_layout`]).
    pub cell: IVec3,
    /// Index-space box of its support, min corner.
    pub lo: Vec3,
    /// Index-space box of its support, max corner.
    pub hi: Vec3,
    /// Max of the interpolated density over the cell (unscaled).
    pub density_max: f32,
}

/// How finely majorants follow the density: per 8^3 block, or one bound for
/// the whole grid (the baseline, `--majorant global`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MajorantKind {
    /// One cell per 8^3 voxels (OpenVDB leaf), empty cells skipped.
    #[default]
    Grid,
    /// A single cell over the grid's whole bounds.
    Global,
}

crate::choice::choice!(MajorantKind {
    Grid => "grid",
    Global => "global",
});

/// Max and min density over the trilinear footprint of one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
struct DensityRange {
    max: f32,
    min: f32,
}

/// Where in one cell interpolated density can be non-zero: the box
/// `[lo, hi]` per axis, in eighths of the cell's edge (0..=8); `FULL` when
/// the whole cell may hold density.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SupportBox {
    lo: [u8; 3],
    hi: [u8; 3],
}

impl SupportBox {
    const FULL: Self = Self {
        lo: [0; 3],
        hi: [8; 3],
    };

    /// The box of the voxel-unit range `lo..hi` (relative to the cell's first
    /// voxel) in a cell `edge` voxels wide, rounded outward to eighths.
    fn of_voxels(lo: IVec3, hi: IVec3, edge: i32) -> Self {
        let eighths = |v: i32, up: bool| {
            let v = v.clamp(0, edge) * 8;
            (if up { (v + edge - 1) / edge } else { v / edge }) as u8
        };
        Self {
            lo: std::array::from_fn(|a| eighths(lo[a], false)),
            hi: std::array::from_fn(|a| eighths(hi[a], true)),
        }
    }
}

/// Conservative density bounds over a dense array of axis-aligned cells in a
/// grid's index space; see the module doc.
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    /// Index-space min corner of cell (0, 0, 0).
    lo: Vec3,
    /// Cell edge lengths, in voxels.
    cell_size: Vec3,
    /// Cells along each axis (x slowest, z fastest).
    dims: IVec3,
    cells: Vec<DensityRange>,
    /// Per cell, beside `cells`: where its density can be non-zero.
    supports: Vec<SupportBox>,
}

/// The iterator returned by [`MajorantGrid::segments`]: an Amanatides & Woo
/// DDA that yields the non-empty cells the ray crosses, front to back.
pub struct MajorantSegments<'a> {
    grid: &'a MajorantGrid,
    origin: Vec3,
    direction: Vec3,
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
}

impl Iterator for MajorantSegments<'_> {
    type Item = MajorantSegment;

    #[inline]
    fn next(&mut self) -> Option<MajorantSegment> {
        while self.t < self.t_exit {
            let axis = if self.t_next.x <= self.t_next.y && self.t_next.x <= self.t_next.z {
                0
            } else if self.t_next.y <= self.t_next.z {
                1
            } else {
                2
            };
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
                    self.direction[axis],
                    self.cell[axis],
                    self.step[axis],
                    axis,
                );
            }
            if range.max > 0.0 && t_max > t_min {
                let (t_min, t_max) = self.clip(cell, self.grid.supports[slot], t_min, t_max);
                if t_max > t_min {
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
    /// `[t_min, t_max)` narrowed to the part inside `cell`'s `support` box.
    #[inline]
    fn clip(&self, cell: IVec3, support: SupportBox, t_min: f32, t_max: f32) -> (f32, f32) {
        if support == SupportBox::FULL {
            return (t_min, t_max);
        }
        let (lo, hi) = self.grid.support_box(cell, support);
        clip_to_box(self.origin, self.direction, lo, hi, t_min, t_max)
    }
}

/// The part of `[t_min, t_max)` where the ray `origin + t direction` lies in
/// the box `[lo, hi)` (slab test); empty, with `t_max` = -infinity, when the
/// ray runs parallel to an axis outside the box's extent on it.
fn clip_to_box(
    origin: Vec3,
    direction: Vec3,
    lo: Vec3,
    hi: Vec3,
    mut t_min: f32,
    mut t_max: f32,
) -> (f32, f32) {
    for a in 0..3 {
        if direction[a] == 0.0 {
            if !(lo[a] <= origin[a] && origin[a] < hi[a]) {
                t_max = f32::NEG_INFINITY;
            }
        } else {
            let t0 = (lo[a] - origin[a]) / direction[a];
            let t1 = (hi[a] - origin[a]) / direction[a];
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
        let (t_enter, t_exit) = clip_to_box(origin, direction, self.lo, hi, t_min, t_max);
        let p = if t_enter.is_finite() {
            origin + direction * t_enter
        } else {
            origin
        };
        let cell = ((p - self.lo) / self.cell_size)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, (self.dims - IVec3::ONE).max(IVec3::ZERO));
        let step = IVec3::new(
            Self::sign(direction.x),
            Self::sign(direction.y),
            Self::sign(direction.z),
        );
        let t_next = Vec3::from_array(std::array::from_fn(|a| {
            self.crossing(origin[a], direction[a], cell[a], step[a], a)
        }));
        MajorantSegments {
            grid: self,
            origin,
            direction,
            cell,
            step,
            t_next,
            t: t_enter,
            t_exit,
            scale_max: scale.max_element(),
            scale_min: scale.min_element(),
        }
    }

    /// Where the ray leaves cell `cell` along `axis` (of the ray's `o` and `d`
    /// on that axis, stepping by `step`), or infinity if it never does.
    #[inline]
    fn crossing(&self, o: f32, d: f32, cell: i32, step: i32, axis: usize) -> f32 {
        if step == 0 {
            return f32::INFINITY;
        }
        let plane = self.lo[axis] + (cell + i32::from(step > 0)) as f32 * self.cell_size[axis];
        (plane - o) / d
    }

    /// The slot of the cell at coordinates `c` (inside the grid).
    #[inline]
    pub(crate) fn cell_slot(&self, c: IVec3) -> usize {
        ((c.x * self.dims.y + c.y) * self.dims.z + c.z) as usize
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

    /// The index-space box the cells cover (every point where density can be
    /// non-zero lies inside it), as (min corner, max corner).
    pub fn index_box(&self) -> (Vec3, Vec3) {
        (self.lo, self.lo + self.cell_size * self.dims.as_vec3())
    }

    /// Every cell whose density can be non-zero, in slot order: its slot,
    /// the index-space box of its support (where interpolated density can be
    /// non-zero) and its density max. Emission light sampling picks among
    /// these (`emitter.rs`).
    pub(crate) fn occupied_cells(&self) -> impl Iterator<Item = OccupiedCell> + '_ {
        let d = self.dims;
        (0..self.cells.len()).filter_map(move |slot| {
            let range = self.cells[slot];
            if range.max <= 0.0 {
                return None;
            }
            let n = slot as i32;
            let cell = IVec3::new(n / (d.y * d.z), n / d.z % d.y, n % d.z);
            let (lo, hi) = self.support_box(cell, self.supports[slot]);
            Some(OccupiedCell {
                slot: slot as u32,
                cell,
                lo,
                hi,
                density_max: range.max,
            })
        })
    }

    /// Cells along each index axis (slots run x slowest, z fastest) and the
    /// cell edge, in voxels.
    pub(crate) fn cell_layout(&self) -> (IVec3, Vec3) {
        (self.dims, self.cell_size)
    }

    /// The slot of the cell holding index-space point `p` when `p` lies in
    /// that cell's support box (so the DDA yields a segment there); `None`
    /// outside the grid, in an empty cell or outside the support.
    pub(crate) fn occupied_slot_at(&self, p: Vec3) -> Option<u32> {
        let cell = ((p - self.lo) / self.cell_size).floor().as_ivec3();
        if cell.cmplt(IVec3::ZERO).any() || cell.cmpge(self.dims).any() {
            return None;
        }
        let slot = self.cell_slot(cell);
        if self.cells[slot].max <= 0.0 {
            return None;
        }
        let (lo, hi) = self.support_box(cell, self.supports[slot]);
        (p.cmpge(lo).all() && p.cmplt(hi).all()).then_some(slot as u32)
    }

    /// The density majorant the DDA carries at index-space point `p`: its
    /// cell's max inside the cell's support box, 0 elsewhere.
    pub(crate) fn max_at(&self, p: Vec3) -> f32 {
        self.occupied_slot_at(p)
            .map_or(0.0, |slot| self.cells[slot as usize].max)
    }

    /// The index-space box `[lo, hi)` of `cell`'s `support`.
    fn support_box(&self, cell: IVec3, support: SupportBox) -> (Vec3, Vec3) {
        let corner = self.lo + cell.as_vec3() * self.cell_size;
        let eighth = self.cell_size / 8.0;
        (
            corner + Vec3::from(support.lo.map(f32::from)) * eighth,
            corner + Vec3::from(support.hi.map(f32::from)) * eighth,
        )
    }

    /// Bytes held (the struct and its cell array).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.cells.capacity() * std::mem::size_of::<DensityRange>()
            + self.supports.capacity() * std::mem::size_of::<SupportBox>()
    }

    /// Max and min of the trilinearly interpolated density over each cell of
    /// 8^3 voxels (aligned with the VDB leaves), built in parallel (rayon)
    /// from the grid's leaves and tiles; `Global`: one cell over the same
    /// bounds, holding the max and min over all of them.
    pub fn build(grid: &SparseGrid, kind: MajorantKind) -> Self {
        let cells = Self::build_cells(grid, MAX_CELLS);
        match kind {
            MajorantKind::Grid => cells,
            MajorantKind::Global => cells.merged(),
        }
    }

    /// The per-block cells, coarsened by powers of two until at most `max_cells` remain.
    fn build_cells(grid: &SparseGrid, max_cells: u64) -> Self {
        let Some(blocks) = grid.block_bounds() else {
            return Self {
                lo: Vec3::ZERO,
                cell_size: Vec3::splat((1 << BLOCK_LOG2) as f32),
                dims: IVec3::ZERO,
                cells: Vec::new(),
                supports: Vec::new(),
            };
        };
        // One block below the data: its +1 footprint reaches the data's first voxel layer.
        let first = *blocks.start() - IVec3::ONE;
        let last = *blocks.end();
        // log2 of blocks per cell edge: 0 unless the grid is huge.
        let mut merge: i32 = 0;
        let (lo, dims) = loop {
            let (lo, hi) = (first >> merge, last >> merge);
            let dims = hi - lo + IVec3::ONE;
            if dims.as_i64vec3().element_product() as u64 <= max_cells {
                break (lo, dims);
            }
            merge += 1;
        };
        let blocks_per_cell = 1 << merge;
        let edge = blocks_per_cell << BLOCK_LOG2;
        let (cells, supports) = (0..dims.element_product() as usize)
            .into_par_iter()
            .map(|n| {
                let n = n as i32;
                let c = lo + IVec3::new(n / (dims.y * dims.z), n / dims.z % dims.y, n % dims.z);
                let mut range = DensityRange {
                    max: f32::NEG_INFINITY,
                    min: f32::INFINITY,
                };
                // The footprint of the cell's last blocks reaches one block further.
                let first = c << merge;
                if grid.blocks_are_empty(first, first + IVec3::splat(blocks_per_cell)) {
                    range.include(grid.background());
                    return (range.clamped(), SupportBox::FULL);
                }
                // In voxels from the cell's first one: the box of points within
                // one voxel of a positive value (values sit at integer points).
                let (mut support_lo, mut support_hi) = (IVec3::splat(edge), IVec3::ZERO);
                for x in 0..blocks_per_cell {
                    for y in 0..blocks_per_cell {
                        for z in 0..blocks_per_cell {
                            let offset = IVec3::new(x, y, z) << BLOCK_LOG2;
                            let block = first + IVec3::new(x, y, z);
                            grid.for_each_footprint_value(block, |lo, hi, v| {
                                range.include(v);
                                if v.is_finite() && v > 0.0 {
                                    support_lo = support_lo.min(offset + lo - IVec3::ONE);
                                    support_hi = support_hi.max(offset + hi + IVec3::ONE);
                                }
                            });
                        }
                    }
                }
                let support = SupportBox::of_voxels(support_lo, support_hi, edge);
                (range.clamped(), support)
            })
            .unzip();
        Self {
            lo: (lo << (merge + BLOCK_LOG2)).as_vec3(),
            cell_size: Vec3::splat(edge as f32),
            dims,
            cells,
            supports,
        }
    }

    /// A copy whose cells `(slot, floor)` hold at least `floor` as their
    /// density max (the support boxes unchanged): still a majorant, with
    /// more tentative collisions there (see `EmissionCells::collision_floors`).
    pub(crate) fn with_floors(&self, floors: impl IntoIterator<Item = (u32, f32)>) -> Self {
        let mut raised = self.clone();
        for (slot, floor) in floors {
            let cell = &mut raised.cells[slot as usize];
            cell.max = cell.max.max(floor);
        }
        raised
    }

    /// One cell over the same bounds, bounding all of them.
    fn merged(self) -> Self {
        let all = self.cells.iter().fold(
            DensityRange {
                max: 0.0,
                min: f32::INFINITY,
            },
            |acc, c| DensityRange {
                max: acc.max.max(c.max),
                min: acc.min.min(c.min),
            },
        );
        Self {
            lo: self.lo,
            cell_size: self.cell_size * self.dims.as_vec3(),
            dims: self.dims.min(IVec3::ONE),
            cells: if self.cells.is_empty() {
                Vec::new()
            } else {
                vec![all]
            },
            supports: if self.cells.is_empty() {
                Vec::new()
            } else {
                vec![SupportBox::FULL]
            },
        }
    }
}

impl DensityRange {
    /// Widens the range to hold `v`; NaN and infinities are ignored (media
    /// read them as 0, see `Medium::density`).
    fn include(&mut self, v: f32) {
        if v.is_finite() {
            self.max = self.max.max(v);
            self.min = self.min.min(v);
        }
    }

    /// Negative densities count as zero (see the module doc); `min <= max`.
    fn clamped(self) -> Self {
        let max = self.max.max(0.0);
        Self {
            max,
            min: self.min.max(0.0).min(max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::volumes::{GridTransform, Tile, VdbFile};
    use glam::DAffine3;

    const TEAPOT: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/assets/pbrt-v4-volumes/scenes/teapot_cloud/geometry/teapot_cloud.vdb"
    );
    const SMOKE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/assets/arnold-usd/test_0030/data/smoke.vdb"
    );

    fn density(path: &str) -> SparseGrid {
        VdbFile::open(path)
            .unwrap()
            .read_float_grid("density", 0)
            .unwrap()
    }

    /// Two leaves with random values in [0, 1) and an empty block between
    /// them, an 8^3 tile of 0.75 and a negative leaf: empty cells between
    /// non-empty ones, constant regions and the clamp all show up.
    fn synthetic() -> SparseGrid {
        let mut rng = Pcg32::new(7, 0);
        let origins = [IVec3::ZERO, IVec3::new(16, 8, 0), IVec3::new(0, 24, 8)];
        let mut values: Vec<f32> = (0..2 * 512).map(|_| rng.next_f32()).collect();
        values.extend((0..512).map(|_| -rng.next_f32()));
        let tile = Tile {
            origin: IVec3::new(8, 16, 16),
            edge: 8,
            value: 0.75,
            active: true,
        };
        let identity = GridTransform::new(DAffine3::IDENTITY).unwrap();
        SparseGrid::build(0.0, &origins, values, &[tile], identity).unwrap()
    }

    fn cell_coords(mg: &MajorantGrid) -> impl Iterator<Item = IVec3> + '_ {
        let d = mg.dims;
        (0..d.x).flat_map(move |x| {
            (0..d.y).flat_map(move |y| (0..d.z).map(move |z| IVec3::new(x, y, z)))
        })
    }

    /// Asserts every cell holds the clamped max and min of the voxels its
    /// trilinear footprint reads (its own and one beyond on +x/+y/+z), read
    /// one by one; returns the number of non-empty cells.
    fn assert_exact_ranges(grid: &SparseGrid, mg: &MajorantGrid) -> usize {
        let edge = mg.cell_size.x as i32;
        let mut non_empty = 0;
        for c in cell_coords(mg) {
            let first = mg.lo.as_ivec3() + c * edge;
            let mut expected = DensityRange {
                max: f32::NEG_INFINITY,
                min: f32::INFINITY,
            };
            for x in 0..=edge {
                for y in 0..=edge {
                    for z in 0..=edge {
                        expected.include(grid.value(first + IVec3::new(x, y, z)));
                    }
                }
            }
            assert_eq!(mg.cells[mg.cell_slot(c)], expected.clamped(), "cell {c}");
            non_empty += usize::from(expected.max > 0.0);
        }
        non_empty
    }

    /// Two leaves 300 super-blocks (38,400 voxels) apart on every axis:
    /// the cells are coarsened to stay under the cap, empty space is skipped
    /// by super-block (visiting its 2^34 blocks one by one would take hours),
    /// and the two cells holding data still bound it exactly.
    #[test]
    fn far_apart_leaves_build_without_visiting_empty_space() {
        let far = IVec3::splat(300 << 7);
        let values: Vec<f32> = (0..1024).map(|i| (i % 512) as f32 / 512.0).collect();
        let identity = GridTransform::new(DAffine3::IDENTITY).unwrap();
        let grid = SparseGrid::build(0.0, &[IVec3::ZERO, far], values, &[], identity).unwrap();
        let mg = MajorantGrid::build_cells(&grid, 1 << 16);
        assert!(mg.cells.len() <= 1 << 16);
        // Each leaf lies in one cell, and a cell below it may read its first layer.
        let filled = mg.cells.iter().filter(|r| r.max > 0.0).count();
        assert!((2..=16).contains(&filled), "{filled} cells hold data");
        for leaf in [IVec3::ZERO, far] {
            let c = ((leaf.as_vec3() - mg.lo) / mg.cell_size).floor().as_ivec3();
            let range = mg.cells[mg.cell_slot(c)];
            assert_eq!((range.min, range.max), (0.0, 511.0 / 512.0), "cell {c}");
        }
    }

    #[test]
    fn cells_hold_the_exact_range_of_their_trilinear_footprint() {
        for grid in [synthetic(), density(TEAPOT), density(SMOKE)] {
            let mg = MajorantGrid::build(&grid, MajorantKind::Grid);
            assert_eq!(mg.cell_size, Vec3::splat(8.0));
            let non_empty = assert_exact_ranges(&grid, &mg);
            // Data on both sides of the ranges: some cells are empty, most are not.
            assert!(non_empty > 0 && non_empty < mg.cells.len());
            println!(
                "{} cells ({} non-empty) of {:?}, {} KiB",
                mg.cells.len(),
                non_empty,
                mg.dims,
                mg.memory_bytes() / 1024
            );
        }
    }

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

    /// Trilinear density never leaves its cell's range, at 64 random points
    /// and the 8 corners of every cell (empty ones included: they are skipped).
    #[test]
    fn random_probes_stay_within_their_cell_range() {
        let mut rng = Pcg32::new(11, 0);
        for grid in [synthetic(), density(TEAPOT), density(SMOKE)] {
            let mg = MajorantGrid::build(&grid, MajorantKind::Grid);
            let mut probes = 0usize;
            for c in cell_coords(&mg) {
                let range = mg.cells[mg.cell_slot(c)];
                let corner = mg.lo + c.as_vec3() * mg.cell_size;
                let corners = (0..8)
                    .map(|n| Vec3::new((n >> 2) as f32, ((n >> 1) & 1) as f32, (n & 1) as f32));
                let inside: Vec<Vec3> = (0..64)
                    .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
                    .collect();
                for u in corners.chain(inside) {
                    let p = corner + u * mg.cell_size;
                    let v = grid.trilinear_index(p).max(0.0);
                    let slack = 1e-6 * range.max;
                    assert!(
                        range.min - slack <= v && v <= range.max + slack,
                        "{p}: {v} outside [{}, {}]",
                        range.min,
                        range.max
                    );
                    probes += 1;
                }
            }
            assert_eq!(probes, 72 * mg.cells.len());
        }
    }

    /// The segments of one ray, checked against a brute-force march: they are
    /// ordered and non-empty, consecutive ones meet exactly or leave a gap of
    /// empty cells, each carries its cell's range x `scale`, and density at
    /// every marched point inside one stays under its majorant.
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
            // Too close to a plane the ray crosses for f32 to tell the two cells apart.
            let near_plane = (0..3).any(|a| d64[a] != 0.0 && (u[a] - u[a].round()).abs() < 1e-4);
            if near_plane {
                continue;
            }
            let c = u
                .floor()
                .as_ivec3()
                .clamp(IVec3::ZERO, mg.dims - IVec3::ONE);
            let range = mg.cells[mg.cell_slot(c)];
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
