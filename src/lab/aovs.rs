//! `cirrus bench aovs`: what the AOVs cost. Renders each scene at a fixed
//! sample count with the beauty alone and with the default AOV set
//! (alternating, several repeats), and writes each film as `render` does;
//! prints median sampling and write times, the overhead ratio and file sizes.

use std::path::PathBuf;
use std::time::Instant;

use glam::UVec2;

use super::machine::{machine_line, with_threads};
use super::scenes::{scene_name, scenes_or_default};
use super::stats::median;
use super::{LabError, Result};
use crate::film::AovSet;
use crate::film::FilterKind;
use crate::image::Compression;
use crate::integrator::{self, Budget, PathSettings, RenderSettings, Strategy, VolumeEstimator};
use crate::output::{write_film, AovFiles, ExrHeader};
use crate::render_state::{RenderState, StateOptions};
use crate::sampling::SamplerKind;

/// What to measure.
pub struct AovsBench {
    /// Scenes (USD or exported); none: [`DEFAULT_SCENES`].
    pub scenes: Vec<PathBuf>,
    /// Image size.
    pub resolution: UVec2,
    /// Samples per pixel of every render.
    pub spp: u32,
    /// Renders per AOV set; the table shows medians.
    pub repeats: u32,
    /// Worker threads.
    pub threads: usize,
    /// Folder for the written EXRs.
    pub out: PathBuf,
}

/// Default scenes, in `scenes/`: the smoke plume.
const DEFAULT_SCENES: [&str; 1] = ["bench/smoke.usda"];

/// Runs the benchmark on `bench.threads` workers and prints its table.
pub fn run(bench: &AovsBench) -> Result<()> {
    with_threads(bench.threads, || run_scenes(bench))
}

/// [`run`], on the worker pool.
fn run_scenes(bench: &AovsBench) -> Result<()> {
    println!("{}\n", machine_line());
    println!(
        "{}x{}, {} spp, {} repeats per set, zip compression; times are medians.\n",
        bench.resolution.x, bench.resolution.y, bench.spp, bench.repeats
    );
    println!("| scene | AOVs | channels | render s | vs beauty | write s | file MB |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    std::fs::create_dir_all(&bench.out).map_err(LabError::Os)?;
    for path in &scenes_or_default(bench.scenes.clone(), &DEFAULT_SCENES) {
        let scene = crate::scene::Scene::open(path, &Default::default())?;
        let state = RenderState::build(&scene, Some(bench.resolution), StateOptions::default())?;
        let sets = [AovSet::beauty_only(), AovSet::default()];
        let name = scene_name(path);
        let mut render_times = [Vec::new(), Vec::new()];
        let mut rows = Vec::new();
        for repeat in 0..bench.repeats.max(1) {
            // Alternate the order so drift in machine speed hits both alike.
            let order = if repeat % 2 == 0 { [0, 1] } else { [1, 0] };
            for i in order {
                let settings = settings(bench.spp, sets[i].clone());
                let (film, stats) = integrator::render(&state, &settings, &|_| {});
                render_times[i].push(stats.elapsed.as_secs_f64());
                if repeat == 0 {
                    let exr = bench
                        .out
                        .join(format!("{name}-{}.exr", ["beauty", "default"][i]));
                    let header = ExrHeader::new(&state, &settings).named(&state, &film);
                    let start = Instant::now();
                    write_film(
                        &exr,
                        AovFiles::Single,
                        &film,
                        &header,
                        &stats,
                        Compression::Zip,
                        &Default::default(),
                    )?;
                    let write = start.elapsed().as_secs_f64();
                    let bytes = std::fs::metadata(&exr).map_err(LabError::Os)?.len();
                    let channels: usize = 4 + sets[i]
                        .aovs()
                        .iter()
                        .map(|a| a.channels().len())
                        .sum::<usize>();
                    rows.push((i, channels, write, bytes));
                }
            }
        }
        let medians = render_times.map(median);
        rows.sort_by_key(|r| r.0);
        for (i, channels, write, bytes) in rows {
            println!(
                "| {name} | {} | {channels} | {:.3} | {:.3}x | {write:.3} | {:.2} |",
                ["beauty", "default"][i],
                medians[i],
                medians[i] / medians[0],
                bytes as f64 / 1e6
            );
        }
    }
    Ok(())
}

/// The render defaults at `spp` samples with `aovs` (MIS, Sobol, depth 16).
pub(super) fn settings(spp: u32, aovs: AovSet) -> RenderSettings {
    RenderSettings {
        budget: Budget::Samples(spp),
        seed: 0,
        sampler: SamplerKind::Sobol,
        filter: FilterKind::default(),
        path: PathSettings {
            strategy: Strategy::Mis,
            max_depth: 16,
            clamp: None,
            volume_estimator: VolumeEstimator::NullScatteringMis,
            equiangular: true,
            camera_ray_transmittance: false,
        },
        aovs,
        adaptive: None,
    }
}
