//! `cirrus bench volumes`: the participating-media benchmark. Per scene
//! (default: the teapot cloud and smoke.vdb of `scenes/bench`), every
//! majorant (grid, global) with every volume estimator renders 1, 2, 4, ...
//! spp per seed; the table gives the spp reached at the largest time budget,
//! density lookups per camera ray, the share of null collisions, majorant
//! violations, and the equal-time relative MSE against a long reference
//! (median over seeds), then the global / grid ratios against the targets:
//! at least 3x fewer lookups and 2x lower relMSE with the grid, and
//! under 50% null collisions. References are kept in the output folder,
//! named by scene, resolution and spp: delete them after changing the
//! renderer.

use std::path::Path;

use crate::choice::Choice;

use glam::UVec2;

use super::equal_time::{
    ladder, median_curve, median_errors, spp_per_second, write_scene_charts, EqualTimeBench,
    EqualTimeDefaults, Rung,
};
use super::markdown::{error_cells, error_columns, print_error_header};
use super::metrics::ErrorMetric;
use super::reference::{base_settings, cached_reference, reference_key};
use super::scenes::scene_name;
use super::stats::median;
use super::Result;
use crate::integrator::{Budget, PathSettings, RenderSettings, VolumeEstimator};
use crate::render_state::{RenderState, StateOptions};
use crate::scene::Scene;
use crate::volumes::estimators::TrackingStats;
use crate::volumes::grid::VdbFile;
use crate::volumes::majorant::MajorantKind;

/// The targets: global / grid density lookups per camera ray at
/// least this, ...
const LOOKUP_RATIO_TARGET: f64 = 3.0;
/// ... global / grid equal-time relMSE at the largest budget at least this, ...
const ERROR_RATIO_TARGET: f64 = 2.0;
/// ... and null collisions under this share of all collisions (grid).
const NULL_SHARE_TARGET: f64 = 0.5;

/// One (majorant, estimator) pair's measurements on one scene.
struct Measurement {
    majorant: MajorantKind,
    estimator: VolumeEstimator,
    /// Equiangular sampling of lights in media (off only in the
    /// extra row of scenes that have such lights).
    equiangular: bool,
    /// relMSE per time budget, median over seeds.
    errors: Vec<f64>,
    /// Samples per pixel reached at the largest budget (median over seeds).
    spp: f64,
    /// Media counters summed over every render of every seed.
    tracking: TrackingStats,
    /// Camera rays of those same renders.
    camera_rays: u64,
    /// (seconds, relMSE) of the median seed's renders, for the chart.
    curve: Vec<(f64, f64)>,
}

impl Measurement {
    /// The estimator's name, marked when equiangular sampling is off.
    fn method(&self) -> String {
        let name = self.estimator.to_string();
        if self.equiangular {
            name
        } else {
            format!("{name}, no equiangular")
        }
    }

    fn lookups_per_camera_ray(&self) -> f64 {
        self.tracking.density_lookups as f64 / self.camera_rays.max(1) as f64
    }

    fn null_share(&self) -> f64 {
        let t = &self.tracking;
        t.null_collisions as f64 / (t.null_collisions + t.real_collisions).max(1) as f64
    }
}

/// Default scenes, in `scenes/`: the teapot cloud and the smoke plume.
const DEFAULT_SCENES: [&str; 2] = ["bench/teapot_cloud.usda", "bench/smoke.usda"];

/// `bench volumes`' defaults; `--quick` is a smoke check in under a minute
/// (numbers are noisy).
pub const DEFAULTS: EqualTimeDefaults = EqualTimeDefaults {
    resolution: UVec2::new(160, 120),
    reference_spp: 1024,
    times: &[0.5, 1.0, 2.0, 4.0],
    out: "out/bench-volumes",
    quick: Some((32, &[0.1, 0.2], 1)),
};

/// Runs the benchmark and prints its tables (on [`DEFAULT_SCENES`] when
/// `bench.scenes` is empty); each chart also goes to `bench.charts` as
/// `volumes-<scene>-equal-time.svg`, when given.
pub fn run(bench: &EqualTimeBench) -> Result<()> {
    bench.run(
        "null-scattering MIS, grid majorant",
        &DEFAULT_SCENES,
        |path| measure_scene(bench, path),
    )
}

/// One scene's tables and chart.
fn measure_scene(bench: &EqualTimeBench, path: &Path) -> Result<()> {
    let scene = crate::scene::Scene::open(path, &Default::default())?;
    let name = scene_name(path);
    println!("### {name}\n");
    print_extinction(&scene)?;
    let grid = RenderState::build(&scene, Some(bench.resolution), StateOptions::default())?;
    let global = RenderState::build(
        &scene,
        Some(bench.resolution),
        StateOptions::global_majorant(),
    )?;
    let key = reference_key(&scene, &name)?;
    drop(scene);
    let reference = cached_reference(&grid, &bench.out, &key, bench.reference_spp)?;
    let mut measurements = Vec::new();
    for (majorant, state) in [(MajorantKind::Grid, &grid), (MajorantKind::Global, &global)] {
        for &(estimator, _) in VolumeEstimator::NAMES {
            let method = (estimator, true);
            measurements.push(measure(state, bench, &reference, majorant, method));
        }
    }
    // Where equiangular sampling has lights to target, what it buys.
    if grid.lights.has_equiangular_target() {
        let method = (VolumeEstimator::NullScatteringMis, false);
        measurements.push(measure(
            &grid,
            bench,
            &reference,
            MajorantKind::Grid,
            method,
        ));
    }
    print_measurements(bench, &measurements);
    print_ratios(bench, &measurements);
    write_scene_charts(bench, ("volumes", &name), &curves(&measurements))?;
    Ok(())
}

