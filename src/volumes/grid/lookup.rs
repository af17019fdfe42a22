//! Reading a [`SparseGrid`]: nearest-neighbour and trilinear lookups in
//! index and world space (equal to OpenVDB's `PointSampler` and
//! `BoxSampler`), the accessor that caches the last block for ray marches,
//! and the footprint a trilinear lookup reads in one block, from which
//! majorant grids are built. Where values sit: sparse.rs and
//! docs/conventions.md, "Voxel centres".

use glam::{DVec3, IVec3, Vec3};

use super::sparse::{SparseGrid, APRON_EDGE, BRICK_LOG2, CONSTANT, EMPTY};

impl SparseGrid {
    /// Nearest-neighbour value at an index-space point: the closest index point,
    /// rounding halves up, as OpenVDB's `PointSampler`.
    #[inline]
    pub fn nearest_index(&self, p_index: Vec3) -> f32 {
        self.value((p_index + Vec3::splat(0.5)).floor().as_ivec3())
    }

    /// Trilinear value at an index-space point, equal to OpenVDB's `BoxSampler`.
    #[inline]
    pub fn trilinear_index(&self, p_index: Vec3) -> f32 {
        let cell = p_index.floor();
        // Exact in f32: p and floor(p) share an exponent range.
        self.trilinear_cell(cell.as_ivec3(), p_index - cell)
    }

    /// Trilinear value at a world-space point; the map to index space runs in
    /// f64 so large index coordinates keep their fractional precision.
    #[inline]
    pub fn trilinear_world(&self, p_world: DVec3) -> f32 {
        let p = self.transform.index_from_world.transform_point3(p_world);
        let cell = p.floor();
        self.trilinear_cell(cell.as_ivec3(), (p - cell).as_vec3())
    }

    /// Nearest-neighbour value at a world-space point.
    #[inline]
    pub fn nearest_world(&self, p_world: DVec3) -> f32 {
        let p = self.transform.index_from_world.transform_point3(p_world);
        self.value((p + DVec3::splat(0.5)).floor().as_ivec3())
    }

