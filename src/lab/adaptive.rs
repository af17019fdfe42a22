//! `cirrus bench render --adaptive`: the time adaptive sampling (`--noise-threshold`)
//! takes to reach the relMSE that uniform sampling reaches at each budget.
//! Per scene and seed, uniform renders at 1, 2, 4, ... spp and adaptive
//! renders at thresholds 0.5, 0.25, 0.125, ... (automatic minimum, capped at
//! four times the most samples the uniform ladder took) each give (time,
//! relMSE) points; the adaptive time at the uniform error is interpolated
//! log-log between the adaptive renders around it.

use std::path::Path;

use super::equal_time::{error_at_time, ladder, median_errors, EqualTimeBench, Rung};
use super::metrics::ErrorMetric;
use super::reference::{base_settings, cached_reference, reference_key, render};
use super::scenes::scene_name;
use super::stats::median;
use super::Result;
use crate::film::AdaptiveSampling;
use crate::integrator::{Budget, RenderSettings};
use crate::render_state::{RenderState, StateOptions};

/// The first threshold of the adaptive ladder; each next one is half.
const FIRST_THRESHOLD: f32 = 0.5;
/// The smallest threshold tried.
const LAST_THRESHOLD: f32 = 1e-4;

/// Runs the benchmark on `bench.threads` workers and prints its tables.
pub fn run(bench: &EqualTimeBench) -> Result<()> {
    bench.run("uniform MIS + Sobol", &[], |path| study(bench, path))
}

/// One scene: the uniform and adaptive ladders per seed, then the table.
fn study(bench: &EqualTimeBench, path: &Path) -> Result<()> {
    let scene = crate::scene::Scene::open(path, &Default::default())?;
    let state = RenderState::build(&scene, Some(bench.resolution), StateOptions::default())?;
    let name = scene_name(path);
    let key = reference_key(&scene, &name)?;
    drop(scene);
    let reference = cached_reference(&state, &bench.out, &key, bench.reference_spp)?;
    let max_time = bench.max_time();
    let seeds = 0..u64::from(bench.repeats.max(1));
    let metric = ErrorMetric::RelMse;
    let uniform: Vec<Vec<Rung>> = seeds
        .clone()
        .map(|seed| {
            let settings = base_settings(Budget::Samples(1), seed);
            ladder(&state, &reference, metric, &settings, max_time)
        })
        .collect();
    let most = uniform
        .iter()
        .flatten()
        .map(|r| r.stats.samples_per_pixel)
        .max()
        .unwrap_or(1);
    let cap = 4 * most;
    let adaptive: Vec<Vec<(f32, Rung)>> = seeds
        .map(|seed| {
            thresholds(
                &state,
                &reference,
                base_settings(Budget::Samples(cap), seed),
                max_time,
            )
        })
        .collect();
    println!("### {name}\n");
    println!("Adaptive: automatic --min-spp, --spp {cap}. Seed 0's renders:\n");
    println!("| --noise-threshold | seconds | relMSE |\n|---:|---:|---:|");
    for (threshold, rung) in &adaptive[0] {
        println!(
            "| {threshold} | {:.2} | {:.3e} |",
            rung.seconds(),
            rung.error
        );
    }
    println!("\n| uniform seconds | uniform relMSE | adaptive seconds to that relMSE | speed-up |\n|---:|---:|---:|---:|");
    let targets = median_errors(&uniform, &bench.times);
    for (t, target) in bench.times.iter().zip(targets) {
        let seconds = median(
            adaptive
                .iter()
                .map(|rungs| seconds_to(rungs, target))
                .collect(),
        );
        println!(
            "| {t} | {target:.3e} | {seconds:.2} | **{:.2}x** |",
            t / seconds
        );
    }
    println!();
    Ok(())
}

/// Adaptive renders with `settings` at halving thresholds, each a separate
/// render, up to the first that takes longer than `max_seconds`.
fn thresholds(
    state: &RenderState,
    reference: &[f32],
    settings: RenderSettings,
    max_seconds: f64,
) -> Vec<(f32, Rung)> {
    let mut rungs = Vec::new();
    let mut threshold = FIRST_THRESHOLD;
    while threshold >= LAST_THRESHOLD {
        let s = RenderSettings {
            adaptive: Some(AdaptiveSampling::new(threshold, None)),
            ..settings.clone()
        };
        let (rgb, stats) = render(state, &s);
        let rung = Rung {
            error: ErrorMetric::RelMse.error(&rgb, reference),
            stats,
        };
        let seconds = rung.seconds();
        rungs.push((threshold, rung));
        if seconds > max_seconds {
            break;
        }
        threshold /= 2.0;
    }
    rungs
}

/// The seconds the renders `rungs` take to reach `error`: log time
/// interpolated linearly in log error between the two renders around it
/// (extrapolated from the end segments).
fn seconds_to(rungs: &[(f32, Rung)], error: f64) -> f64 {
    let mut points: Vec<(f64, f64)> = rungs.iter().map(|(_, r)| (r.error, r.seconds())).collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    error_at_time(&points, error)
}
