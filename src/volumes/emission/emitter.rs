//! Where an emitting volume emits, for sampling it as a light (Villemin &
//! Hery 2013, "Practical Illumination from Flames", JCGT 2(2)): the
//! majorant grid's occupied cells, each weighed by an estimate of the power
//! it emits, the integral of sigma_a Le over its support box, and sampled
//! in proportion: a cell by weight, then, when the emission grids share the
//! density grid's voxels, one of its unit cubes (between neighbouring index
//! points) by the mean source at the cube's eight corners, then a point
//! uniformly in the cube; otherwise a point uniformly in the cell's support
//! box. Blackbody emission grows with the fourth-to-tenth power of
//! temperature, so one 8^3 cell can hold a 1000x range of emission: sampled
//! uniformly in the cell, a fire's hot core came out as fireflies on what it
//! lit. Everything here is in the density grid's index space; the medium
//! places it in the world.
//!
//! Far from the volume, the power the light selection weighs it by is what
//! escapes it (near it, what the near picks estimate it delivers there):
//! each cell's emission times its mean transmittance to the grid's edge
//! along the six axes, marched through the cells' mean extinctions. Fire
//! wrapped in dense smoke mostly lights the smoke; weighed by its emitted
//! power it would take the samples of the sun and the sky and waste them on
//! blocked shadow rays (measured: 12x the noise under the sun beside a shell
//! of optical depth 87, tests/it/stability.rs). Far from the volume, cells are
//! picked by emitted power (weighing them by their escape as well measured
//! 2.4x more variance on the boulder the canyon's fire lights); near it, by
//! what they deliver to the shading point's region, the transmittance from
//! there included (`near_picks.rs`).
//!
//! Unbiased whatever the estimate: a cell's weight never falls below
//! [`FLOOR`] times a bound on its emission, so every cell that may emit
//! keeps a non-zero probability. The bound is exact when the emission grids
//! share the density grid's voxels (the usual case: one VDB's `density` and
//! `temperature`): a cell whose footprint voxels all emit nothing emits
//! nothing anywhere, and gets weight 0. Otherwise every occupied cell may
//! emit (the bound uses the largest emission seen anywhere).

use glam::{Affine3A, IVec3, Vec3};
use rayon::prelude::*;

use super::near_picks::{NearImportance, NearPicks, WeighedCell};
use crate::sampling::AliasTable;
use crate::volumes::majorant::{MajorantGrid, OccupiedCell};

/// The smallest share of its emission bound a cell's weight is given.
const FLOOR: f32 = 1e-3;

/// Tentative collisions a ray crossing the brightest emitting cell meets
/// at least (fewer in dimmer cells, in proportion to their emission): see
/// [`EmissionCells::collision_floors`].
const COLLISIONS_IN_BRIGHTEST_CELL: f32 = 4.0;

/// The medium at an index-space point, as luminance.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SourceSample {
    /// Extinction sigma_t (channel mean), per world unit.
    pub sigma_t: f32,
    /// Luminance of the source term sigma_a Le, W/(m^3 sr) in scene units.
    pub source: f32,
    /// Luminance of the emitted radiance Le alone, W/(m^2 sr).
    pub radiance: f32,
}

/// The cells of one medium that may emit, with the distribution that picks
/// them by power.
#[derive(Debug)]
pub(crate) struct EmissionCells {
    /// In slot order (the majorant grid's), for lookups by binary search.
    cells: Vec<EmittingCell>,
    /// Over `cells`, by estimated power.
    distribution: AliasTable,
    /// Estimated luminance of the power that escapes the volume, over 4 pi,
    /// per unit of index-space volume (a world volume is |det| times it).
    escaping: f32,
    /// Per emitting cell (slot), the least majorant tracking needs there,
    /// per world unit (see [`Self::collision_floors`]).
    floors: Vec<(u32, f32)>,
    /// Picks for shading points near the emission.
    near: NearPicks,
}

