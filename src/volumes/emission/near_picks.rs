//! Picks of an emitting volume's cells that depend on where the light is
//! seen from. Picked by power alone, a fire's cells are sampled as often
//! from the ground touching its base as from the far side of the scene:
//! the ground is lit mostly by the few cells nearest to it, and the boulder
//! beside a fire wrapped in soot by the cells on its own side. So the space
//! around the emission (its box, grown by its own size on every side) is
//! cut into [`REGIONS_PER_AXIS`]^3 regions, and each region gets its own
//! distribution over clusters of cells: a cluster's power times the
//! transmittance from the region's centre to the cluster through the
//! cells' mean extinctions, over their squared distance (floored at the
//! region's and the cluster's sizes), the many-light estimate of what the
//! cluster delivers there (Conty Estevez & Kulla 2018 weigh lights the same
//! way, without the transmittance). Within a cluster a cell is picked by
//! power. Summed over the clusters, the same estimate is what the light
//! selection weighs the volume by against the other lights from a shading
//! point in the region ([`NearImportance`]).
//!
//! Unbiased whatever the estimate: [`GLOBAL_SHARE`] of every region's
//! distribution is the clusters' power share, so every cell that may emit
//! keeps a non-zero probability from everywhere, and a shading point
//! outside the regions picks by power alone. Sample and density read the
//! same region, so the pdf that MIS uses is the one that sampled.
//!
//! Measured (docs/benchmarks.md, "Fire", 2026-12-03): 1.17x lower
//! relMSE at equal spp on both fire benchmarks, within the timing noise of
//! the same cost per sample; 16 regions per axis without merging cells did
//! within 2% of this, 128 clusters lost a sixth of the gain.

use glam::{Affine3A, IVec3, Vec3};
use rayon::prelude::*;

use crate::sampling::AliasTable;

/// Regions along each axis of the grown emission box.
const REGIONS_PER_AXIS: i32 = 12;

/// Most clusters a region's distribution spans: neighbouring cells are
/// merged (2^3, 4^3, ...) until there are no more, so the tables hold at
/// most 12^3 x 512 bins (10.6 MB) however large the fire (the memory
/// preflight counts that bound; tests/it/fire.rs sets it aside).
const MAX_CLUSTERS: usize = 512;

/// Share of a region's picks made by power alone (defensive mixture).
const GLOBAL_SHARE: f32 = 0.25;

/// One emitting cell, as the regions weigh it.
#[derive(Clone, Copy, Debug)]
pub(super) struct WeighedCell {
    /// Its majorant-grid coordinates.
    pub cell: IVec3,
    /// Index-space centre of its support box.
    pub centre: Vec3,
    /// Half its support box's diagonal, index units.
    pub radius: f32,
    /// Its pick weight by power.
    pub weight: f32,
}

/// Cells merged for the regions' distributions.
#[derive(Debug)]
struct Cluster {
    /// Indices of its cells.
    cells: Vec<u32>,
    /// Over `cells`, by power.
    by_power: AliasTable,
}

/// The [`REGIONS_PER_AXIS`]^3 boxes the space around an emission is cut
/// into, in the density grid's index space.
#[derive(Clone, Copy, Debug)]
struct Regions {
    /// Min corner of the regions' box.
    lo: Vec3,
    /// Edge lengths of one region, index units.
    size: Vec3,
}

impl Regions {
    /// Number of the region holding `p` (x slowest, z fastest); `None`
    /// outside them.
    fn of(&self, p: Vec3) -> Option<usize> {
        let c = ((p - self.lo) / self.size).floor();
        let n = REGIONS_PER_AXIS as f32;
        if c.cmplt(Vec3::ZERO).any() || c.cmpge(Vec3::splat(n)).any() {
            return None;
        }
        let c = c.as_ivec3();
        let n = REGIONS_PER_AXIS;
        Some(((c.x * n + c.y) * n + c.z) as usize)
    }
}

/// The regions' distributions (see the module doc).
#[derive(Debug)]
pub(super) struct NearPicks {
    regions: Regions,
    clusters: Vec<Cluster>,
    /// Per cell: its cluster and its position there.
    cell_slots: Vec<(u32, u32)>,
    /// Per region, over `clusters`.
    tables: Vec<AliasTable>,
    /// Per region, the estimate its distribution is drawn from, summed over
    /// the clusters: power x transmittance / squared distance, in the cells'
    /// weight unit per index unit squared.
    delivered: Vec<f32>,
}

/// What an emitting volume delivers around it by region, for the light
/// selection: 4 pi x the irradiance the near picks' estimate gives each
/// region's centre (power x transmittance / distance^2, summed over the
/// clusters), the unit of `lights/bvh.rs`'s importance. Plain data, so a
/// light can hold it.
#[derive(Clone, Debug)]
pub(crate) struct NearImportance {
    /// World to the density grid's index space.
    index_from_world: Affine3A,
    regions: Regions,
    /// Per region.
    importance: Vec<f32>,
}

impl NearImportance {
    /// The importance at world point `p`; `None` outside the regions.
    pub(crate) fn at(&self, p: Vec3) -> Option<f32> {
        let region = self.regions.of(self.index_from_world.transform_point3(p))?;
        Some(self.importance[region])
    }
}

