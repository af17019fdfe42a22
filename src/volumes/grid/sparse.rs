//! `SparseGrid`: the Rust-side copy of a float VDB tree, built once at load and
//! sampled by the renderer without ever calling back into OpenVDB. This file
//! holds the layout and its construction; lookup.rs reads values from it.
//!
//! Layout (two levels over OpenVDB's own 8^3 leaf blocks):
//! - `top`: a dense array over the occupied bounds in units of 128^3 voxels
//!   ("super-blocks", the span of an OpenVDB lower internal node). Each entry is
//!   empty (background), a constant (a tile of 128^3 or 4096^3 voxels), or the
//!   index of a node.
//! - `nodes`: 16^3 entries per occupied super-block, one per 8^3 block: empty,
//!   constant (an 8^3 tile), or the index of a brick.
//! - `bricks`: one per OpenVDB leaf, 9^3 values: the leaf's 8^3 voxels
//!   (inactive ones included, as OpenVDB stores them) plus a one-voxel apron
//!   copied from the +x/+y/+z neighbours, so every trilinear lookup whose lowest
//!   corner lies in a brick reads one brick only (offset = x*81 + y*9 + z). The
//!   apron costs 42% more brick memory and removes the slow cross-block path
//!   from 33% of lookups; `cirrus bench vdb` measures both sides.
//!
//! Values follow OpenVDB's `BoxSampler` convention (docs/conventions.md,
//! "Voxel centres"): value v(i,j,k) sits at the integer index point (i,j,k);
//! between points the value is trilinear; anything not stored is the
//! background.

use glam::{DAffine3, IVec3, U64Vec3};
use rayon::prelude::*;

/// Entry tag: nothing stored here, the grid's background applies.
pub(super) const EMPTY: u32 = u32::MAX;
/// Entry tag bit: the low 31 bits index `constants` instead of a child.
pub(super) const CONSTANT: u32 = 1 << 31;
/// Voxels per brick edge (OpenVDB leaf), and its log2.
pub(super) const BRICK_LOG2: i32 = 3;
/// Values per OpenVDB leaf (8^3), as handed over by the bridge.
pub(super) const LEAF_VOXELS: usize = 512;
/// Stored brick edge including the apron, and values per stored brick.
pub(super) const APRON_EDGE: usize = 9;
const APRON_VOXELS: usize = APRON_EDGE * APRON_EDGE * APRON_EDGE;
/// Bricks per node edge (OpenVDB lower internal node), and the super-block log2 in voxels.
const NODE_LOG2: i32 = 4;
const SUPER_LOG2: i32 = BRICK_LOG2 + NODE_LOG2;
const NODE_ENTRIES: usize = 1 << (3 * NODE_LOG2);
/// Largest `top` array accepted (entries, 4 bytes each): 256 MiB.
const MAX_TOP_ENTRIES: u64 = 1 << 26;
/// Stored voxels lie in `[-INDEX_LIMIT, INDEX_LIMIT)` on every axis: half the
/// i32 range, so block arithmetic near the data (the +1 apron, majorant cells
/// one block beyond the bounds) cannot overflow.
const INDEX_LIMIT: i32 = 1 << 30;

/// Index-space <-> world-space affine maps of a grid (OpenVDB's linear transform,
/// composed with the volume's own placement by the caller when needed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridTransform {
    /// World position of an index-space point.
    pub world_from_index: DAffine3,
    /// Inverse of `world_from_index`.
    pub index_from_world: DAffine3,
}

impl GridTransform {
    /// Both directions of an invertible affine map; `None` if it is singular
    /// or either direction has a non-finite entry (a NaN translation, or an
    /// inverse too large for f64).
    pub fn new(world_from_index: DAffine3) -> Option<Self> {
        let det = world_from_index.matrix3.determinant();
        if !(det.is_finite() && det.abs() > 1e-300) {
            return None;
        }
        let index_from_world = world_from_index.inverse();
        (world_from_index.is_finite() && index_from_world.is_finite()).then_some(Self {
            world_from_index,
            index_from_world,
        })
    }
}

/// Counts describing what a grid holds, for reports and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridStats {
    /// OpenVDB leaves copied as 8^3 bricks.
    pub leaf_count: usize,
    /// Active tiles kept as constant regions.
    pub active_tile_count: usize,
    /// Inactive tiles whose value differs from the background (kept, as OpenVDB samples them).
    pub inactive_tile_count: usize,
    /// Smallest finite stored value (leaf voxels and tiles).
    pub min_value: f32,
    /// Largest finite stored value: the global majorant of density.
    pub max_value: f32,
    /// Stored values that are NaN or infinite.
    pub non_finite_count: usize,
}