/// One cell that may emit: its majorant-grid slot, its support box and,
/// for aligned grids, the distribution over the box's unit cubes.
#[derive(Clone, Debug)]
struct EmittingCell {
    slot: u32,
    /// Index-space min corner of the support box (integer for aligned grids).
    lo: Vec3,
    /// Its edge lengths.
    extent: Vec3,
    /// Over the unit cubes of the box (x slowest, z fastest), by their
    /// corners' mean source; `None`: uniform over the box.
    cubes: Option<AliasTable>,
}

impl EmittingCell {
    /// A point of the cell from `u` in [0, 1)^3 and its density relative
    /// to the cell's pick.
    fn sample(&self, u: Vec3) -> (Vec3, f32) {
        let Some(cubes) = &self.cubes else {
            return (
                self.lo + self.extent * u,
                1.0 / self.extent.element_product(),
            );
        };
        let pick = cubes.sample_discrete(u.x);
        let d = self.extent.as_ivec3();
        let k = pick.index as i32;
        let cube = IVec3::new(k / (d.y * d.z), k / d.z % d.y, k % d.z);
        let p = self.lo + cube.as_vec3() + Vec3::new(pick.remapped, u.y, u.z);
        (p, pick.probability)
    }

    /// The density relative to the cell's pick with which [`Self::sample`]
    /// returns `p`; 0 outside the box.
    fn pdf(&self, p: Vec3) -> f32 {
        let local = p - self.lo;
        if !(local.cmpge(Vec3::ZERO).all() && local.cmplt(self.extent).all()) {
            return 0.0;
        }
        let Some(cubes) = &self.cubes else {
            return 1.0 / self.extent.element_product();
        };
        let d = self.extent.as_ivec3();
        let cube = local.floor().as_ivec3().min(d - IVec3::ONE);
        cubes.probability(((cube.x * d.y + cube.y) * d.z + cube.z) as usize)
    }
}

impl EmissionCells {
    /// Bytes the emission cells of a volume whose majorant grid has
    /// `cells` cells and whose emission grid has `active_voxels` active
    /// voxels hold at most, estimated before either is read: every cell
    /// emitting, with its entry, pick weight and collision floor, and one
    /// unit cube per active voxel in the cells' own distributions.
    pub(crate) fn bytes_for(cells: u64, active_voxels: u64) -> u64 {
        let per_cell = std::mem::size_of::<EmittingCell>() + std::mem::size_of::<(u32, f32)>();
        cells * per_cell as u64
            + AliasTable::bytes_for(cells)
            + NearPicks::bytes_for(cells)
            + AliasTable::bytes_for(active_voxels)
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        let cubes: usize = self
            .cells
            .iter()
            .filter_map(|c| c.cubes.as_ref().map(AliasTable::memory_bytes))
            .sum();
        self.cells.capacity() * std::mem::size_of::<EmittingCell>()
            + self.floors.capacity() * std::mem::size_of::<(u32, f32)>()
            + self.distribution.memory_bytes()
            + self.near.memory_bytes()
            + cubes
    }

    /// An index-space point by what it delivers to the index-space
    /// shading point `from` (by power away from the emission) from `u` in
    /// [0, 1)^3, and its index-space volume density.
    pub(crate) fn sample(&self, from: Vec3, u: Vec3) -> (Vec3, f32) {
        let (cell, probability, remapped) = match self.near.sample(from, u.x) {
            Some(pick) => (pick.cell, pick.probability, pick.remapped),
            None => {
                let pick = self.distribution.sample_discrete(u.x);
                (pick.index, pick.probability, pick.remapped)
            }
        };
        let (p, pdf) = self.cells[cell].sample(Vec3::new(remapped, u.y, u.z));
        (p, probability * pdf)
    }

    /// The index-space volume density with which [`Self::sample`] returns
    /// `p` for `from`; 0 where it never does (outside every emitting
    /// support box).
    pub(crate) fn pdf(&self, majorant: &MajorantGrid, from: Vec3, p: Vec3) -> f32 {
        let Some(slot) = majorant.occupied_slot_at(p) else {
            return 0.0;
        };
        let Ok(i) = self.cells.binary_search_by_key(&slot, |c| c.slot) else {
            return 0.0;
        };
        let probability = self
            .near
            .probability(from, i)
            .unwrap_or_else(|| self.distribution.probability(i));
        probability * self.cells[i].pdf(p)
    }

