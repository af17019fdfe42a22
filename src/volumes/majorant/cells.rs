//! `MajorantGrid`: bounds on density over coarse cells of a [`SparseGrid`],
//! so null-collision trackers (Novák et al. 2018, §4) sample against a tight
//! local majorant and skip empty space, as pbrt-v4's `MajorantGrid` does.
//! dda.rs walks it along a ray.
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

use glam::{IVec3, U64Vec3, Vec3};
use rayon::prelude::*;

use crate::volumes::grid::{blocks_spanned, SparseGrid};

/// Voxels per cell edge, log2, at the finest resolution (one OpenVDB leaf).
pub(super) const BLOCK_LOG2: i32 = 3;
/// Most cells kept (14 bytes each: 224 MiB); larger grids get coarser cells.
const MAX_CELLS: u64 = 1 << 24;

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

/// How finely majorants follow the density: per 8^3 block, per block split
/// where density varies (refine.rs), or one bound for the whole grid (the
/// baseline, `--majorant global`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MajorantKind {
    /// One cell per 8^3 voxels (OpenVDB leaf), empty cells skipped.
    #[default]
    Grid,
    /// The 8^3 cells, split into 2^3, 4^3 or 8^3 sub-cells where
    /// (sigma_max - sigma_min) x diagonal > 1.44 (refine.rs).
    Adaptive,
    /// A single cell over the grid's whole bounds.
    Global,
}

crate::choice::choice!(MajorantKind {
    Grid => "grid",
    Adaptive => "adaptive",
    Global => "global",
});

/// Max and min density over the trilinear footprint of one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct DensityRange {
    pub(super) max: f32,
    pub(super) min: f32,
}

/// Where in one cell interpolated density can be non-zero: the box
/// `[lo, hi]` per axis, in eighths of the cell's edge (0..=8); `FULL` when
/// the whole cell may hold density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SupportBox {
    lo: [u8; 3],
    hi: [u8; 3],
}

impl SupportBox {
    pub(super) const FULL: Self = Self {
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

/// How one cell is split (`Adaptive`, refine.rs): `level` 0 (not split) to
/// 3 (8^3 sub-cells), its `2^(3 level)` sub-cell ranges at `offset` in the
/// grid's `sub_cells`, x slowest, z fastest.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Refinement {
    pub(super) offset: u32,
    pub(super) level: u8,
}

impl Refinement {
    /// Sub-cells along each axis.
    #[inline]
    pub(super) fn res(self) -> i32 {
        1 << self.level
    }
}

/// Conservative density bounds over a dense array of axis-aligned cells in a
/// grid's index space; see the module doc.
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    /// Index-space min corner of cell (0, 0, 0).
    pub(super) lo: Vec3,
    /// Cell edge lengths, in voxels.
    pub(super) cell_size: Vec3,
    /// Cells along each axis (x slowest, z fastest).
    pub(super) dims: IVec3,
    pub(super) cells: Vec<DensityRange>,
    /// Per cell, beside `cells`: where its density can be non-zero.
    pub(super) supports: Vec<SupportBox>,
    /// Per cell, beside `cells`, how it is split (`Adaptive`); empty when no
    /// cell is.
    pub(super) refinements: Vec<Refinement>,
    /// The ranges of split cells' sub-cells (see [`Refinement`]).
    pub(super) sub_cells: Vec<DensityRange>,
}

impl MajorantGrid {
    /// The slot of the cell at coordinates `c` (inside the grid).
    #[inline]
    pub(crate) fn cell_slot(&self, c: IVec3) -> usize {
        ((c.x * self.dims.y + c.y) * self.dims.z + c.z) as usize
    }

    /// The index-space box the cells cover (every point where density can be
    /// non-zero lies inside it), as (min corner, max corner).
    pub fn index_box(&self) -> (Vec3, Vec3) {
        (self.lo, self.lo + self.cell_size * self.dims.as_vec3())
    }