/// One tile of constant value, in index space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    /// Min corner, in voxels.
    pub origin: IVec3,
    /// Edge length in voxels: 8, 128 or 4096 (OpenVDB's standard float tree).
    pub edge: u32,
    /// The constant value of every voxel it covers.
    pub value: f32,
    /// Whether OpenVDB marks it active (inactive tiles are kept only when their value differs from the background).
    pub active: bool,
}

/// Why a tree cannot be laid out.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LayoutError {
    /// A leaf origin off the 8-voxel lattice.
    #[error("leaf origin {0} is not a multiple of 8")]
    MisalignedLeaf(IVec3),
    /// A tile of a size or alignment the standard 5-4-3 float tree never makes.
    #[error("tile at {origin} has edge {edge}; only 8, 128 and 4096 are supported")]
    UnsupportedTile {
        /// Min corner, in voxels.
        origin: IVec3,
        /// Edge length, in voxels.
        edge: u32,
    },
    /// Two leaves or tiles claim the same block.
    #[error("leaf or tile data overlaps at {0}")]
    Overlap(IVec3),
    /// Leaf values and leaf origins disagree in count.
    #[error("{0} leaf values for {1} leaves (expected 512 each)")]
    LeafValueCount(usize, usize),
    /// A leaf or tile reaches outside the index range the layout supports.
    #[error("leaf or tile at {origin} (edge {edge}) reaches outside the supported index range [-2^30, 2^30)")]
    OutOfRange {
        /// Min corner, in voxels.
        origin: IVec3,
        /// Edge length, in voxels.
        edge: u32,
    },
    /// The dense top level would exceed its size limit.
    #[error("the grid spans {}x{}x{} blocks of 128^3 voxels, more than the {MAX_TOP_ENTRIES} the sparse layout accepts", .0.x, .0.y, .0.z)]
    TooLarge(IVec3),
}

/// A sparse float grid: OpenVDB's leaves and tiles in flat Rust arrays.
#[derive(Clone, Debug)]
pub struct SparseGrid {
    pub(super) background: f32,
    /// First super-block coordinate covered by `top`.
    top_origin: IVec3,
    /// Super-blocks along each axis of `top` (x slowest, z fastest).
    top_dims: IVec3,
    top: Vec<u32>,
    nodes: Vec<u32>,
    pub(super) bricks: Vec<[f32; APRON_VOXELS]>,
    pub(super) constants: Vec<f32>,
    pub(super) transform: GridTransform,
    stats: GridStats,
}

/// The most aligned blocks of `edge` voxels a box of `dims` voxels can
/// touch: `ceil(d / edge) + 1` per axis (the box need not be aligned).
pub(in crate::volumes) fn blocks_spanned(dims: U64Vec3, edge: u64) -> u64 {
    dims.to_array()
        .map(|d| d.div_ceil(edge) + 1)
        .iter()
        .product()
}

impl SparseGrid {
    /// The value at integer index point `ijk` (nearest-neighbour lookup).
    #[inline]
    pub fn value(&self, ijk: IVec3) -> f32 {
        match self.entry(ijk) {
            EMPTY => self.background,
            e if e & CONSTANT != 0 => self.constants[(e & !CONSTANT) as usize],
            b => self.bricks[b as usize][Self::apron_offset(ijk)],
        }
    }

    /// Offset of `ijk` inside its apron brick.
    #[inline]
    pub(super) fn apron_offset(ijk: IVec3) -> usize {
        let l = (ijk & IVec3::splat((1 << BRICK_LOG2) - 1)).as_uvec3();
        (l.x as usize * APRON_EDGE + l.y as usize) * APRON_EDGE + l.z as usize
    }

    /// The node entry of the 8^3 block holding `ijk`: `EMPTY`, a `CONSTANT`
    /// index, or a brick index.
    #[inline]
    pub(super) fn entry(&self, ijk: IVec3) -> u32 {
        let s = (ijk >> SUPER_LOG2) - self.top_origin;
        if s.cmplt(IVec3::ZERO).any() || s.cmpge(self.top_dims).any() {
            return EMPTY;
        }
        let top = self.top[self.top_slot(s)];
        match self.resolve(top) {
            Some(node) => self.nodes[node * NODE_ENTRIES + Self::node_slot(ijk)],
            None => top,
        }
    }

