//! `cirrus bench vdb`: the sparse grid layout against OpenVDB's own tree.
//! Per file: load time, memory next to OpenVDB's `memUsage()`, and
//! single-thread trilinear lookups per second at random points, along
//! independent ray marches, and along tiles of neighbouring ray marches
//! (plain and through a `GridAccessor`).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;

use super::machine::machine_line;
use super::stats::median;
use super::Result;
use crate::sampling::Pcg32;
use crate::volumes::grid::VdbFile;

/// What to measure.
pub struct VdbBench {
    /// VDB files to measure.
    pub files: Vec<PathBuf>,
    /// Float grid to read from each file.
    pub grid: String,
    /// Timed repeats (at least one); the table shows medians.
    pub repeats: usize,
    /// Lookups per timed repeat (at least one).
    pub lookups: usize,
}

/// Runs the benchmark and prints its table.
pub fn run(bench: &VdbBench) -> Result<()> {
    let (grid_name, repeats, lookups) = (&bench.grid, bench.repeats.max(1), bench.lookups.max(1));
    println!("{}\n", machine_line());
    println!("| file | load (ms) | layout (MiB) | OpenVDB tree (MiB) | layout / OpenVDB | random (M/s) | independent rays (M/s) | ray tiles (M/s) | ray tiles, accessor (M/s) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for file in &bench.files {
        let mut load_ms = Vec::new();
        let mut grid = None;
        for _ in 0..repeats {
            let start = Instant::now();
            let g = VdbFile::open(file)?.read_float_grid(grid_name, 0)?;
            load_ms.push(start.elapsed().as_secs_f64() * 1e3);
            grid = Some(g);
        }
        let grid = grid.expect("at least one repeat");
        let vdb = VdbFile::open(file)?;
        let info = &vdb.grids()[vdb.find(grid_name, 0)?];
        let openvdb_bytes = vdb.openvdb_tree_bytes(grid_name, 0)?;
        let (lo, hi) = (
            info.index_min.as_vec3() - 1.0,
            info.index_max.as_vec3() + 1.0,
        );

        let random = random_points(lo, hi, lookups);
        let rays = ray_march_points(lo, hi, lookups, 1);
        let coherent = ray_march_points(lo, hi, lookups, 16);
        let plain = || |p| grid.trilinear_index(p);
        let random_rate = median_rate(repeats, &random, plain);
        let rays_rate = median_rate(repeats, &rays, plain);
        let coherent_rate = median_rate(repeats, &coherent, plain);
        let accessor_rate = median_rate(repeats, &coherent, || {
            let mut accessor = grid.accessor();
            move |p| accessor.trilinear_index(p)
        });
        let mib = |b: f64| b / (1024.0 * 1024.0);
        println!(
            "| {} | {:.1} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} |",
            file.file_name()
                .map(|n| n.to_string_lossy())
                .unwrap_or_default(),
            median(load_ms),
            mib(grid.memory_bytes() as f64),
            mib(openvdb_bytes as f64),
            grid.memory_bytes() as f64 / openvdb_bytes as f64,
            random_rate / 1e6,
            rays_rate / 1e6,
            coherent_rate / 1e6,
            accessor_rate / 1e6,
        );
    }
    Ok(())
}

/// Median over `repeats` of [`lookup_rate`], each repeat with a fresh lookup
/// from `fresh` (so cached state, such as an accessor's, starts cold). The
/// lookup type is generic: no dynamic call per lookup.
fn median_rate<F: FnMut(Vec3) -> f32>(
    repeats: usize,
    points: &[Vec3],
    mut fresh: impl FnMut() -> F,
) -> f64 {
    median((0..repeats).map(|_| lookup_rate(points, fresh())).collect())
}

/// Lookups per second of `lookup` over `points`, on this thread.
fn lookup_rate(points: &[Vec3], mut lookup: impl FnMut(Vec3) -> f32) -> f64 {
    let start = Instant::now();
    let mut sum = 0.0f32;
    for &p in points {
        sum += lookup(black_box(p));
    }
    black_box(sum);
    points.len() as f64 / start.elapsed().as_secs_f64()
}

/// Uniform random index-space points in the box [lo, hi].
fn random_points(lo: Vec3, hi: Vec3, n: usize) -> Vec<Vec3> {
    let mut rng = Pcg32::new(1, 0);
    (0..n)
        .map(|_| lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
        .collect()
}

/// Points a quarter voxel apart along straight rays through [lo, hi], as a ray
/// marcher visits them. Rays come in bundles of `tile` x `tile` parallel rays
/// half a voxel apart, marched one after another, as a tile renderer sends
/// neighbouring camera rays; `tile = 1` gives independent random rays.
fn ray_march_points(lo: Vec3, hi: Vec3, n: usize, tile: usize) -> Vec<Vec3> {
    let mut rng = Pcg32::new(2, 0);
    let mut points = Vec::with_capacity(n);
    while points.len() < n {
        let start = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let dir =
            (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize_or(Vec3::X);
        let (u, v) = dir.any_orthonormal_pair();
        for ray in 0..tile * tile {
            let mut p = start + (u * (ray % tile) as f32 + v * (ray / tile) as f32) * 0.5;
            for _ in 0..1024 {
                if points.len() == n || p.cmplt(lo).any() || p.cmpgt(hi).any() {
                    break;
                }
                points.push(p);
                p += dir * 0.25;
            }
        }
    }
    points
}