    /// The index-space box around every emitting cell's support, as (min
    /// corner, max corner).
    pub(crate) fn index_box(&self) -> (Vec3, Vec3) {
        cells_box(&self.cells)
    }

    /// Per emitting cell (majorant-grid slot), the least majorant sigma_maj
    /// (per world unit) free-flight tracking must use there for emission
    /// found along camera rays not to sparkle: emission is collected at
    /// tentative collisions, so a thin, hot region crossed with few of them
    /// gives a few bright samples among many dark ones (relative variance
    /// 1 / the number of collisions). The brightest cell (mean sigma_a Le)
    /// gets [`COLLISIONS_IN_BRIGHTEST_CELL`] collisions per edge crossed,
    /// dimmer cells fewer in proportion to their emission; where density is
    /// dense enough already nothing changes. Cycles 5 raises its majorants
    /// with emission for the same reason. A majorant above sigma_t is still
    /// a majorant: tracking stays unbiased, and pays in null collisions.
    pub(crate) fn collision_floors(&self) -> &[(u32, f32)] {
        &self.floors
    }

    /// What the emission delivers around it by region, for the light
    /// selection of a placement of the grid by `index_from_world` whose
    /// index-space unit cube has world volume `voxel_volume`. The cells
    /// (shared by every placement of a Volume prim) weigh distances in
    /// index units; each placement converts them by its voxel's mean edge,
    /// the cube root of its volume (exact for voxels of equal sides).
    pub(crate) fn near_importance(
        &self,
        index_from_world: Affine3A,
        voxel_volume: f32,
    ) -> NearImportance {
        // A cell's weight is its integral of sigma_a Le over index space:
        // x the voxel volume, W/sr; x 4 pi, W; over (edge x index distance)^2.
        let edge_squared = voxel_volume.cbrt().powi(2);
        let scale = 4.0 * std::f32::consts::PI * voxel_volume / edge_squared;
        self.near.importance(index_from_world, scale)
    }

    /// Estimated luminance of the integral of sigma_a Le times its escape
    /// transmittance, per unit of index-space volume: W/sr after scaling by
    /// the index-to-world volume (see the module doc).
    pub(crate) fn escaping(&self) -> f32 {
        self.escaping
    }

    /// Weighs every occupied cell of `majorant` by `source` evaluated at the
    /// integer index points its trilinear lookups read; `absorption` is the
    /// luminance of sigma_a per unit density, `axis_length` the world length
    /// of one index unit along each index axis (for the collision floors),
    /// and `aligned` says that the
    /// emission grids' index points are the density grid's (then a cell
    /// whose points emit nothing gets weight 0). `None` when nothing emits.
    pub(crate) fn build(
        majorant: &MajorantGrid,
        (absorption, axis_length): (f32, Vec3),
        aligned: bool,
        source: impl Fn(Vec3) -> SourceSample + Sync,
    ) -> Option<Self> {
        let occupied: Vec<OccupiedCell> = majorant.occupied_cells().collect();
        let sampled: Vec<CellSample> = occupied
            .par_iter()
            .map(|cell| CellSample::of(cell, &source))
            .collect();
        let extinction = Extinction::of(majorant, &occupied, &sampled, axis_length);
        let escape = extinction.escape_transmittances(&occupied);
        let global_max = sampled
            .iter()
            .map(|s| s.radiance_max)
            .fold(0.0f32, f32::max);
        if global_max <= 0.0 || absorption <= 0.0 {
            return None;
        }
        let brightest = sampled.iter().map(|s| s.source_mean).fold(0.0f32, f32::max);
        let mut cells = Vec::new();
        let mut weighed = Vec::new();
        let mut floors = Vec::new();
        let mut escaping = 0.0f64;
        for ((cell, sample), escape) in occupied.iter().zip(&sampled).zip(escape) {
            let bound = if aligned {
                sample.radiance_max
            } else {
                global_max
            };
            let floor = FLOOR * cell.density_max * absorption * bound;
            let extent = cell.hi - cell.lo;
            let volume = extent.element_product();
            // Aligned: the cubes' weights, summing to the cell's integral.
            let cubes = sample.cubes.as_ref().filter(|_| aligned);
            let weight = match cubes {
                Some(cubes) => cubes.iter().sum(),
                None => volume * sample.source_mean.max(floor),
            };
            if floor <= 0.0 || volume <= 0.0 || weight <= 0.0 {
                continue;
            }
            cells.push(EmittingCell {
                slot: cell.slot,
                lo: cell.lo,
                extent,
                cubes: cubes.map(|c| AliasTable::new(c)),
            });
            weighed.push(WeighedCell {
                cell: cell.cell,
                centre: cell.lo + 0.5 * extent,
                radius: 0.5 * extent.length(),
                weight,
            });
            escaping += f64::from(volume * sample.source_mean * escape);
            if sample.source_mean > 0.0 {
                let edge_world = (extent * axis_length).element_sum() / 3.0;
                let share = sample.source_mean / brightest;
                floors.push((cell.slot, COLLISIONS_IN_BRIGHTEST_CELL * share / edge_world));
            }
        }
        if cells.is_empty() {
            return None;
        }
        let weights: Vec<f32> = weighed.iter().map(|c| c.weight).collect();
        let near = NearPicks::build(&weighed, cells_box(&cells), |a, b| {
            extinction.optical_depth(a, b)
        });
        Some(Self {
            distribution: AliasTable::new(&weights),
            near,
            cells,
            escaping: escaping as f32,
            floors,
        })
    }
}