    /// Position in `top` of super-block `s`, given relative to `top_origin`.
    #[inline]
    fn top_slot(&self, s: IVec3) -> usize {
        ((s.x * self.top_dims.y + s.y) * self.top_dims.z + s.z) as usize
    }

    /// Position inside its node of the 8^3 block holding `ijk`.
    #[inline]
    fn node_slot(ijk: IVec3) -> usize {
        let b = (ijk >> BRICK_LOG2) & IVec3::splat((1 << NODE_LOG2) - 1);
        ((b.x << (2 * NODE_LOG2)) | (b.y << NODE_LOG2) | b.z) as usize
    }

    /// The child index of a non-empty, non-constant entry.
    #[inline]
    pub(super) fn resolve(&self, entry: u32) -> Option<usize> {
        (entry != EMPTY && entry & CONSTANT == 0).then_some(entry as usize)
    }

    /// Whether the 8^3 blocks `first..=last` (block coordinates, index >> 3)
    /// all lie in super-blocks that store nothing, so every value there is
    /// the background: lets the majorant grid skip empty space in O(super-
    /// blocks) instead of visiting every block of a sparse grid's bounds.
    pub(crate) fn blocks_are_empty(&self, first: IVec3, last: IVec3) -> bool {
        let lo = ((first >> NODE_LOG2) - self.top_origin).max(IVec3::ZERO);
        let hi = ((last >> NODE_LOG2) - self.top_origin).min(self.top_dims - IVec3::ONE);
        if lo.cmpgt(hi).any() {
            return true;
        }
        (lo.x..=hi.x).all(|x| {
            (lo.y..=hi.y).all(|y| {
                (lo.z..=hi.z).all(|z| self.top[self.top_slot(IVec3::new(x, y, z))] == EMPTY)
            })
        })
    }

    /// Inclusive range of the 8^3 block coordinates (index >> 3) holding a leaf
    /// or a tile, or `None` for a grid that stores nothing.
    pub(crate) fn block_bounds(&self) -> Option<std::ops::RangeInclusive<IVec3>> {
        let mut lo = IVec3::MAX;
        let mut hi = IVec3::MIN;
        let blocks_per_super = IVec3::splat(1 << NODE_LOG2);
        for (slot, &top) in self.top.iter().enumerate() {
            let slot = slot as i32;
            let s = IVec3::new(
                slot / (self.top_dims.y * self.top_dims.z),
                slot / self.top_dims.z % self.top_dims.y,
                slot % self.top_dims.z,
            );
            let first = (self.top_origin + s) << NODE_LOG2;
            if top == EMPTY {
                continue;
            }
            let Some(node) = self.resolve(top) else {
                lo = lo.min(first);
                hi = hi.max(first + blocks_per_super - IVec3::ONE);
                continue;
            };
            let entries = &self.nodes[node * NODE_ENTRIES..(node + 1) * NODE_ENTRIES];
            for (n, _) in entries.iter().enumerate().filter(|(_, &e)| e != EMPTY) {
                let n = n as i32;
                let b = first
                    + IVec3::new(
                        n >> (2 * NODE_LOG2),
                        (n >> NODE_LOG2) & ((1 << NODE_LOG2) - 1),
                        n & ((1 << NODE_LOG2) - 1),
                    );
                lo = lo.min(b);
                hi = hi.max(b);
            }
        }
        (lo.cmple(hi).all()).then_some(lo..=hi)
    }

    /// The value of an `EMPTY` or `CONSTANT` entry.
    #[inline]
    pub(super) fn entry_value(&self, e: u32) -> f32 {
        match e {
            EMPTY => self.background,
            e => self.constants[(e & !CONSTANT) as usize],
        }
    }

    /// The value outside every stored voxel and tile.
    pub fn background(&self) -> f32 {
        self.background
    }

    /// Index <-> world maps.
    pub fn transform(&self) -> &GridTransform {
        &self.transform
    }

    /// What the grid holds.
    pub fn stats(&self) -> &GridStats {
        &self.stats
    }

