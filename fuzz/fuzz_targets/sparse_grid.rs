//! Fuzzes `SparseGrid::build` and `GridTransform::new` on arbitrary trees:
//! leaves and tiles anywhere (misaligned, overlapping, at the ends of the i32
//! index range), any values, any affine map. Building must return `Ok` or
//! `Err`, never panic; an accepted grid must return every leaf voxel and tile
//! value as given, and its trilinear lookups must stay within the stored
//! values' range whenever they are all finite.

#![no_main]

use arbitrary::Arbitrary;
use cirrus::volumes::grid::{GridTransform, SparseGrid, Tile};
use glam::{DAffine3, IVec3, Vec3};
use libfuzzer_sys::fuzz_target;

/// A leaf or tile position: near the origin (so neighbours and overlaps are
/// common) or anywhere, aligned or not.
#[derive(Arbitrary, Debug)]
enum Origin {
    /// Block coordinates, scaled by the edge: always aligned.
    Near([i8; 3]),
    /// Any index point.
    Raw([i32; 3]),
}

impl Origin {
    fn index(&self, edge: i32) -> IVec3 {
        match *self {
            Self::Near(b) => IVec3::from_array(b.map(i32::from)) * edge,
            Self::Raw(o) => IVec3::from_array(o),
        }
    }
}

/// One leaf: 512 voxels of a linear ramp, one voxel overridden.
#[derive(Arbitrary, Debug)]
struct Leaf {
    origin: Origin,
    base: f32,
    step: [f32; 3],
    spike: (u16, f32),
}

impl Leaf {
    fn values(&self) -> impl Iterator<Item = f32> + '_ {
        (0..512).map(|n| {
            if n == usize::from(self.spike.0) % 512 {
                return self.spike.1;
            }
            let (x, y, z) = ((n / 64) as f32, (n / 8 % 8) as f32, (n % 8) as f32);
            self.base + self.step[0] * x + self.step[1] * y + self.step[2] * z
        })
    }
}

#[derive(Arbitrary, Debug)]
enum Edge {
    E8,
    E128,
    E4096,
    Raw(u32),
}

#[derive(Arbitrary, Debug)]
struct TileInput {
    origin: Origin,
    edge: Edge,
    value: f32,
    active: bool,
}

#[derive(Arbitrary, Debug)]
struct Input {
    background: f32,
    leaves: Vec<Leaf>,
    tiles: Vec<TileInput>,
    /// Column-major 3x4; `None` = identity.
    world_from_index: Option<[f64; 12]>,
    points: Vec<[f32; 3]>,
}

fuzz_target!(|input: Input| {
    let transform = match input.world_from_index {
        Some(m) => GridTransform::new(DAffine3::from_cols_array(&m)),
        None => GridTransform::new(DAffine3::IDENTITY),
    };
    if let Some(t) = &transform {
        assert!(t.world_from_index.is_finite() && t.index_from_world.is_finite());
    }
    let transform = transform.unwrap_or(GridTransform::new(DAffine3::IDENTITY).unwrap());
    let origins: Vec<IVec3> = input.leaves.iter().map(|l| l.origin.index(8)).collect();
    let values: Vec<f32> = input.leaves.iter().flat_map(Leaf::values).collect();
    let tiles: Vec<Tile> = input
        .tiles
        .iter()
        .map(|t| {
            let edge = match t.edge {
                Edge::E8 => 8,
                Edge::E128 => 128,
                Edge::E4096 => 4096,
                Edge::Raw(e) => e,
            };
            Tile {
                origin: t.origin.index(edge.clamp(1, 4096) as i32),
                edge,
                value: t.value,
                active: t.active,
            }
        })
        .collect();
    let Ok(grid) = SparseGrid::build(
        input.background,
        &origins,
        values.clone(),
        &tiles,
        transform,
    ) else {
        return;
    };
    let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    for (leaf, &origin) in origins.iter().enumerate() {
        for (n, &v) in values[leaf * 512..(leaf + 1) * 512].iter().enumerate() {
            let ijk = origin + IVec3::new(n as i32 / 64, n as i32 / 8 % 8, n as i32 % 8);
            assert!(same(grid.value(ijk), v), "leaf voxel {ijk}");
        }
    }
    for t in &tiles {
        let far = t.origin + IVec3::splat(t.edge as i32 - 1);
        assert!(same(grid.value(t.origin), t.value) && same(grid.value(far), t.value));
    }
    let stats = grid.stats();
    let lo = stats.min_value.min(input.background);
    let hi = stats.max_value.max(input.background);
    let bounded =
        stats.non_finite_count == 0 && input.background.is_finite() && (hi - lo).is_finite();
    let tolerance = 1e-5 * lo.abs().max(hi.abs());
    let mut accessor = grid.accessor();
    for p in input.points.iter().map(|&p| Vec3::from_array(p)) {
        let v = grid.trilinear_index(p);
        assert!(same(accessor.trilinear_index(p), v), "accessor at {p}");
        grid.nearest_index(p);
        grid.trilinear_world(p.as_dvec3());
        if bounded && p.is_finite() {
            assert!(
                v >= lo - tolerance && v <= hi + tolerance,
                "{v} at {p} outside [{lo}, {hi}]"
            );
        }
    }
});