/// What the points of one occupied cell hold.
#[derive(Clone, Debug)]
struct CellSample {
    /// Mean source luminance over the points.
    source_mean: f32,
    /// Mean extinction over the points, per world unit.
    sigma_t_mean: f32,
    /// Largest emitted radiance luminance at a point.
    radiance_max: f32,
    /// Per unit cube of the support box (x slowest, z fastest): the mean
    /// source at its eight corners, or a floor of [`FLOOR`] x the largest
    /// corner extinction x the largest corner radiance when that is larger;
    /// 0 only where no corner has density or no corner emits (with aligned
    /// grids, trilinear lookups in the cube read only its corners, so it
    /// emits nothing). `None` for a box that is not whole voxels.
    cubes: Option<Vec<f32>>,
}

impl CellSample {
    /// `source` at the integer index points a trilinear lookup inside
    /// `cell`'s support box reads.
    fn of(cell: &OccupiedCell, source: &impl Fn(Vec3) -> SourceSample) -> Self {
        let (first, last) = (cell.lo.floor().as_ivec3(), cell.hi.ceil().as_ivec3());
        let points = last - first + IVec3::ONE;
        let mut lattice = Vec::with_capacity(points.element_product() as usize);
        for x in first.x..=last.x {
            for y in first.y..=last.y {
                for z in first.z..=last.z {
                    lattice.push(source(IVec3::new(x, y, z).as_vec3()));
                }
            }
        }
        let n = lattice.len().max(1) as f64;
        let whole = cell.lo == first.as_vec3() && cell.hi == last.as_vec3();
        Self {
            source_mean: (lattice.iter().map(|s| f64::from(s.source)).sum::<f64>() / n) as f32,
            sigma_t_mean: (lattice.iter().map(|s| f64::from(s.sigma_t)).sum::<f64>() / n) as f32,
            radiance_max: lattice.iter().map(|s| s.radiance).fold(0.0, f32::max),
            cubes: whole.then(|| cube_weights(&lattice, points)),
        }
    }
}

/// The weight of every unit cube of a lattice of `points` samples (see
/// [`CellSample::cubes`]).
fn cube_weights(lattice: &[SourceSample], points: IVec3) -> Vec<f32> {
    let at = |p: IVec3| &lattice[((p.x * points.y + p.y) * points.z + p.z) as usize];
    let cubes = points - IVec3::ONE;
    let mut weights = Vec::with_capacity(cubes.element_product().max(0) as usize);
    for x in 0..cubes.x {
        for y in 0..cubes.y {
            for z in 0..cubes.z {
                let corners =
                    (0..8).map(|c| at(IVec3::new(x + (c >> 2), y + ((c >> 1) & 1), z + (c & 1))));
                let (mut sum, mut sigma_t, mut radiance) = (0.0f32, 0.0f32, 0.0f32);
                for s in corners {
                    sum += s.source;
                    sigma_t = sigma_t.max(s.sigma_t);
                    radiance = radiance.max(s.radiance);
                }
                weights.push((sum / 8.0).max(FLOOR * sigma_t * radiance));
            }
        }
    }
    weights
}