    /// Bytes the layout of a grid of `leaves` 8^3 leaves over an index box
    /// of `dims` voxels will hold, estimated before it is read (the memory
    /// preflight): an apron brick per leaf, a node array per super-block
    /// that can hold one, and the top array over the box.
    pub fn bytes_for(dims: U64Vec3, leaves: u64) -> u64 {
        let supers = blocks_spanned(dims, 1 << SUPER_LOG2);
        let node_bytes = (NODE_ENTRIES * 4) as u64;
        std::mem::size_of::<Self>() as u64
            + leaves * (APRON_VOXELS * 4) as u64
            + supers.min(leaves) * node_bytes
            + supers * 4
    }

    /// Bytes held by the layout's arrays (what the renderer keeps resident).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + 4 * (self.top.capacity()
                + self.nodes.capacity()
                + self.bricks.capacity() * APRON_VOXELS
                + self.constants.capacity())
    }

    /// Builds the layout from OpenVDB's flattened tree. `leaf_values` holds 512
    /// values per leaf origin, in OpenVDB's voxel order.
    pub fn build(
        background: f32,
        leaf_origins: &[IVec3],
        leaf_values: Vec<f32>,
        tiles: &[Tile],
        transform: GridTransform,
    ) -> Result<Self, LayoutError> {
        if leaf_values.len() != leaf_origins.len() * LEAF_VOXELS {
            return Err(LayoutError::LeafValueCount(
                leaf_values.len(),
                leaf_origins.len(),
            ));
        }
        let mut lo = IVec3::MAX;
        let mut hi = IVec3::MIN;
        for &o in leaf_origins {
            if o & IVec3::splat((1 << BRICK_LOG2) - 1) != IVec3::ZERO {
                return Err(LayoutError::MisalignedLeaf(o));
            }
            check_range(o, 1 << BRICK_LOG2)?;
            lo = lo.min(o >> SUPER_LOG2);
            hi = hi.max(o >> SUPER_LOG2);
        }
        for t in tiles {
            if ![8, 128, 4096].contains(&t.edge) || t.origin % t.edge as i32 != IVec3::ZERO {
                return Err(LayoutError::UnsupportedTile {
                    origin: t.origin,
                    edge: t.edge,
                });
            }
            check_range(t.origin, t.edge)?;
            lo = lo.min(t.origin >> SUPER_LOG2);
            hi = hi.max((t.origin + IVec3::splat(t.edge as i32 - 1)) >> SUPER_LOG2);
        }
        if leaf_origins.is_empty() && tiles.is_empty() {
            lo = IVec3::ZERO;
            hi = IVec3::splat(-1);
        }
        let top_dims = hi - lo + IVec3::ONE;
        // In u128: up to 2^24 super-blocks per axis, whose product overflows i64.
        let entries: u128 = top_dims.to_array().iter().map(|&d| d as u128).product();
        if entries > MAX_TOP_ENTRIES.into() {
            return Err(LayoutError::TooLarge(top_dims));
        }

        let mut grid = SparseGrid {
            background,
            top_origin: lo,
            top_dims,
            top: vec![EMPTY; entries as usize],
            nodes: Vec::new(),
            bricks: Vec::new(),
            constants: Vec::new(),
            transform,
            stats: GridStats {
                leaf_count: leaf_origins.len(),
                min_value: f32::INFINITY,
                max_value: f32::NEG_INFINITY,
                ..GridStats::default()
            },
        };
        for &v in &leaf_values {
            grid.stats.note_value(v);
        }
        // Large tiles first: they own whole super-blocks.
        for t in tiles.iter().filter(|t| t.edge > 8) {
            grid.stats.note_tile(t);
            let c = grid.push_constant(t.value);
            let first = t.origin >> SUPER_LOG2;
            let span = t.edge as i32 >> SUPER_LOG2;
            for x in 0..span {
                for y in 0..span {
                    for z in 0..span {
                        let s = first + IVec3::new(x, y, z);
                        let slot = grid.top_slot(s - grid.top_origin);
                        if grid.top[slot] != EMPTY {
                            return Err(LayoutError::Overlap(s << SUPER_LOG2));
                        }
                        grid.top[slot] = c;
                    }
                }
            }
        }
        for (i, &o) in leaf_origins.iter().enumerate() {
            grid.set_block(o, i as u32)?;
        }
        for t in tiles.iter().filter(|t| t.edge == 8) {
            grid.stats.note_tile(t);
            let c = grid.push_constant(t.value);
            grid.set_block(t.origin, c)?;
        }
        if grid.stats.min_value > grid.stats.max_value {
            grid.stats.min_value = background;
            grid.stats.max_value = background;
        }
        grid.nodes.shrink_to_fit();
        grid.constants.shrink_to_fit();
        grid.bricks = grid.apron_bricks(leaf_origins, &leaf_values);
        Ok(grid)
    }

    /// The 9^3 bricks: each leaf's voxels plus the +1 apron read from its
    /// neighbours (leaves, tiles or background), in parallel over leaves.
    fn apron_bricks(
        &self,
        leaf_origins: &[IVec3],
        leaf_values: &[f32],
    ) -> Vec<[f32; APRON_VOXELS]> {
        let leaf_value = |ijk: IVec3| match self.entry(ijk) {
            EMPTY => self.background,
            e if e & CONSTANT != 0 => self.constants[(e & !CONSTANT) as usize],
            b => {
                let l = (ijk & IVec3::splat(7)).as_uvec3();
                leaf_values[b as usize * LEAF_VOXELS + (l.x * 64 + l.y * 8 + l.z) as usize]
            }
        };
        let mut bricks = vec![[0.0f32; APRON_VOXELS]; leaf_origins.len()];
        bricks
            .par_iter_mut()
            .zip(leaf_origins.par_iter())
            .for_each(|(brick, &origin)| {
                for (n, v) in brick.iter_mut().enumerate() {
                    let (x, y, z) = (
                        n / (APRON_EDGE * APRON_EDGE),
                        n / APRON_EDGE % APRON_EDGE,
                        n % APRON_EDGE,
                    );
                    *v = leaf_value(origin + IVec3::new(x as i32, y as i32, z as i32));
                }
            });
        bricks
    }

    fn push_constant(&mut self, value: f32) -> u32 {
        self.constants.push(value);
        (self.constants.len() - 1) as u32 | CONSTANT
    }

    /// Points the node entry of the 8^3 block at `origin` to `entry`, creating the node.
    fn set_block(&mut self, origin: IVec3, entry: u32) -> Result<(), LayoutError> {
        let slot = self.top_slot((origin >> SUPER_LOG2) - self.top_origin);
        let node = match self.top[slot] {
            EMPTY => {
                let node = self.nodes.len() / NODE_ENTRIES;
                self.nodes.resize(self.nodes.len() + NODE_ENTRIES, EMPTY);
                self.top[slot] = node as u32;
                node
            }
            e if e & CONSTANT != 0 => return Err(LayoutError::Overlap(origin)),
            e => e as usize,
        };
        let cell = &mut self.nodes[node * NODE_ENTRIES + Self::node_slot(origin)];
        if *cell != EMPTY {
            return Err(LayoutError::Overlap(origin));
        }
        *cell = entry;
        Ok(())
    }
}