/// Settings for one benchmark render: [`base_settings`] with this volume
/// estimator, with or without equiangular sampling.
fn settings(
    budget: Budget,
    (volume_estimator, equiangular): (VolumeEstimator, bool),
    seed: u64,
) -> RenderSettings {
    let base = base_settings(budget, seed);
    RenderSettings {
        path: PathSettings {
            volume_estimator,
            equiangular,
            ..base.path
        },
        ..base
    }
}

/// Ladders of one (majorant, estimator) pair, one per seed, summarised.
fn measure(
    state: &RenderState,
    bench: &EqualTimeBench,
    reference: &[f32],
    majorant: MajorantKind,
    (estimator, equiangular): (VolumeEstimator, bool),
) -> Measurement {
    let max_time = bench.max_time();
    let ladders: Vec<Vec<Rung>> = (0..bench.repeats.max(1))
        .map(|seed| {
            let s = settings(
                Budget::Samples(1),
                (estimator, equiangular),
                u64::from(seed),
            );
            ladder(state, reference, ErrorMetric::RelMse, &s, max_time)
        })
        .collect();
    let mut tracking = TrackingStats::default();
    let mut camera_rays = 0;
    for rung in ladders.iter().flatten() {
        tracking.merge(&rung.stats.tracking);
        camera_rays += rung.stats.rays.camera;
    }
    Measurement {
        majorant,
        estimator,
        equiangular,
        errors: median_errors(&ladders, &bench.times),
        spp: median(
            ladders
                .iter()
                .map(|l| spp_per_second(l) * max_time)
                .collect(),
        ),
        tracking,
        camera_rays,
        curve: median_curve(&ladders),
    }
}

/// One line per volume: its largest sigma_t per world unit (densityScale x
/// the density grid's largest value).
fn print_extinction(scene: &Scene) -> Result<()> {
    for volume in &scene.manifest.volumes {
        let Some(field) = volume.fields.get("density") else {
            continue;
        };
        let grid =
            VdbFile::open(&field.file)?.read_float_grid(&field.grid, field.index as usize)?;
        let max_density = grid.stats().max_value;
        println!(
            "{}: densityScale {:?} x max density {max_density:.3} = max sigma_t {:.2} per world unit.",
            volume.path,
            volume.density_scale,
            volume.density_scale.into_iter().fold(0.0, f32::max) * max_density
        );
    }
    println!();
    Ok(())
}

/// The per-method table.
fn print_measurements(bench: &EqualTimeBench, measurements: &[Measurement]) {
    let max_time = bench.max_time();
    let header = format!(
        "| majorant | estimator | spp @ {max_time} s | lookups / camera ray | null / all collisions | violations |"
    );
    let rule = "|---|---|---:|---:|---:|---:|";
    print_error_header((&header, rule), ErrorMetric::RelMse, &bench.times);
    for m in measurements {
        println!(
            "| {} | {} | {:.1} | {:.1} | {:.1}% | {} |{}",
            m.majorant,
            m.method(),
            m.spp,
            m.lookups_per_camera_ray(),
            100.0 * m.null_share(),
            m.tracking.majorant_violations,
            error_cells(&m.errors)
        );
    }
    println!();
}

/// The global / grid ratios per estimator, and whether the targets hold.
fn print_ratios(bench: &EqualTimeBench, measurements: &[Measurement]) {
    let max_time = bench.max_time();
    let (errors_header, errors_rule) = error_columns(ErrorMetric::RelMse, &bench.times);
    println!(
        "| estimator | lookups, global / grid |{} null share (grid) | targets (>= {LOOKUP_RATIO_TARGET}x lookups, >= {ERROR_RATIO_TARGET}x relMSE @ {max_time} s, < {:.0}% null) |\n|---|---:|{errors_rule}---:|---|",
        errors_header.replace(" relMSE", " relMSE global / grid"),
        100.0 * NULL_SHARE_TARGET
    );
    for &(estimator, _) in VolumeEstimator::NAMES {
        let find = |majorant| {
            measurements
                .iter()
                .find(|m| m.majorant == majorant && m.estimator == estimator && m.equiangular)
                .expect("every majorant and estimator is measured")
        };
        let (grid, global) = (find(MajorantKind::Grid), find(MajorantKind::Global));
        let lookups = global.lookups_per_camera_ray() / grid.lookups_per_camera_ray();
        let errors: Vec<f64> = global
            .errors
            .iter()
            .zip(&grid.errors)
            .map(|(a, b)| a / b)
            .collect();
        let last_error = errors.last().copied().unwrap_or(f64::NAN);
        let mark = |met: bool| if met { "met" } else { "MISSED" };
        println!(
            "| {} | {lookups:.2} |{} {:.1}% | lookups {}, relMSE {}, null {} |",
            estimator,
            errors
                .iter()
                .map(|r| format!(" {r:.2} |"))
                .collect::<String>(),
            100.0 * grid.null_share(),
            mark(lookups >= LOOKUP_RATIO_TARGET),
            mark(last_error >= ERROR_RATIO_TARGET),
            mark(grid.null_share() < NULL_SHARE_TARGET),
        );
    }
    println!();
}

/// The chart curves of one scene's measurements.
fn curves(measurements: &[Measurement]) -> Vec<(String, Vec<(f64, f64)>)> {
    measurements
        .iter()
        .map(|m| (format!("{} + {}", m.majorant, m.method()), m.curve.clone()))
        .collect()
}