/// The index-space box around `cells`' support boxes, as (min corner, max
/// corner).
fn cells_box(cells: &[EmittingCell]) -> (Vec3, Vec3) {
    cells.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), c| (lo.min(c.lo), hi.max(c.lo + c.extent)),
    )
}

/// Every majorant cell's mean extinction, for estimates of transmittance
/// between cells: the escape towards the grid's edge that the light
/// selection weighs the volume by, and what the near picks
/// (`near_picks.rs`) weigh each cluster by.
struct Extinction<'a> {
    majorant: &'a MajorantGrid,
    /// Per slot, the mean extinction of the cell's points, per world unit.
    sigma_t: Vec<f32>,
    /// World length of one index unit along each index axis.
    axis_length: Vec3,
}

impl<'a> Extinction<'a> {
    fn of(
        majorant: &'a MajorantGrid,
        occupied: &[OccupiedCell],
        sampled: &[CellSample],
        axis_length: Vec3,
    ) -> Self {
        let (dims, _) = majorant.cell_layout();
        let mut sigma_t = vec![0.0f32; dims.element_product().max(0) as usize];
        for (cell, sample) in occupied.iter().zip(sampled) {
            sigma_t[cell.slot as usize] = sample.sigma_t_mean;
        }
        Self {
            majorant,
            sigma_t,
            axis_length,
        }
    }

    /// Per occupied cell, the mean over the six axis directions of
    /// exp(-optical depth) from its centre to the grid's edge, each cell
    /// crossed counting its mean extinction over its full edge (its own
    /// over half of it).
    fn escape_transmittances(&self, occupied: &[OccupiedCell]) -> Vec<f32> {
        let (dims, cell_size) = self.majorant.cell_layout();
        let edge = cell_size * self.axis_length;
        occupied
            .par_iter()
            .map(|cell| {
                let own = 0.5 * self.sigma_t[cell.slot as usize];
                let mut sum = 0.0;
                for axis in 0..3 {
                    for step in [-1, 1] {
                        let mut depth = own * edge[axis];
                        let mut c = cell.cell;
                        c[axis] += step;
                        while c[axis] >= 0 && c[axis] < dims[axis] {
                            depth += self.sigma_t[self.majorant.cell_slot(c)] * edge[axis];
                            c[axis] += step;
                        }
                        sum += (-depth).exp();
                    }
                }
                sum / 6.0
            })
            .collect()
    }