/// `Ok` if the `edge`^3 block at `origin` lies inside `[-INDEX_LIMIT, INDEX_LIMIT)`.
fn check_range(origin: IVec3, edge: u32) -> Result<(), LayoutError> {
    let inside = origin.cmpge(IVec3::splat(-INDEX_LIMIT)).all()
        && origin.cmple(IVec3::splat(INDEX_LIMIT - edge as i32)).all();
    inside
        .then_some(())
        .ok_or(LayoutError::OutOfRange { origin, edge })
}

impl GridStats {
    fn note_value(&mut self, v: f32) {
        if v.is_finite() {
            self.min_value = self.min_value.min(v);
            self.max_value = self.max_value.max(v);
        } else {
            self.non_finite_count += 1;
        }
    }

    fn note_tile(&mut self, t: &Tile) {
        if t.active {
            self.active_tile_count += 1;
        } else {
            self.inactive_tile_count += 1;
        }
        self.note_value(t.value);
    }
}

#[cfg(test)]
pub(super) mod tests {
    use glam::DVec3;

    use super::*;

    pub(in crate::volumes) fn identity() -> GridTransform {
        GridTransform::new(DAffine3::IDENTITY).unwrap()
    }

    #[test]
    fn large_tiles_cover_whole_super_blocks() {
        let grid = SparseGrid::build(
            0.5,
            &[],
            vec![],
            &[Tile {
                origin: IVec3::new(-4096, 0, 0),
                edge: 4096,
                value: 3.0,
                active: true,
            }],
            identity(),
        )
        .unwrap();
        assert_eq!(grid.value(IVec3::new(-1, 4095, 17)), 3.0);
        assert_eq!(grid.value(IVec3::new(0, 0, 0)), 0.5);
        assert_eq!(grid.value(IVec3::new(-4097, 0, 0)), 0.5);
        assert_eq!(grid.top.len(), 32 * 32 * 32);
        assert!(grid.nodes.is_empty());
    }

