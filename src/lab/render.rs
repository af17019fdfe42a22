//! `cirrus bench render`: the rendering-core benchmark. Per scene:
//! camera-ray and full-path ray rates and samples per second, then the
//! equal-time mean squared error of every estimator (BSDF-only, NEE-only,
//! MIS) with every sampler (Sobol, independent) against a high-spp MIS +
//! Sobol reference, as a Markdown table and an SVG chart of error against
//! time. References are kept in the output folder, named by scene,
//! resolution and spp: delete them after changing the renderer.

use glam::UVec2;

use super::chart::{write_chart, TIME_AXIS};
use super::equal_time::{
    ladder, median_curve, median_errors, spp_per_second, EqualTimeBench, EqualTimeDefaults, Rung,
};
use super::machine::{machine_line, with_threads};
use super::markdown::{error_cells, print_error_header};
use super::metrics::ErrorMetric;
use super::reference::{base_settings, cached_reference, reference_key, render};
use super::scenes::scene_name;
use super::stats::median;
use super::Result;
use crate::file_error::FileError;
use crate::integrator::{
    Budget, PathSettings, RenderSettings, RenderStats, Strategy, DEFAULT_MAX_DEPTH,
};
use crate::render_state::{RenderState, StateOptions};
use crate::sampling::SamplerKind;

/// The estimator and sampler pairs compared at equal time.
const METHODS: [(Strategy, SamplerKind); 6] = [
    (Strategy::Bsdf, SamplerKind::Independent),
    (Strategy::Bsdf, SamplerKind::Sobol),
    (Strategy::Nee, SamplerKind::Independent),
    (Strategy::Nee, SamplerKind::Sobol),
    (Strategy::Mis, SamplerKind::Independent),
    (Strategy::Mis, SamplerKind::Sobol),
];

/// `bench render`'s (and `--adaptive`'s) defaults.
pub const DEFAULTS: EqualTimeDefaults = EqualTimeDefaults {
    resolution: UVec2::new(160, 120),
    reference_spp: 4096,
    times: &[0.5, 1.0, 2.0, 4.0, 8.0],
    out: "out/bench-render",
    quick: None,
};

/// Runs the benchmark on `bench.threads` workers and prints its tables.
pub fn run(bench: &EqualTimeBench) -> Result<()> {
    with_threads(bench.threads, || run_scenes(bench))
}

/// [`run`], on the worker pool.
fn run_scenes(bench: &EqualTimeBench) -> Result<()> {
    std::fs::create_dir_all(&bench.out).map_err(|e| FileError::new("create", &bench.out, e))?;
    println!("{}\n", machine_line());
    println!(
        "Threads: {}; {}x{} pixels; max depth {DEFAULT_MAX_DEPTH}; box filter; reference: MIS + Sobol at {} spp.\n",
        rayon::current_num_threads(),
        bench.resolution.x,
        bench.resolution.y,
        bench.reference_spp
    );
    for path in &bench.scenes {
        let scene = crate::scene::Scene::open(path, &Default::default())?;
        let state = RenderState::build(&scene, Some(bench.resolution), StateOptions::default())?;
        let name = scene_name(path);
        let key = reference_key(&scene, &name)?;
        drop(scene);
        println!("### {name}\n");
        throughput(&state, bench.repeats);
        let reference = cached_reference(&state, &bench.out, &key, bench.reference_spp)?;
        equal_time(&state, bench, &name, &reference)?;
    }
    Ok(())
}

/// Settings for one benchmark render: [`base_settings`] with this
/// estimator, sampler and path depth.
fn settings(
    budget: Budget,
    strategy: Strategy,
    sampler: SamplerKind,
    seed: u64,
    max_depth: u32,
) -> RenderSettings {
    let base = base_settings(budget, seed);
    RenderSettings {
        sampler,
        path: PathSettings {
            strategy,
            max_depth,
            ..base.path
        },
        ..base
    }
}

/// Camera rays per second (depth 0, no light sampling) and, for full MIS
/// paths, rays per second (closest-hit and shadow) and samples per second.
fn throughput(state: &RenderState, repeats: u32) {
    let rate = |max_depth: u32, strategy: Strategy, per: fn(&RenderStats) -> u64| {
        median(
            (0..repeats.max(1))
                .map(|seed| {
                    let s = settings(
                        Budget::Samples(4),
                        strategy,
                        SamplerKind::Sobol,
                        u64::from(seed),
                        max_depth,
                    );
                    let (_, stats) = render(state, &s);
                    per(&stats) as f64 / stats.elapsed.as_secs_f64()
                })
                .collect(),
        )
    };
    let primary = rate(0, Strategy::Bsdf, |s| s.rays.camera);
    let rays = rate(DEFAULT_MAX_DEPTH, Strategy::Mis, |s| {
        s.rays.closest + s.rays.shadow
    });
    let samples = rate(DEFAULT_MAX_DEPTH, Strategy::Mis, |s| s.rays.camera);
    println!("| camera rays (M/s) | path rays, closest + shadow (M/s) | samples (M/s) | rays per sample |");
    println!("|---:|---:|---:|---:|");
    println!(
        "| {:.2} | {:.2} | {:.3} | {:.2} |\n",
        primary / 1e6,
        rays / 1e6,
        samples / 1e6,
        rays / samples
    );
}

/// The equal-time table and chart: every method renders at 1, 2, 4, ... spp
/// (per seed) until one render exceeds the largest budget; its MSE at each
/// budget is interpolated log-log between the renders around it.
fn equal_time(
    state: &RenderState,
    bench: &EqualTimeBench,
    name: &str,
    reference: &[f32],
) -> Result<()> {
    let max_time = bench.max_time();
    let pixels = f64::from(state.resolution.x) * f64::from(state.resolution.y);
    let leading = ("| estimator | sampler | samples/s (M) |", "|---|---|---:|");
    print_error_header(leading, ErrorMetric::Mse, &bench.times);
    let mut curves = Vec::new();
    let mut at_times = Vec::new();
    for (strategy, sampler) in METHODS {
        let s = settings(Budget::Samples(1), strategy, sampler, 0, DEFAULT_MAX_DEPTH);
        let runs: Vec<Vec<Rung>> = (0..bench.repeats.max(1))
            .map(|seed| {
                let s = RenderSettings {
                    seed: u64::from(seed),
                    ..s.clone()
                };
                ladder(state, reference, ErrorMetric::Mse, &s, max_time)
            })
            .collect();
        let errors = median_errors(&runs, &bench.times);
        let rate = median(runs.iter().map(|l| pixels * spp_per_second(l)).collect());
        println!(
            "| {strategy:?} | {sampler:?} | {:.3} |{}",
            rate / 1e6,
            error_cells(&errors)
        );
        curves.push((format!("{strategy:?} + {sampler:?}"), median_curve(&runs)));
        at_times.push(errors);
    }
    let ratios: Vec<String> = at_times[4]
        .iter()
        .zip(&at_times[5])
        .map(|(independent, sobol)| format!("{:.2}", independent / sobol))
        .collect();
    println!(
        "\nEqual-time MSE ratio, MIS + independent / MIS + Sobol, at {:?} s: {}",
        bench.times,
        ratios.join(", ")
    );
    let chart = bench.out.join(format!("{name}-equal-time.svg"));
    write_chart(&chart, name, &TIME_AXIS, ErrorMetric::Mse, &curves)?;
    println!("Chart: {}\n", chart.display());
    Ok(())
}