    /// Optical depth between index-space points `a` and `b` through the
    /// cells' mean extinctions, read at the midpoints of steps of one cell
    /// along the dominant axis.
    fn optical_depth(&self, a: Vec3, b: Vec3) -> f32 {
        let (dims, cell_size) = self.majorant.cell_layout();
        let lo = self.majorant.index_box().0;
        let d = b - a;
        let steps = (d / cell_size).abs().max_element().ceil().max(1.0);
        let world_step = (d * self.axis_length).length() / steps;
        (0..steps as u32)
            .map(|i| {
                let q = a + d * ((i as f32 + 0.5) / steps);
                let c = ((q - lo) / cell_size).floor().as_ivec3();
                let inside = c.cmpge(IVec3::ZERO).all() && c.cmplt(dims).all();
                if inside {
                    self.sigma_t[self.majorant.cell_slot(c)] * world_step
                } else {
                    0.0
                }
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::volumes::grid::{GridTransform, SparseGrid, Tile};
    use crate::volumes::majorant::MajorantKind;
    use glam::DAffine3;

    /// Density 1 over the 16^3 voxels of eight constant blocks, emitting
    /// (source 1) only at the index points with z <= 7: the four cells of
    /// the lower layer, [0, 16) x [0, 16) x [0, 8), emit alike.
    fn cells() -> (MajorantGrid, EmissionCells) {
        let tiles: Vec<Tile> = (0..8)
            .map(|n| Tile {
                origin: IVec3::new(n >> 2, (n >> 1) & 1, n & 1) * 8,
                edge: 8,
                value: 1.0,
                active: true,
            })
            .collect();
        let identity = GridTransform::new(DAffine3::IDENTITY).unwrap();
        let grid = SparseGrid::build(0.0, &[], Vec::new(), &tiles, identity).unwrap();
        let majorant = MajorantGrid::build(&grid, MajorantKind::Grid);
        let source = |p: Vec3| {
            let hot = f32::from(u8::from(p.z <= 7.0 && p.min_element() >= 0.0));
            SourceSample {
                sigma_t: 1.0,
                source: hot,
                radiance: hot,
            }
        };
        let cells = EmissionCells::build(&majorant, (1.0, Vec3::ONE), true, source).unwrap();
        (majorant, cells)
    }

    /// A placement twice as large (8x the voxel volume) reads twice the
    /// near importance at the same index-space point: power grows as the
    /// volume, squared distances as the area.
    #[test]
    fn near_importance_scales_with_the_placement() {
        let (_, cells) = cells();
        let p = Vec3::new(8.0, 8.0, -3.0);
        let unit = cells
            .near_importance(Affine3A::IDENTITY, 1.0)
            .at(p)
            .unwrap();
        let doubled = cells
            .near_importance(Affine3A::from_scale(Vec3::splat(0.5)), 8.0)
            .at(2.0 * p)
            .unwrap();
        assert!(unit > 0.0);
        assert!((doubled / unit - 2.0).abs() < 1e-5, "{doubled} vs {unit}");
    }

    /// From a shading point far away (picks by power) and from one beside
    /// a corner of the emission (picks by what each cell delivers there),
    /// samples lie only in cells whose points emit, each with the density
    /// `pdf` reports; the density integrates the emitting layer's volume
    /// (E[1 / pdf] over points in [0, 16) x [0, 16) x [0, 8) is 2048; the
    /// cubes just outside, whose inner corners emit, are sampled too)
    /// within 4 sigma; the near point
    /// draws the cell beside it more often than its power share (1/4).
    #[test]
    fn samples_cover_the_emission_with_the_density_pdf_reports() {
        let (majorant, cells) = cells();
        for (from, share_beside) in [
            (Vec3::splat(-30.0), 0.2..0.3),
            (Vec3::new(2.0, 2.0, -3.0), 0.5..1.0),
        ] {
            let mut rng = Pcg32::new(5, 0);
            let n = 20_000;
            let (mut sum, mut sum2, mut beside) = (0.0f64, 0.0f64, 0);
            for _ in 0..n {
                let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let (p, pdf) = cells.sample(from, u);
                assert!(p.z < 8.0, "{p} is in a cell that emits nothing");
                let reported = cells.pdf(&majorant, from, p);
                assert!((reported - pdf).abs() <= 1e-5 * pdf, "{reported} vs {pdf}");
                let inside = p.cmpge(Vec3::ZERO).all() && p.cmplt(Vec3::new(16.0, 16.0, 8.0)).all();
                let g = if inside { 1.0 / f64::from(pdf) } else { 0.0 };
                sum += g;
                sum2 += g * g;
                beside += usize::from(p.x < 8.0 && p.y < 8.0);
            }
            let mean = sum / f64::from(n);
            let sigma = ((sum2 / f64::from(n) - mean * mean) / f64::from(n)).sqrt();
            assert!(
                (mean - 2048.0).abs() < 4.0 * sigma,
                "from {from}: {mean} +- {sigma}"
            );
            let share = beside as f32 / n as f32;
            assert!(share_beside.contains(&share), "from {from}: {share} beside");
        }
        // The floors raise the emitting cells' majorants only.
        assert!(cells.collision_floors().iter().all(|&(_, f)| f > 0.0));
        assert_eq!(cells.pdf(&majorant, Vec3::ZERO, Vec3::splat(12.0)), 0.0);
    }
}