    #[test]
    fn bad_trees_are_rejected() {
        let t = identity();
        assert_eq!(
            SparseGrid::build(0.0, &[IVec3::new(1, 0, 0)], vec![0.0; 512], &[], t).unwrap_err(),
            LayoutError::MisalignedLeaf(IVec3::new(1, 0, 0))
        );
        assert!(matches!(
            SparseGrid::build(0.0, &[IVec3::ZERO; 2], vec![0.0; 1024], &[], t),
            Err(LayoutError::Overlap(_))
        ));
        assert!(matches!(
            SparseGrid::build(0.0, &[IVec3::ZERO], vec![0.0; 5], &[], t),
            Err(LayoutError::LeafValueCount(5, 1))
        ));
        let far = [IVec3::splat(-1 << 20), IVec3::splat(1 << 20)];
        assert!(matches!(
            SparseGrid::build(0.0, &far, vec![0.0; 1024], &[], t),
            Err(LayoutError::TooLarge(_))
        ));
    }

    /// Regression (fuzz target `sparse_grid`): a leaf at the end of the i32
    /// range overflowed while its apron was copied, and majorant cells one
    /// block beyond such data overflowed too; such trees are now refused.
    #[test]
    fn data_outside_the_supported_index_range_is_refused() {
        let t = identity();
        let out = |origin: IVec3, edge: u32| Err(LayoutError::OutOfRange { origin, edge });
        for o in [IVec3::new(0, 0, i32::MAX - 7), IVec3::new(i32::MIN, 0, 0)] {
            assert_eq!(
                SparseGrid::build(0.0, &[o], vec![1.0; 512], &[], t).map(|_| ()),
                out(o, 8)
            );
        }
        let tile = |origin: IVec3, edge: u32| Tile {
            origin,
            edge,
            value: 1.0,
            active: true,
        };
        let o = IVec3::new(INDEX_LIMIT, 0, 0);
        assert_eq!(
            SparseGrid::build(0.0, &[], vec![], &[tile(o, 4096)], t).map(|_| ()),
            out(o, 4096)
        );
        // The last blocks inside the range are kept.
        let last = IVec3::splat(INDEX_LIMIT - 8);
        let grid = SparseGrid::build(0.0, &[last], vec![1.0; 512], &[], t).unwrap();
        assert_eq!(grid.value(last + IVec3::splat(7)), 1.0);
        let first = IVec3::splat(-INDEX_LIMIT);
        assert!(SparseGrid::build(0.0, &[], vec![], &[tile(first, 4096)], t).is_ok());
    }

    /// Regression (fuzz target `sparse_grid`): the top level's entry count
    /// was an i64 product that wraps for data spread over the index range
    /// (to 0 here, 2^24 super-blocks per axis), and the top level was then
    /// indexed out of bounds.
    #[test]
    fn top_level_size_is_checked_without_overflow() {
        let corners = [IVec3::splat(-INDEX_LIMIT), IVec3::splat(INDEX_LIMIT - 8)];
        assert_eq!(
            SparseGrid::build(0.0, &corners, vec![0.0; 1024], &[], identity()).map(|_| ()),
            Err(LayoutError::TooLarge(IVec3::splat(1 << 24)))
        );
    }

    /// Regression (`tests/it/fuzz_inputs.rs`): an invertible matrix with a NaN
    /// translation was accepted, and every world lookup then returned NaN.
    #[test]
    fn transforms_with_non_finite_entries_are_refused() {
        let shifted = |t: DVec3| DAffine3::from_translation(t);
        assert!(GridTransform::new(shifted(DVec3::new(f64::NAN, 0.0, 0.0))).is_none());
        assert!(GridTransform::new(shifted(DVec3::new(0.0, f64::INFINITY, 0.0))).is_none());
        // Finite forward map whose inverse overflows f64.
        let tiny = shifted(DVec3::splat(1e300)) * DAffine3::from_scale(DVec3::splat(1e-90));
        assert!(GridTransform::new(tiny).is_none());
        assert!(GridTransform::new(shifted(DVec3::splat(1e300))).is_some());
    }
}