    /// A cursor for coherent lookups (one per ray march).
    pub fn accessor(&self) -> GridAccessor<'_> {
        GridAccessor {
            grid: self,
            block: IVec3::MAX,
            entry: EMPTY,
        }
    }

    #[inline]
    fn trilinear_cell(&self, ijk: IVec3, t: Vec3) -> f32 {
        self.trilinear_in_block(ijk, t, self.entry(ijk))
    }

    /// Trilinear interpolation inside the cell whose lowest corner is `ijk`, at
    /// fractional position `t` in [0,1)^3, given the entry `e` of the block
    /// holding `ijk`; lerps z, then y, then x, as OpenVDB's `BoxSampler`.
    #[inline(always)]
    fn trilinear_in_block(&self, ijk: IVec3, t: Vec3, e: u32) -> f32 {
        let v = if e != EMPTY && e & CONSTANT == 0 {
            // The apron holds the +1 neighbours: one brick serves all 8 corners.
            let b = &self.bricks[e as usize];
            let o = Self::apron_offset(ijk);
            const X: usize = APRON_EDGE * APRON_EDGE;
            const Y: usize = APRON_EDGE;
            [
                [[b[o], b[o + 1]], [b[o + Y], b[o + Y + 1]]],
                [[b[o + X], b[o + X + 1]], [b[o + X + Y], b[o + X + Y + 1]]],
            ]
        } else if (ijk & IVec3::splat(7)).cmplt(IVec3::splat(7)).all() {
            // A constant or empty block, and the cell does not reach its neighbours.
            return self.value(ijk);
        } else {
            let mut v = [[[0.0f32; 2]; 2]; 2];
            for (dx, plane) in v.iter_mut().enumerate() {
                for (dy, row) in plane.iter_mut().enumerate() {
                    for (dz, value) in row.iter_mut().enumerate() {
                        // Wrapping past i32::MAX lands at i32::MIN: background
                        // either way, as data ends at INDEX_LIMIT.
                        let corner = ijk.wrapping_add(IVec3::new(dx as i32, dy as i32, dz as i32));
                        *value = self.value(corner);
                    }
                }
            }
            v
        };
        let lerp = |a: f32, b: f32, w: f32| a + (b - a) * w;
        lerp(
            lerp(
                lerp(v[0][0][0], v[0][0][1], t.z),
                lerp(v[0][1][0], v[0][1][1], t.z),
                t.y,
            ),
            lerp(
                lerp(v[1][0][0], v[1][0][1], t.z),
                lerp(v[1][1][0], v[1][1][1], t.z),
                t.y,
            ),
            t.x,
        )
    }

    /// Calls `f(lo, hi, v)` for every value `v` a trilinear lookup at a point
    /// inside the 8^3 block `block` (index-space box `[8 block, 8 block + 8)`)
    /// can read, with the inclusive box `lo..=hi` of footprint voxels holding
    /// it, relative to the block's first voxel: the block's own voxels and the
    /// layer one voxel beyond it on +x, +y and +z (the 9^3 footprint of
    /// [`Self::trilinear_index`], coordinates 0..=8), each at least once; a
    /// constant or empty region is reported once with its whole box. Built for
    /// majorant grids: min and max over these values bound every interpolated
    /// value in the block, and where the non-zero ones lie bounds where
    /// density can be non-zero.
    pub(crate) fn for_each_footprint_value(
        &self,
        block: IVec3,
        mut f: impl FnMut(IVec3, IVec3, f32),
    ) {
        let origin = block << BRICK_LOG2;
        let e = self.entry(origin);
        if let Some(b) = self.resolve(e) {
            // The apron already holds the +1 layer.
            let edge = APRON_EDGE as i32;
            for (i, &v) in self.bricks[b].iter().enumerate() {
                let i = i as i32;
                let at = IVec3::new(i / (edge * edge), i / edge % edge, i % edge);
                f(at, at, v);
            }
            return;
        }
        f(IVec3::ZERO, IVec3::splat(7), self.entry_value(e));
        for n in 1..8 {
            let d = IVec3::new(n >> 2, (n >> 1) & 1, n & 1);
            // Only the neighbour's layer touching this block: one voxel deep along each stepped axis.
            let first = d << BRICK_LOG2;
            let end = IVec3::select(d.cmpeq(IVec3::ONE), IVec3::ONE, IVec3::splat(8));
            let e = self.entry(origin + first);
            let Some(b) = self.resolve(e) else {
                f(first, first + end - IVec3::ONE, self.entry_value(e));
                continue;
            };
            for x in 0..end.x {
                for y in 0..end.y {
                    for z in 0..end.z {
                        let at = IVec3::new(x, y, z);
                        f(
                            first + at,
                            first + at,
                            self.bricks[b][Self::apron_offset(at)],
                        );
                    }
                }
            }
        }
    }
}

/// Trilinear lookups that remember the last 8^3 block visited, as OpenVDB's
/// `ValueAccessor` does: consecutive points of a ray march mostly share a block,
/// so the two-level descent is skipped. Results equal [`SparseGrid::trilinear_index`].
pub struct GridAccessor<'a> {
    grid: &'a SparseGrid,
    /// Block coordinate (index >> 3) of the cached entry.
    block: IVec3,
    entry: u32,
}

impl GridAccessor<'_> {
    /// Trilinear value at an index-space point.
    #[inline]
    pub fn trilinear_index(&mut self, p_index: Vec3) -> f32 {
        let cell = p_index.floor();
        let ijk = cell.as_ivec3();
        let block = ijk >> BRICK_LOG2;
        if block != self.block {
            self.block = block;
            self.entry = self.grid.entry(ijk);
        }
        self.grid
            .trilinear_in_block(ijk, p_index - cell, self.entry)
    }
}

#[cfg(test)]
mod tests {
    use glam::DAffine3;

    use super::*;
    use crate::sampling::Pcg32;
    use crate::volumes::grid::sparse::tests::identity;
    use crate::volumes::grid::sparse::LEAF_VOXELS;
    use crate::volumes::grid::{GridTransform, Tile};

    /// A grid with one leaf at `origin` whose voxel (x,y,z) holds x + 10y + 100z
    /// (a linear function, so trilinear interpolation inside it is exact).
    fn linear_leaf(origin: IVec3) -> SparseGrid {
        let mut values = vec![0.0; LEAF_VOXELS];
        for x in 0..8 {
            for y in 0..8 {
                for z in 0..8 {
                    let p = origin + IVec3::new(x, y, z);
                    values[(x * 64 + y * 8 + z) as usize] = (p.x + 10 * p.y + 100 * p.z) as f32;
                }
            }
        }
        SparseGrid::build(0.0, &[origin], values, &[], identity()).unwrap()
    }

