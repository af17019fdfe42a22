//! Adaptive majorants (`--majorant adaptive`): a [`MajorantGrid`] cell of
//! 8^3 voxels over which density varies much is split into 2^3, 4^3 or 8^3
//! sub-cells (edges of 4, 2 or 1 voxels), each holding the max and min of
//! its own trilinear footprint, so delta tracking there samples against a
//! tighter bound. A two-level grid: the DDA (dda.rs) walks the 8^3 cells as
//! before, clipped to their support boxes, and inside a split cell walks its
//! sub-cells with a second DDA over the same stretch.
//!
//! Criterion (Pixar's "Elemental" production talk, which Cycles 5's volume
//! octree follows): a cell is split while some sub-cell has
//! (sigma_max - sigma_min) x its diagonal > [`SPLIT_DEPTH`], that is while the
//! majorant could overshoot the density by more than about 1.44 tentative
//! collisions across it; a thin cell gains nothing worth a DDA step from a
//! split. Unlike an octree, every sub-cell of a cell shares one level (the
//! deepest any of its parts needs): one array per cell, one DDA.
//!
//! A sub-cell's footprint is the union of its eight children's, so the
//! levels are built bottom-up from the one-voxel cells' ranges (the 2^3
//! voxels at their corners), each as exact as the 8^3 cells' are.

use glam::IVec3;
use rayon::prelude::*;

use super::cells::{DensityRange, MajorantGrid, Refinement, BLOCK_LOG2};
use crate::volumes::grid::SparseGrid;

/// Split threshold on (sigma_max - sigma_min) x cell diagonal: an optical
/// depth (unitless). 1.44 is the "Elemental" value Cycles 5 uses; see
/// docs/volumes.md for the sweep behind keeping it.
pub(super) const SPLIT_DEPTH: f32 = 1.44;

/// Deepest level: 8^3 sub-cells of one voxel.
const MAX_LEVEL: u8 = 3;

/// Sub-cells kept, per cell that holds density: where more cells want
/// splitting, the deepest level allowed is lowered until they fit. 128 (1
/// KiB) per occupied cell is about a third of what its 8^3 voxels take in
/// the [`SparseGrid`] (a 10^3 apron brick of f32).
const SUB_CELLS_PER_CELL: usize = 128;

/// Sub-cells any grid may keep (512 KiB), whatever its size.
const MIN_SUB_CELLS: usize = 1 << 16;

/// The ranges of one 8^3 cell's sub-cells at every level, finest last.
struct Pyramid {
    levels: [Vec<DensityRange>; MAX_LEVEL as usize + 1],
}

impl Pyramid {
    /// The ranges over the trilinear footprints of `block`'s sub-cells.
    fn of(grid: &SparseGrid, block: IVec3) -> Self {
        const F: usize = (1 << BLOCK_LOG2) + 1;
        let mut values = [0.0f32; F * F * F];
        grid.for_each_footprint_value(block, |lo, hi, v| {
            for x in lo.x..=hi.x {
                for y in lo.y..=hi.y {
                    for z in lo.z..=hi.z {
                        values[((x as usize) * F + y as usize) * F + z as usize] = v;
                    }
                }
            }
        });
        let mut finest = Vec::with_capacity(512);
        for x in 0..F - 1 {
            for y in 0..F - 1 {
                for z in 0..F - 1 {
                    let mut range = DensityRange::EMPTY;
                    for n in 0..8 {
                        let (dx, dy, dz) = (n >> 2, (n >> 1) & 1, n & 1);
                        range.include(values[((x + dx) * F + y + dy) * F + z + dz]);
                    }
                    finest.push(range.clamped());
                }
            }
        }
        let mut levels: [Vec<DensityRange>; 4] = Default::default();
        levels[MAX_LEVEL as usize] = finest;
        for level in (0..MAX_LEVEL as usize).rev() {
            let (res, fine) = (1usize << level, &levels[level + 1]);
            let mut coarse = Vec::with_capacity(res * res * res);
            for x in 0..res {
                for y in 0..res {
                    for z in 0..res {
                        let child = |n: usize| {
                            let (cx, cy, cz) =
                                (2 * x + (n >> 2), 2 * y + ((n >> 1) & 1), 2 * z + (n & 1));
                            fine[(cx * 2 * res + cy) * 2 * res + cz]
                        };
                        coarse.push(
                            (0..8)
                                .map(child)
                                .fold(DensityRange::EMPTY, DensityRange::union),
                        );
                    }
                }
            }
            levels[level] = coarse;
        }
        Self { levels }
    }

