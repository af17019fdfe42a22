//! `cirrus bench ...`: benchmarks that print a Markdown table with the machine,
//! date and commit, so every number in the README can be rerun. Medians of
//! several repeats; never used by tests.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use clap::Subcommand;
use glam::Vec3;

use super::bench_equal_time::EqualTimeBench;
use cirrus::sampling::Pcg32;
use cirrus::volumes::VdbFile;

#[derive(Subcommand, Debug)]
pub enum Bench {
    /// AOV cost (issue 6): render time with the default AOV set against the
    /// beauty alone, EXR write time and file size.
    Aovs {
        /// Scenes (USD or exported); default: the StandardShaderBall and
        /// scenes/bench/smoke.usda.
        scenes: Vec<PathBuf>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "640x360", value_parser = super::render::parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of every render.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Renders per AOV set; the table shows medians.
        #[arg(long, default_value_t = 5)]
        repeats: u32,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Folder for the written EXRs.
        #[arg(long, default_value = "out/bench-aovs")]
        out: PathBuf,
    },
    /// Sparse grid layout: load time, memory next to OpenVDB's own tree, and
    /// single-thread trilinear lookups per second (random points, independent
    /// ray marches, and tiles of neighbouring ray marches).
    Vdb {
        /// VDB files to measure.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Float grid to read from each file.
        #[arg(long, default_value = "density")]
        grid: String,
        /// Timed repeats; the table shows medians.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Lookups per timed repeat.
        #[arg(long, default_value_t = 4_000_000)]
        lookups: usize,
    },
    /// Instancing ingest (issue 3): export, load and BVH build time and
    /// memory of a PointInstancer stage, beyond a 1-instance baseline.
    Instances {
        /// PointInstancer instances in the measured stage.
        #[arg(long, default_value_t = 1_000_000)]
        instances: usize,
        /// Approximate triangles of the prototype sphere.
        #[arg(long, default_value_t = 100_000)]
        triangles: usize,
        /// Timed repeats of load and build; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
    /// Rendering core (issue 4): camera-ray, path-ray and sample rates, and
    /// the equal-time MSE of BSDF-only, NEE-only and MIS with Sobol and
    /// independent samples against a high-spp reference (table + SVG chart).
    Render {
        /// Scenes (USD or exported); default: the StandardShaderBall and the
        /// intent-vfx layout from ../shared/assets.
        scenes: Vec<PathBuf>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "160x120", value_parser = super::render::parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of the MIS + Sobol reference.
        #[arg(long, default_value_t = 4096)]
        reference_spp: u32,
        /// Equal-time budgets in seconds.
        #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,4,8")]
        times: Vec<f64>,
        /// Seeds per measurement; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: u32,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Folder for the reference EXRs and the charts.
        #[arg(long, default_value = "out/bench-render")]
        out: PathBuf,
    },
    /// Participating media: density lookups per camera ray, null-collision
    /// share, majorant violations and the equal-time relative MSE against a
    /// long reference, for the grid and global majorants with every volume
    /// estimator, and their global / grid ratios (table + SVG chart).
    Volumes {
        /// Scenes (USD or exported); default: the teapot cloud and smoke.vdb
        /// of scenes/bench.
        scenes: Vec<PathBuf>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "160x120", value_parser = super::render::parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of the reference (null-scattering MIS, grid majorant).
        #[arg(long, default_value_t = 1024)]
        reference_spp: u32,
        /// Equal-time budgets in seconds.
        #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,4")]
        times: Vec<f64>,
        /// Seeds per measurement; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: u32,
        /// Smoke check in under a minute: budgets 0.1,0.2 s, one seed, a
        /// 32-spp reference (numbers are noisy).
        #[arg(long, conflicts_with_all = ["reference_spp", "times", "repeats"])]
        quick: bool,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Folder for the reference EXRs and the charts.
        #[arg(long, default_value = "out/bench-volumes")]
        out: PathBuf,
        /// Also write each chart as DIR/volumes-<scene>-equal-time.svg (the
        /// README's charts live in docs/bench).
        #[arg(long, value_name = "DIR")]
        charts: Option<PathBuf>,
    },
    /// Emitting volumes as lights: the equal-time relative MSE against a
    /// long reference with `--volume-light-sampling` on and off, time per
    /// sample and density lookups per camera ray (table + SVG chart).
    Fire {
        /// Scenes (USD or exported); default: scenes/bench/fire_lit.usda
        /// and scenes/bench/canyon_fire.usda (docs/benchmarks.md says how to
        /// write the VDB and the canyon they read).
        scenes: Vec<PathBuf>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "160x90", value_parser = super::render::parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of the reference (light sampling on).
        #[arg(long, default_value_t = 4096)]
        reference_spp: u32,
        /// Equal-time budgets in seconds.
        #[arg(long, value_delimiter = ',', default_value = "5,10,20,30")]
        times: Vec<f64>,
        /// Seeds per measurement; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: u32,
        /// Smoke check in about a minute: budgets 0.2,0.5 s, one seed, a
        /// 64-spp reference (numbers are noisy).
        #[arg(long, conflicts_with_all = ["reference_spp", "times", "repeats"])]
        quick: bool,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Folder for the reference EXRs and the charts.
        #[arg(long, default_value = "out/bench-fire")]
        out: PathBuf,
        /// Also write each chart as DIR/fire-<scene>-equal-time.svg.
        #[arg(long, value_name = "DIR")]
        charts: Option<PathBuf>,
    },
    /// Internal to `bench instances`: loads one exported scene and builds its
    /// BVHs in this fresh process, and prints the resident bytes added.
    #[command(hide = true)]
    InstancesMemory {
        /// The exported scene folder.
        scene: PathBuf,
    },
}

pub fn run(bench: Bench) -> Result<()> {
    match bench {
        Bench::Aovs {
            scenes,
            res,
            spp,
            repeats,
            threads,
            out,
        } => {
            let scenes = scenes_or_default(scenes, super::bench_aovs::default_scenes);
            let bench = super::bench_aovs::AovsBench {
                scenes,
                resolution: res,
                spp,
                repeats,
                out,
            };
            with_threads(threads, || super::bench_aovs::run(&bench))
        }
        Bench::Vdb {
            files,
            grid,
            repeats,
            lookups,
        } => vdb(&files, &grid, repeats.max(1), lookups.max(1)),
        Bench::Instances {
            instances,
            triangles,
            repeats,
        } => super::bench_instances::run(instances.max(1), triangles.max(8), repeats.max(1)),
        Bench::Render {
            scenes,
            res,
            reference_spp,
            times,
            repeats,
            threads,
            out,
        } => {
            let scenes = scenes_or_default(scenes, super::bench_render::default_scenes);
            let bench = super::bench_equal_time::EqualTimeBench {
                scenes,
                resolution: res,
                reference_spp,
                times,
                repeats,
                out,
            };
            with_threads(threads, || super::bench_render::run(&bench))
        }
        Bench::Volumes {
            scenes,
            res,
            reference_spp,
            times,
            repeats,
            quick,
            threads,
            out,
            charts,
        } => {
            let scenes = scenes_or_default(scenes, super::bench_volumes::default_scenes);
            let quick = quick.then(|| (32, vec![0.1, 0.2], 1));
            let bench =
                EqualTimeBench::new(scenes, res, (reference_spp, times, repeats), quick, out);
            with_threads(threads, || {
                super::bench_volumes::run(&bench, charts.as_deref())
            })
        }
        Bench::Fire {
            scenes,
            res,
            reference_spp,
            times,
            repeats,
            quick,
            threads,
            out,
            charts,
        } => {
            let scenes = scenes_or_default(scenes, super::bench_fire::default_scenes);
            let quick = quick.then(|| (64, vec![0.2, 0.5], 1));
            let bench =
                EqualTimeBench::new(scenes, res, (reference_spp, times, repeats), quick, out);
            with_threads(threads, || {
                super::bench_fire::run(&bench, charts.as_deref())
            })
        }
        Bench::InstancesMemory { scene } => super::bench_instances::print_memory(&scene),
    }
}

/// The scenes named on the command line, or the benchmark's defaults
/// (`default_scenes(repo root)`) when none are.
pub(super) fn scenes_or_default(
    scenes: Vec<PathBuf>,
    default_scenes: fn(&Path) -> Vec<PathBuf>,
) -> Vec<PathBuf> {
    if scenes.is_empty() {
        default_scenes(&cirrus::scene::repo_root())
    } else {
        scenes
    }
}

/// Runs `f` on a rayon pool of `threads` workers (at least one).
pub(super) fn with_threads(threads: usize, f: impl FnOnce() -> Result<()> + Send) -> Result<()> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()?
        .install(f)
}

fn vdb(files: &[PathBuf], grid_name: &str, repeats: usize, lookups: usize) -> Result<()> {
    println!("{}\n", machine_line());
    println!("| file | load (ms) | layout (MiB) | OpenVDB tree (MiB) | layout / OpenVDB | random (M/s) | independent rays (M/s) | ray tiles (M/s) | ray tiles, accessor (M/s) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for file in files {
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

/// The command-line name of an option value (`grid`, `null-scattering-mis`).
pub(super) fn value_name(value: impl clap::ValueEnum) -> String {
    value
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_owned())
}

pub(super) fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// "Machine: <cpu>, <cores> cores; <date>; commit <hash>" for benchmark headers.
pub(super) fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_owned())
        })
        .unwrap_or_else(|| "unknown CPU".to_owned());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let run = |cmd: &str, args: &[&str]| {
        std::process::Command::new(cmd)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
            .unwrap_or_else(|| "unknown".to_owned())
    };
    format!(
        "Machine: {cpu}, {cores} cores; date {}; commit {}",
        run("date", &["-u", "+%Y-%m-%d"]),
        run("git", &["rev-parse", "--short", "HEAD"])
    )
}