    #[test]
    fn trilinear_is_exact_on_a_linear_field_inside_a_leaf() {
        let origin = IVec3::new(-8, 16, 128);
        let grid = linear_leaf(origin);
        let mut rng = Pcg32::new(1, 0);
        for _ in 0..1000 {
            let p =
                origin.as_vec3() + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 7.0;
            let expected = p.x + 10.0 * p.y + 100.0 * p.z;
            let got = grid.trilinear_index(p);
            assert!(
                (got - expected).abs() <= 1e-4 * expected.abs().max(1.0),
                "{p}: {got} vs {expected}"
            );
        }
    }

    #[test]
    fn values_fall_to_background_one_voxel_past_the_data() {
        let grid = SparseGrid::build(
            0.0,
            &[],
            vec![],
            &[Tile {
                origin: IVec3::ZERO,
                edge: 8,
                value: 2.0,
                active: true,
            }],
            identity(),
        )
        .unwrap();
        assert_eq!(grid.trilinear_index(Vec3::new(3.3, 4.0, 5.5)), 2.0);
        // Halfway between the last stored voxel (x = 7) and the first empty one (x = 8).
        assert!((grid.trilinear_index(Vec3::new(7.5, 4.0, 4.0)) - 1.0).abs() < 1e-6);
        assert_eq!(grid.trilinear_index(Vec3::new(8.0, 4.0, 4.0)), 0.0);
        assert_eq!(grid.trilinear_index(Vec3::new(-1.0, 4.0, 4.0)), 0.0);
        assert_eq!(grid.stats().active_tile_count, 1);
    }

    /// Regression (fuzz target `sparse_grid`): a lookup whose cell saturates
    /// at i32::MAX overflowed reading its +1 corners (a panic in debug builds).
    #[test]
    fn lookups_at_the_ends_of_the_index_range_read_background() {
        let grid = linear_leaf(IVec3::ZERO);
        for p in [
            Vec3::splat(2.4e24),
            Vec3::splat(-2.4e24),
            Vec3::splat(f32::MAX),
        ] {
            assert_eq!(grid.trilinear_index(p), 0.0, "at {p}");
            assert_eq!(grid.accessor().trilinear_index(p), 0.0, "at {p}");
        }
    }

    #[test]
    fn world_sampling_applies_the_inverse_transform() {
        let origin = IVec3::ZERO;
        let mut grid = linear_leaf(origin);
        let world_from_index = DAffine3::from_scale_rotation_translation(
            DVec3::new(0.5, -2.0, 0.25),
            glam::DQuat::from_rotation_y(0.3),
            DVec3::new(1.0, 2.0, 3.0),
        );
        grid.transform = GridTransform::new(world_from_index).unwrap();
        let p_index = DVec3::new(2.25, 3.5, 4.75);
        let p_world = world_from_index.transform_point3(p_index);
        let expected = grid.trilinear_index(p_index.as_vec3());
        assert!((grid.trilinear_world(p_world) - expected).abs() < 1e-4);
        assert_eq!(grid.nearest_world(p_world), grid.value(IVec3::new(2, 4, 5)));
    }

    #[test]
    fn accessor_equals_plain_lookup_along_a_march_across_blocks() {
        // Two leaves side by side along x plus an 8^3 tile beyond them.
        let mut values = vec![0.0; 2 * LEAF_VOXELS];
        let mut rng = Pcg32::new(5, 0);
        values.iter_mut().for_each(|v| *v = rng.next_f32());
        let tile = Tile {
            origin: IVec3::new(16, 0, 0),
            edge: 8,
            value: 0.75,
            active: true,
        };
        let grid = SparseGrid::build(
            0.0,
            &[IVec3::ZERO, IVec3::new(8, 0, 0)],
            values,
            &[tile],
            identity(),
        )
        .unwrap();
        let mut accessor = grid.accessor();
        let mut p = Vec3::new(-2.0, 3.3, 4.1);
        while p.x < 28.0 {
            assert_eq!(
                accessor.trilinear_index(p),
                grid.trilinear_index(p),
                "at {p}"
            );
            p += Vec3::new(0.23, 0.011, -0.007);
        }
    }
}