    /// The shallowest level at which no sub-cell needs splitting.
    fn level(&self, depth_per_density_voxel: f32) -> u8 {
        (0..MAX_LEVEL)
            .find(|&level| {
                let edge = (1 << (BLOCK_LOG2 as u8 - level)) as f32;
                self.levels[level as usize]
                    .iter()
                    .all(|r| !needs_split(*r, edge, depth_per_density_voxel))
            })
            .unwrap_or(MAX_LEVEL)
    }
}

/// The criterion: (max - min) x sigma_t per density x diagonal of a cell
/// `edge` voxels wide > [`SPLIT_DEPTH`].
fn needs_split(range: DensityRange, edge: f32, depth_per_density_voxel: f32) -> bool {
    let diagonal = edge * 3f32.sqrt();
    (range.max - range.min) * depth_per_density_voxel * diagonal > SPLIT_DEPTH
}

impl MajorantGrid {
    /// Splits the cells over which density varies by the "Elemental"
    /// criterion (see the module doc). `depth_per_density_voxel` is the
    /// optical depth one unit of density gives over one voxel (densityScale
    /// x world units per voxel; 1 when density is sigma_t per voxel). Grids
    /// coarsened past 8^3 voxels per cell (huge ones) are left unsplit.
    pub(super) fn refine(&mut self, grid: &SparseGrid, depth_per_density_voxel: f32) {
        let edge = 1 << BLOCK_LOG2;
        if self.cell_size.x != edge as f32
            || depth_per_density_voxel.is_nan()
            || depth_per_density_voxel <= 0.0
        {
            return;
        }
        let first_block = self.lo.as_ivec3() >> BLOCK_LOG2;
        let dims = self.dims;
        let block = move |slot: usize| {
            let n = slot as i32;
            first_block + IVec3::new(n / (dims.y * dims.z), n / dims.z % dims.y, n % dims.z)
        };
        let levels: Vec<u8> = (0..self.cells.len())
            .into_par_iter()
            .map(|slot| {
                let range = self.cells[slot];
                if range.max <= 0.0 || !needs_split(range, edge as f32, depth_per_density_voxel) {
                    return 0;
                }
                Pyramid::of(grid, block(slot)).level(depth_per_density_voxel)
            })
            .collect();
        let occupied = self.cells.iter().filter(|r| r.max > 0.0).count();
        let budget = (SUB_CELLS_PER_CELL * occupied).max(MIN_SUB_CELLS);
        let used = |cap: u8| -> usize {
            levels
                .iter()
                .map(|&l| usize::from(l.min(cap) > 0) << (3 * l.min(cap)))
                .sum()
        };
        let cap = (0..=MAX_LEVEL)
            .rev()
            .find(|&cap| used(cap) <= budget)
            .unwrap_or(0);
        if cap == 0 || levels.iter().all(|&l| l == 0) {
            return;
        }
        let mut offset = 0u32;
        self.refinements = levels
            .iter()
            .map(|&l| {
                let level = l.min(cap);
                let r = Refinement { offset, level };
                offset += u32::from(level > 0) << (3 * level);
                r
            })
            .collect();
        let split: Vec<Vec<DensityRange>> = (0..self.cells.len())
            .into_par_iter()
            .filter(|&slot| self.refinements[slot].level > 0)
            .map(|slot| {
                let level = self.refinements[slot].level as usize;
                std::mem::take(&mut Pyramid::of(grid, block(slot)).levels[level])
            })
            .collect();
        self.sub_cells = split.concat();
        let count = |level: u8| self.refinements.iter().filter(|r| r.level == level).count();
        log::info!(
            "adaptive majorants: of {} cells, {} / {} / {} split into 2^3 / 4^3 / 8^3 \
             sub-cells ({} KiB)",
            self.cells.len(),
            count(1),
            count(2),
            count(3),
            self.sub_cells.len() * std::mem::size_of::<DensityRange>() / 1024
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::volumes::grid::GridTransform;
    use crate::volumes::majorant::cells::tests::{
        assert_probes_within, density, footprint_range, ramp, split_grids, SMOKE,
    };
    use crate::volumes::majorant::MajorantKind;
    use glam::{DAffine3, Vec3};

    /// Every sub-cell of every split cell holds the exact clamped range of
    /// the voxels its trilinear footprint reads (read one by one), and
    /// trilinear density at its 8 corners and 8 random points inside stays
    /// within it. Cells split at levels 2 and 3 (teapot: 1 and 2).
    #[test]
    fn split_cells_bound_every_trilinear_value_inside_them() {
        let mut rng = Pcg32::new(17, 0);
        for (name, grid, mg) in split_grids() {
            let mut per_level = [0usize; 4];
            for slot in 0..mg.cells.len() {
                let split = mg.refinement(slot);
                per_level[split.level as usize] += 1;
                if split.level == 0 {
                    continue;
                }
                let (res, cell) = (split.res(), mg.cell_of(slot));
                let edge = 8 / res;
                let first = mg.lo.as_ivec3() + cell * 8;
                for n in 0..res * res * res {
                    let sub = IVec3::new(n / (res * res), n / res % res, n % res);
                    let range = mg.sub_cells[split.offset as usize + n as usize];
                    let first = first + sub * edge;
                    let expected = footprint_range(&grid, first, edge);
                    assert_eq!(range, expected, "{name} cell {cell} sub {sub}");
                    let size = Vec3::splat(edge as f32);
                    assert_probes_within(&grid, (first.as_vec3(), size), range, 8, &mut rng);
                }
            }
            println!(
                "{name}: cells per level {per_level:?}, {} sub-cells",
                mg.sub_cells.len()
            );
            assert!(per_level[2] > 0 || name == "ramp", "{name}: {per_level:?}");
            assert!(
                per_level[3] > 0 || name == "teapot",
                "{name}: {per_level:?}"
            );
        }
    }

    /// The ramp's majorants are as tight as cells can be: every one-voxel
    /// sub-cell inside the data bounds x / 4 by its value at the far face,
    /// 1/4 above the near one, where the 8^3 cell's was 2 above.
    #[test]
    fn ramp_sub_cells_are_one_voxel_tight() {
        let grid = ramp();
        let mg = MajorantGrid::build_for(&grid, MajorantKind::Adaptive, 1.0);
        let slot = mg.cell_slot(-(mg.lo / 8.0).as_ivec3());
        let split = mg.refinement(slot);
        assert_eq!(split.level, 3);
        for x in 0..8 {
            let range = mg.sub_cells[split.offset as usize + (x * 64) as usize];
            assert_eq!(
                (range.min, range.max),
                (x as f32 / 4.0, (x + 1) as f32 / 4.0)
            );
        }
        assert_eq!(mg.cells[slot].max - mg.cells[slot].min, 2.0);
    }

    /// Delta tracking (track-length), ratio and residual ratio tracking
    /// over the split ramp read its analytic transmittance: along x through
    /// the data at y = z = 3.5, density x / 4 up to x = 15 and down to 0 by
    /// x = 16, so the optical depth at densityScale 0.05 is
    /// 0.05 x (225 / 8 + 15 / 8) = 1.5; within 4 sigma of exp(-1.5), with no density above
    /// its (sub-cell) majorant. The control: sub-cell majorants lowered to
    /// their minima (the near face's value) bias track-length visibly.
    #[test]
    fn tracking_over_split_cells_reads_the_ramps_transmittance() {
        use crate::volumes::estimators::{transmittance, TrackingStats, TransmittanceEstimator};
        let grid = ramp();
        let mg = MajorantGrid::build_for(&grid, MajorantKind::Adaptive, 1.0);
        assert!(mg.refinements.iter().any(|r| r.level == 3));
        let (origin, direction, scale) = (Vec3::new(-3.0, 3.5, 3.5), Vec3::X, 0.05);
        let truth = (-1.5f64).exp();
        // Mean, its standard error and the violations over 20,000 estimates.
        let run = |mg: &MajorantGrid, estimator: TransmittanceEstimator| {
            let mut rng = Pcg32::new(5, estimator as u64);
            let mut stats = TrackingStats::default();
            let n = 20_000;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let segments = mg.segments(origin, direction, 0.0, 30.0, Vec3::splat(scale));
                let sigma_t = |t: f32| {
                    Vec3::splat(scale * grid.trilinear_index(origin + direction * t).max(0.0))
                };
                let x = transmittance(estimator, segments, sigma_t, &mut rng, &mut stats).x;
                sum += f64::from(x);
                sum2 += f64::from(x) * f64::from(x);
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            (mean, sigma, stats.majorant_violations)
        };
        for estimator in [
            TransmittanceEstimator::TrackLength,
            TransmittanceEstimator::Ratio,
            TransmittanceEstimator::ResidualRatio,
        ] {
            let (mean, sigma, violations) = run(&mg, estimator);
            println!("{estimator:?}: {mean:.5} +- {sigma:.1e} (truth {truth:.5})");
            assert!(
                (mean - truth).abs() < 4.0 * sigma + 1e-6,
                "{estimator:?}: {mean} +- {sigma} vs {truth}"
            );
            assert_eq!(violations, 0, "{estimator:?}");
        }
        let mut low = mg.clone();
        for range in &mut low.sub_cells {
            range.max = range.min;
        }
        let (mean, sigma, violations) = run(&low, TransmittanceEstimator::TrackLength);
        println!("sub-cells at their min: {mean:.5} +- {sigma:.1e}, {violations} violations");
        assert!(
            violations > 0 && mean - truth > 4.0 * sigma,
            "{mean} +- {sigma}"
        );
    }

    /// NaN, infinite and negative voxels in a split cell are read as 0, as
    /// the 8^3 cells read them: every sub-cell range stays finite and >= 0,
    /// and the cell holding them still splits to one-voxel sub-cells, the
    /// one around the NaN bounding its finite neighbours.
    #[test]
    fn non_finite_voxels_never_reach_a_sub_cell() {
        let origins = [IVec3::ZERO, IVec3::new(8, 0, 0)];
        let mut values: Vec<f32> = origins
            .iter()
            .flat_map(|o| (0..512).map(move |i| (o.x + i / 64) as f32 / 4.0))
            .collect();
        let at = |x: usize, y: usize, z: usize| (x * 8 + y) * 8 + z;
        values[at(3, 3, 3)] = f32::NAN;
        values[at(5, 5, 5)] = f32::INFINITY;
        values[at(6, 2, 2)] = -5.0;
        let identity = GridTransform::new(DAffine3::IDENTITY).unwrap();
        let grid = SparseGrid::build(0.0, &origins, values, &[], identity).unwrap();
        let mg = MajorantGrid::build_for(&grid, MajorantKind::Adaptive, 1.0);
        assert!(mg
            .sub_cells
            .iter()
            .all(|r| r.min.is_finite() && r.max.is_finite() && r.min >= 0.0));
        let slot = mg.cell_slot(-(mg.lo / 8.0).as_ivec3());
        let split = mg.refinement(slot);
        assert_eq!(split.level, 3);
        // The one-voxel sub-cell at (3, 3, 3) reads x = 3 (NaN, ignored) and 4.
        let range = mg.sub_cells[split.offset as usize + at(3, 3, 3)];
        assert_eq!((range.min, range.max), (0.75, 1.0));
    }

    /// Thin media are not split (nothing to gain), the grid and global
    /// kinds never are, and when more cells want splitting than the budget
    /// allows, the deepest level is lowered until they fit.
    #[test]
    fn thin_grids_stay_whole_and_the_budget_caps_the_level() {
        let grid = density(SMOKE);
        let thin = MajorantGrid::build_for(&grid, MajorantKind::Adaptive, 1e-4);
        assert!(thin.refinements.is_empty() && thin.sub_cells.is_empty());
        for kind in [MajorantKind::Grid, MajorantKind::Global] {
            assert!(MajorantGrid::build_for(&grid, kind, 1e3)
                .sub_cells
                .is_empty());
        }
        let dense = MajorantGrid::build_for(&grid, MajorantKind::Adaptive, 1e3);
        let occupied = dense.cells.iter().filter(|r| r.max > 0.0).count();
        assert!(dense.sub_cells.len() <= SUB_CELLS_PER_CELL * occupied);
        assert!(SUB_CELLS_PER_CELL * occupied > MIN_SUB_CELLS);
        let deepest = dense.refinements.iter().map(|r| r.level).max();
        assert_eq!(
            deepest,
            Some(2),
            "every non-constant cell wants 8^3 sub-cells"
        );
    }
}