#[cfg(test)]
impl NearImportance {
    /// `importance` throughout the world box `(lo, hi)` (cut into the
    /// regions), for the light selection's tests.
    pub(crate) fn constant((lo, hi): (Vec3, Vec3), importance: f32) -> Self {
        Self {
            index_from_world: Affine3A::IDENTITY,
            regions: Regions {
                lo,
                size: (hi - lo) / REGIONS_PER_AXIS as f32,
            },
            importance: vec![importance; REGIONS_PER_AXIS.pow(3) as usize],
        }
    }
}

/// A cell picked with a region's distribution.
pub(super) struct NearPick {
    /// Index of the cell.
    pub cell: usize,
    /// Its probability.
    pub probability: f32,
    /// The random number rescaled within the pick, uniform again.
    pub remapped: f32,
}

impl NearPicks {
    /// Picks a cell for shading point `from` (index space) with `u`;
    /// `None` outside the regions (pick by power alone there).
    pub(super) fn sample(&self, from: Vec3, u: f32) -> Option<NearPick> {
        let table = self.table(from)?;
        let c = table.sample_discrete(u);
        let cluster = &self.clusters[c.index];
        let pick = cluster.by_power.sample_discrete(c.remapped);
        Some(NearPick {
            cell: cluster.cells[pick.index] as usize,
            probability: c.probability * pick.probability,
            remapped: pick.remapped,
        })
    }

    /// Probability that [`Self::sample`] picks cell `cell` for `from`;
    /// `None` outside the regions.
    pub(super) fn probability(&self, from: Vec3, cell: usize) -> Option<f32> {
        let table = self.table(from)?;
        let (cluster, slot) = self.cell_slots[cell];
        let within = self.clusters[cluster as usize]
            .by_power
            .probability(slot as usize);
        Some(table.probability(cluster as usize) * within)
    }

    /// The distribution of the region holding `p`.
    fn table(&self, p: Vec3) -> Option<&AliasTable> {
        self.regions.of(p).map(|r| &self.tables[r])
    }

    /// The regions' importance for the light selection, for a grid placed
    /// by `index_from_world`: `scale` x the summed estimates, `scale`
    /// converting their unit to [`NearImportance`]'s (see `emitter.rs`).
    pub(super) fn importance(&self, index_from_world: Affine3A, scale: f32) -> NearImportance {
        NearImportance {
            index_from_world,
            regions: self.regions,
            importance: self.delivered.iter().map(|d| scale * d).collect(),
        }
    }

    /// Bytes the picks over `cells` emitting cells hold at most.
    pub(super) fn bytes_for(cells: u64) -> u64 {
        let regions = REGIONS_PER_AXIS.pow(3) as u64;
        regions * AliasTable::bytes_for(cells.min(MAX_CLUSTERS as u64))
            + AliasTable::bytes_for(cells)
            + cells * (4 + 8)
            + 2 * regions * 4
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        let tables: usize = self.tables.iter().map(AliasTable::memory_bytes).sum();
        let clusters: usize = self
            .clusters
            .iter()
            .map(|c| c.by_power.memory_bytes() + c.cells.capacity() * 4)
            .sum();
        tables + clusters + self.cell_slots.capacity() * 8 + self.delivered.capacity() * 4
    }

    /// The regions over `cells` (not empty), within the index-space box
    /// `(lo, hi)` around them; `optical_depth(a, b)` estimates the optical
    /// depth between two index-space points.
    pub(super) fn build(
        cells: &[WeighedCell],
        (lo, hi): (Vec3, Vec3),
        optical_depth: impl Fn(Vec3, Vec3) -> f32 + Sync,
    ) -> Self {
        let (clusters, cell_slots) = clusters(cells);
        // Each cluster: power, centre (power-weighted where it has power)
        // and radius.
        let summaries: Vec<(f32, Vec3, f32)> = clusters
            .iter()
            .map(|cluster| {
                let members = cluster.cells.iter().map(|&i| &cells[i as usize]);
                let power: f32 = members.clone().map(|c| c.weight).sum();
                let (lo, hi) = members.clone().fold(
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                    |(lo, hi), c| (lo.min(c.centre - c.radius), hi.max(c.centre + c.radius)),
                );
                let centre = members.map(|c| c.centre * c.weight).sum::<Vec3>() / power;
                let centre = if centre.is_finite() {
                    centre
                } else {
                    0.5 * (lo + hi)
                };
                (power, centre, 0.5 * (hi - lo).length())
            })
            .collect();
        let total: f32 = summaries.iter().map(|s| s.0).sum();
        let extent = hi - lo;
        let regions = Regions {
            lo: lo - extent,
            size: 3.0 * extent / REGIONS_PER_AXIS as f32,
        };
        let floor = (0.25 * regions.size.length()).powi(2);
        let n = REGIONS_PER_AXIS;
        let (tables, delivered) = (0..n * n * n)
            .into_par_iter()
            .map(|k| {
                let at = IVec3::new(k / (n * n), k / n % n, k % n);
                let centre = regions.lo + (at.as_vec3() + 0.5) * regions.size;
                let delivered: Vec<f32> = summaries
                    .iter()
                    .map(|&(power, c, radius)| {
                        let d2 = c.distance_squared(centre).max(floor + radius * radius);
                        power * (-optical_depth(centre, c)).exp() / d2
                    })
                    .collect();
                let delivered_total: f32 = delivered.iter().sum();
                let weights: Vec<f32> = delivered
                    .iter()
                    .zip(&summaries)
                    .map(|(&w, s)| {
                        let share = if delivered_total > 0.0 {
                            w / delivered_total
                        } else {
                            0.0
                        };
                        (1.0 - GLOBAL_SHARE) * share + GLOBAL_SHARE * s.0 / total
                    })
                    .collect();
                (AliasTable::new(&weights), delivered_total)
            })
            .unzip();
        Self {
            regions,
            clusters,
            cell_slots,
            tables,
            delivered,
        }
    }
}