    /// Every cell whose density can be non-zero, in slot order: its slot,
    /// the index-space box of its support (where interpolated density can be
    /// non-zero) and its density max. Emission light sampling picks among
    /// these (`emission/emitter.rs`).
    pub(crate) fn occupied_cells(&self) -> impl Iterator<Item = OccupiedCell> + '_ {
        (0..self.cells.len()).filter_map(move |slot| {
            let range = self.cells[slot];
            if range.max <= 0.0 {
                return None;
            }
            let cell = self.cell_of(slot);
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

    /// The coordinates of the cell in `slot`.
    #[inline]
    pub(super) fn cell_of(&self, slot: usize) -> IVec3 {
        let (n, d) = (slot as i32, self.dims);
        IVec3::new(n / (d.y * d.z), n / d.z % d.y, n % d.z)
    }

    /// How the cell in `slot` is split (level 0: not at all).
    #[inline]
    pub(super) fn refinement(&self, slot: usize) -> Refinement {
        self.refinements.get(slot).copied().unwrap_or_default()
    }

    /// The density range the DDA carries at index-space point `p` of the
    /// cell `cell` in `slot`: its sub-cell's where it is split.
    #[inline]
    pub(super) fn range_at(&self, cell: IVec3, slot: usize, p: Vec3) -> DensityRange {
        let split = self.refinement(slot);
        if split.level == 0 {
            return self.cells[slot];
        }
        let res = split.res();
        let corner = self.lo + cell.as_vec3() * self.cell_size;
        let sub = ((p - corner) / self.cell_size * res as f32)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, IVec3::splat(res - 1));
        self.sub_cells[split.offset as usize + ((sub.x * res + sub.y) * res + sub.z) as usize]
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
    /// cell's (or sub-cell's) max inside the cell's support box, 0 elsewhere.
    pub(crate) fn max_at(&self, p: Vec3) -> f32 {
        self.occupied_slot_at(p).map_or(0.0, |slot| {
            let slot = slot as usize;
            self.range_at(self.cell_of(slot), slot, p).max
        })
    }

    /// The index-space box `[lo, hi)` of `cell`'s `support`.
    pub(super) fn support_box(&self, cell: IVec3, support: SupportBox) -> (Vec3, Vec3) {
        let corner = self.lo + cell.as_vec3() * self.cell_size;
        let eighth = self.cell_size / 8.0;
        (
            corner + Vec3::from(support.lo.map(f32::from)) * eighth,
            corner + Vec3::from(support.hi.map(f32::from)) * eighth,
        )
    }

    /// Bytes the majorant grid of a density grid whose active voxels span
    /// `dims` will hold, estimated before the grid is read (the memory
    /// preflight): one cell per 8^3 block the span can touch and one block
    /// below it per axis (whose footprint reaches the data), at most
    /// [`MAX_CELLS`].
    pub fn bytes_for(dims: U64Vec3) -> u64 {
        std::mem::size_of::<Self>() as u64 + Self::cells_for(dims) * Self::CELL_BYTES
    }

    /// The most cells the majorant grid of a span of `dims` voxels has (see
    /// [`Self::bytes_for`]).
    pub(crate) fn cells_for(dims: U64Vec3) -> u64 {
        let blocks = blocks_spanned(dims + U64Vec3::splat(1 << BLOCK_LOG2), 1 << BLOCK_LOG2);
        blocks.min(MAX_CELLS)
    }

    /// Bytes per cell: its density range and support box.
    const CELL_BYTES: u64 =
        (std::mem::size_of::<DensityRange>() + std::mem::size_of::<SupportBox>()) as u64;

    /// Bytes held (the struct and its cell array).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + (self.cells.capacity() + self.sub_cells.capacity())
                * std::mem::size_of::<DensityRange>()
            + self.supports.capacity() * std::mem::size_of::<SupportBox>()
            + self.refinements.capacity() * std::mem::size_of::<Refinement>()
    }

    /// Max and min of the trilinearly interpolated density over each cell of
    /// 8^3 voxels (aligned with the VDB leaves), built in parallel (rayon)
    /// from the grid's leaves and tiles; `Global`: one cell over the same
    /// bounds, holding the max and min over all of them; `Adaptive`: split
    /// as if density were sigma_t per voxel (see [`Self::build_for`]).
    pub fn build(grid: &SparseGrid, kind: MajorantKind) -> Self {
        Self::build_for(grid, kind, 1.0)
    }

    /// [`Self::build`] for a medium where one unit of density gives an
    /// optical depth of `depth_per_density_voxel` per voxel (densityScale x
    /// world units per voxel): `Adaptive` splits cells by the optical depth
    /// their density range spans (refine.rs).
    pub fn build_for(grid: &SparseGrid, kind: MajorantKind, depth_per_density_voxel: f32) -> Self {
        let mut cells = Self::build_cells(grid, MAX_CELLS);
        match kind {
            MajorantKind::Grid => cells,
            MajorantKind::Adaptive => {
                cells.refine(grid, depth_per_density_voxel);
                cells
            }
            MajorantKind::Global => cells.merged(),
        }
    }

    /// The per-block cells, coarsened by powers of two until at most `max_cells` remain.
    pub(super) fn build_cells(grid: &SparseGrid, max_cells: u64) -> Self {
        let Some(blocks) = grid.block_bounds() else {
            return Self {
                lo: Vec3::ZERO,
                cell_size: Vec3::splat((1 << BLOCK_LOG2) as f32),
                dims: IVec3::ZERO,
                cells: Vec::new(),
                supports: Vec::new(),
                refinements: Vec::new(),
                sub_cells: Vec::new(),
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
                let mut range = DensityRange::EMPTY;
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
            refinements: Vec::new(),
            sub_cells: Vec::new(),
        }
    }

    /// A copy whose cells `(slot, floor)` hold at least `floor` as their
    /// density max, in every sub-cell where split (the support boxes
    /// unchanged): still a majorant, with more tentative collisions there
    /// (see `EmissionCells::collision_floors`).
    pub(crate) fn with_floors(&self, floors: impl IntoIterator<Item = (u32, f32)>) -> Self {
        let mut raised = self.clone();
        for (slot, floor) in floors {
            let split = raised.refinement(slot as usize);
            let subs = split.offset as usize..split.offset as usize + (split.res().pow(3) as usize);
            let subs = if split.level == 0 { 0..0 } else { subs };
            let cell = &mut raised.cells[slot as usize];
            cell.max = cell.max.max(floor);
            for sub in &mut raised.sub_cells[subs] {
                sub.max = sub.max.max(floor);
            }
        }
        raised
    }

    /// A copy that bounds, at every point q, the density at q - d for any
    /// displacement d in the box `[lo, hi]` of `reach` (index units per
    /// axis): a volume whose lookups move back by such d over the shutter
    /// (`motion/advection.rs`) keeps a conservative majorant. Each cell's max
    /// becomes the max over the cells `ceil(hi / edge)` below and
    /// `ceil(-lo / edge)` above it (a separable max filter), the grid
    /// growing by as many cells on the other side; minorants drop to 0,
    /// support boxes to the whole cell, and `Adaptive` splits are left out
    /// (the sub-cells do not survive the filter).
    pub(crate) fn dilated(&self, (lo, hi): (Vec3, Vec3)) -> Self {
        let cells = |d: Vec3| (d / self.cell_size).ceil().as_ivec3().max(IVec3::ZERO);
        // Cells read from below (motion towards +) and from above (towards -).
        let (below, above) = (cells(hi), cells(-lo));
        let dims = self.dims + below + above;
        let count = if self.cells.is_empty() {
            0
        } else {
            dims.element_product() as usize
        };
        let slot = |c: IVec3| ((c.x * dims.y + c.y) * dims.z + c.z) as usize;
        let mut max = vec![0.0f32; count];
        for (n, range) in self.cells.iter().enumerate() {
            max[slot(self.cell_of(n) + above)] = range.max;
        }
        for axis in 0..3 {
            let read = max.clone();
            for (n, out) in max.iter_mut().enumerate() {
                let n = n as i32;
                let c = IVec3::new(n / (dims.y * dims.z), n / dims.z % dims.y, n % dims.z);
                for k in -below[axis]..=above[axis] {
                    let mut q = c;
                    q[axis] += k;
                    if (0..dims[axis]).contains(&q[axis]) {
                        *out = out.max(read[slot(q)]);
                    }
                }
            }
        }
        Self {
            lo: self.lo - above.as_vec3() * self.cell_size,
            cell_size: self.cell_size,
            dims: if count == 0 { self.dims } else { dims },
            cells: max
                .into_iter()
                .map(|max| DensityRange { max, min: 0.0 })
                .collect(),
            supports: vec![SupportBox::FULL; count],
            refinements: Vec::new(),
            sub_cells: Vec::new(),
        }
    }

    /// One cell over the same bounds, bounding all of them.
    fn merged(self) -> Self {
        let all = self.cells.iter().copied().fold(
            DensityRange {
                max: 0.0,
                min: f32::INFINITY,
            },
            DensityRange::union,
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
            refinements: Vec::new(),
            sub_cells: Vec::new(),
        }
    }
}

impl DensityRange {
    /// The range of no value, to [`Self::include`] values into.
    pub(super) const EMPTY: Self = Self {
        max: f32::NEG_INFINITY,
        min: f32::INFINITY,
    };

    /// The smallest range holding both.
    pub(super) fn union(self, other: Self) -> Self {
        Self {
            max: self.max.max(other.max),
            min: self.min.min(other.min),
        }
    }

    /// Widens the range to hold `v`; NaN and infinities are ignored (media
    /// read them as 0, see `Medium::density`).
    pub(super) fn include(&mut self, v: f32) {
        if v.is_finite() {
            self.max = self.max.max(v);
            self.min = self.min.min(v);
        }
    }

    /// Negative densities count as zero (see the module doc); `min <= max`.
    pub(super) fn clamped(self) -> Self {
        let max = self.max.max(0.0);
        Self {
            max,
            min: self.min.max(0.0).min(max),
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::volumes::grid::{GridTransform, Tile, VdbFile};
    use glam::DAffine3;

    pub(in crate::volumes) const TEAPOT: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/assets/pbrt-v4-volumes/scenes/teapot_cloud/geometry/teapot_cloud.vdb"
    );
    pub(in crate::volumes) const SMOKE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/assets/arnold-usd/test_0030/data/smoke.vdb"
    );

    pub(in crate::volumes) fn density(path: &str) -> SparseGrid {
        VdbFile::open(path)
            .unwrap()
            .read_float_grid("density", 0)
            .unwrap()
    }

    /// Two leaves with random values in [0, 1) and an empty block between
    /// them, an 8^3 tile of 0.75 and a negative leaf: empty cells between
    /// non-empty ones, constant regions and the clamp all show up.
    pub(in crate::volumes) fn synthetic() -> SparseGrid {
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

    /// A dilated majorant bounds density moved by anything within its
    /// reach: at random points, the dilated grid's max is at least the
    /// density at the point shifted by random offsets inside the reach
    /// (13, 0, 5) voxels, for every majorant kind; the undilated grid fails
    /// this (so the check can fail).
    #[test]
    fn dilated_majorants_bound_density_moved_within_their_reach() {
        let grid = synthetic();
        let reach = (Vec3::new(-3.0, 0.0, -5.0), Vec3::new(13.0, 0.0, 0.0));
        let mut rng = Pcg32::new(11, 0);
        for kind in [
            MajorantKind::Grid,
            MajorantKind::Adaptive,
            MajorantKind::Global,
        ] {
            let majorant = MajorantGrid::build(&grid, kind);
            let dilated = majorant.dilated(reach);
            let mut undilated_misses = 0;
            for _ in 0..20_000 {
                let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let p = Vec3::new(-20.0, -4.0, -12.0) + u * Vec3::new(60.0, 40.0, 48.0);
                let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let shift = reach.0 + v * (reach.1 - reach.0);
                let density = grid.trilinear_index(p - shift).max(0.0);
                assert!(
                    dilated.max_at(p) >= density,
                    "{kind:?} at {p} - {shift}: {density}"
                );
                undilated_misses += usize::from(majorant.max_at(p) < density);
            }
            assert!(undilated_misses > 0, "{kind:?}: the test cannot fail");
        }
    }

    /// An analytic ramp: density x / 4 over two leaves (16 x 8 x 8 voxels),
    /// 0 beyond them. Trilinear density is then exactly linear in x inside
    /// the data, and drops to 0 over the last voxel layer.
    pub(in crate::volumes) fn ramp() -> SparseGrid {
        let origins = [IVec3::ZERO, IVec3::new(8, 0, 0)];
        let values = origins
            .iter()
            .flat_map(|o| (0..512).map(move |i| (o.x + i / 64) as f32 / 4.0))
            .collect();
        let identity = GridTransform::new(DAffine3::IDENTITY).unwrap();
        SparseGrid::build(0.0, &origins, values, &[], identity).unwrap()
    }

    /// The shared VDBs at their benchmark scenes' optical scale (densityScale
    /// x world units per voxel: smoke 20 x 0.0095, teapot 0.5 x 0.0077, here
    /// 10x denser so it splits into 4^3 sub-cells) and the ramp at 1.
    pub(in crate::volumes) fn split_grids() -> Vec<(&'static str, SparseGrid, MajorantGrid)> {
        [
            ("ramp", ramp(), 1.0),
            ("smoke", density(SMOKE), 0.19),
            ("teapot", density(TEAPOT), 0.038),
        ]
        .into_iter()
        .map(|(name, grid, depth)| {
            let mg = MajorantGrid::build_for(&grid, MajorantKind::Adaptive, depth);
            (name, grid, mg)
        })
        .collect()
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
    pub(in crate::volumes) fn assert_exact_ranges(grid: &SparseGrid, mg: &MajorantGrid) -> usize {
        let edge = mg.cell_size.x as i32;
        let mut non_empty = 0;
        for c in cell_coords(mg) {
            let expected = footprint_range(grid, mg.lo.as_ivec3() + c * edge, edge);
            assert_eq!(mg.cells[mg.cell_slot(c)], expected, "cell {c}");
            non_empty += usize::from(expected.max > 0.0);
        }
        non_empty
    }

    /// The clamped range of the voxels `first ..= first + edge` on each
    /// axis (the trilinear footprint of a box `edge` voxels wide), read one
    /// by one.
    pub(in crate::volumes) fn footprint_range(
        grid: &SparseGrid,
        first: IVec3,
        edge: i32,
    ) -> DensityRange {
        let mut range = DensityRange::EMPTY;
        for x in 0..=edge {
            for y in 0..=edge {
                for z in 0..=edge {
                    range.include(grid.value(first + IVec3::new(x, y, z)));
                }
            }
        }
        range.clamped()
    }

    /// Asserts trilinear density (clamped to >= 0) stays within `range` at
    /// the 8 corners of the box at `corner`, `size` voxels wide, and at
    /// `inside` random points in it; returns the number of probes.
    pub(in crate::volumes) fn assert_probes_within(
        grid: &SparseGrid,
        (corner, size): (Vec3, Vec3),
        range: DensityRange,
        inside: usize,
        rng: &mut Pcg32,
    ) -> usize {
        let corners =
            (0..8).map(|n| Vec3::new((n >> 2) as f32, ((n >> 1) & 1) as f32, (n & 1) as f32));
        let inside: Vec<Vec3> = (0..inside)
            .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
            .collect();
        let mut probes = 0;
        for u in corners.chain(inside) {
            let p = corner + u * size;
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
        probes
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
                probes += assert_probes_within(&grid, (corner, mg.cell_size), range, 64, &mut rng);
            }
            assert_eq!(probes, 72 * mg.cells.len());
        }
    }
}