/// The cells merged into blocks of 2^k majorant cells per axis, k the
/// least that leaves at most [`MAX_CLUSTERS`] blocks; and per cell its
/// cluster and position there.
fn clusters(cells: &[WeighedCell]) -> (Vec<Cluster>, Vec<(u32, u32)>) {
    let mut shift = 0;
    let keyed = loop {
        let mut keys: Vec<(IVec3, u32)> = cells
            .iter()
            .enumerate()
            .map(|(i, c)| (c.cell >> shift, i as u32))
            .collect();
        keys.sort_unstable_by_key(|&(k, _)| (k.x, k.y, k.z));
        let distinct = 1 + keys.windows(2).filter(|w| w[0].0 != w[1].0).count();
        if distinct <= MAX_CLUSTERS || shift >= 30 {
            break keys;
        }
        shift += 1;
    };
    let mut clusters = Vec::new();
    let mut cell_slots = vec![(0, 0); cells.len()];
    for group in keyed.chunk_by(|a, b| a.0 == b.0) {
        let members: Vec<u32> = group.iter().map(|&(_, i)| i).collect();
        for (slot, &i) in members.iter().enumerate() {
            cell_slots[i as usize] = (clusters.len() as u32, slot as u32);
        }
        let weights: Vec<f32> = members.iter().map(|&i| cells[i as usize].weight).collect();
        clusters.push(Cluster {
            by_power: AliasTable::new(&weights),
            cells: members,
        });
    }
    (clusters, cell_slots)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1000 cells on a 10^3 lattice (more than [`MAX_CLUSTERS`]), the
    /// brighter the larger x, one of them opaque between the others and a
    /// region: every region's probabilities over the cells sum to 1, each
    /// is what a sample that picks the cell reports, and a cell is never
    /// less likely than its defensive share of its power.
    #[test]
    fn every_region_picks_each_cell_with_the_probability_it_reports() {
        let cells: Vec<WeighedCell> = (0..1000)
            .map(|k| {
                let cell = IVec3::new(k / 100, k / 10 % 10, k % 10);
                WeighedCell {
                    cell,
                    centre: cell.as_vec3() * 8.0 + 4.0,
                    radius: 4.0 * 3f32.sqrt(),
                    weight: 1.0 + cell.x as f32,
                }
            })
            .collect();
        let total: f32 = cells.iter().map(|c| c.weight).sum();
        let wall = |a: Vec3, b: Vec3| {
            if (a.x < 40.0) != (b.x < 40.0) {
                50.0
            } else {
                0.0
            }
        };
        let picks = NearPicks::build(&cells, (Vec3::ZERO, Vec3::splat(80.0)), wall);
        assert!(picks.clusters.len() <= MAX_CLUSTERS);
        for from in [
            Vec3::new(-20.0, 5.0, 5.0),
            Vec3::splat(40.0),
            Vec3::new(95.0, 90.0, 3.0),
        ] {
            let probabilities: Vec<f32> = (0..cells.len())
                .map(|i| picks.probability(from, i).unwrap())
                .collect();
            let sum: f32 = probabilities.iter().sum();
            assert!((sum - 1.0).abs() < 1e-4, "from {from}: {sum}");
            for (i, (&p, c)) in probabilities.iter().zip(&cells).enumerate() {
                assert!(
                    p >= 0.99 * GLOBAL_SHARE * c.weight / total,
                    "cell {i} from {from}: {p}"
                );
            }
            for k in 0..1000 {
                let pick = picks.sample(from, (k as f32 + 0.5) / 1000.0).unwrap();
                let expected = probabilities[pick.cell];
                assert!((pick.probability - expected).abs() <= 1e-5 * expected);
            }
        }
        // Behind the wall from the left, the right half gets its
        // defensive share only, although it holds most of the power.
        let right: f32 = (0..cells.len())
            .filter(|&i| cells[i].centre.x > 40.0)
            .map(|i| picks.probability(Vec3::new(-20.0, 5.0, 5.0), i).unwrap())
            .sum();
        assert!(right < 0.25, "{right}");
        assert!(picks.probability(Vec3::splat(-1000.0), 0).is_none());
    }
}
