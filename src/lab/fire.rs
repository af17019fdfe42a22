//! `cirrus bench fire`: emitting volumes as lights. Per scene (default: the
//! flame column of `scenes/bench/fire_lit.usda` and the quick-start
//! canyon framed on its fireball, `scenes/bench/canyon_fire.usda`), renders
//! with `--volume-light-sampling` on and off at 1, 2, 4, ... spp per seed;
//! the table gives the spp reached at the largest time budget, the time
//! per sample per pixel, density lookups per camera ray and the equal-time
//! relative MSE against a long reference (light sampling on; both ways are
//! unbiased), then the off / on ratio at each budget. References are kept
//! in the output folder, keyed by the exported scene's contents.
//!
//! The reference's own noise adds its variance to every measured error (the
//! measured image and the reference are independent): a floor under both
//! methods that compresses their ratio as the budgets grow. A second,
//! independent reference at 1/16 of the spp estimates it: the relMSE
//! between the two is the first's noise times 1 + 16 (its variance and the
//! second's, 16 times larger), and the table's last row gives the off / on
//! ratio of the errors less that floor.

use std::path::Path;

use glam::UVec2;

use super::equal_time::{
    ladder, median_curve, median_errors, spp_per_second, write_scene_charts, EqualTimeBench,
    EqualTimeDefaults, Rung,
};
use super::markdown::{error_cells, print_error_header};
use super::metrics::ErrorMetric;
use super::reference::{
    base_settings, cached_reference, reference, reference_key, reference_path, REFERENCE_SEED,
};
use super::scenes::scene_name;
use super::stats::median;
use super::{LabError, Result};
use crate::integrator::Budget;
use crate::render_state::{RenderState, StateOptions};

/// One way of rendering one scene, measured.
struct Measurement {
    /// `--volume-light-sampling`.
    light_sampling: bool,
    /// relMSE per time budget, median over seeds.
    errors: Vec<f64>,
    /// Samples per pixel per second at the largest budget (median over seeds).
    spp_per_second: f64,
    /// Density lookups per camera ray over every render of every seed.
    lookups_per_camera_ray: f64,
    /// (seconds, relMSE) of the median seed's renders, for the chart.
    curve: Vec<(f64, f64)>,
}

impl Measurement {
    fn name(&self) -> &'static str {
        if self.light_sampling {
            "light sampling on"
        } else {
            "light sampling off"
        }
    }
}

/// Default scenes, in `scenes/`: the flame column and the canyon's fire
/// (docs/benchmarks.md says how to write the VDB and the canyon they read).
const DEFAULT_SCENES: [&str; 2] = ["bench/fire_lit.usda", "bench/canyon_fire.usda"];

/// `bench fire`'s defaults; `--quick` is a smoke check in about a minute
/// (numbers are noisy).
pub const DEFAULTS: EqualTimeDefaults = EqualTimeDefaults {
    resolution: UVec2::new(160, 90),
    reference_spp: 4096,
    times: &[5.0, 10.0, 20.0, 30.0],
    out: "out/bench-fire",
    quick: Some((64, &[0.2, 0.5], 1)),
};

/// Runs the benchmark and prints its tables (on [`DEFAULT_SCENES`] when
/// `bench.scenes` is empty); each chart also goes to `bench.charts` as
/// `fire-<scene>-equal-time.svg`, when given.
pub fn run(bench: &EqualTimeBench) -> Result<()> {
    bench.run("light sampling on", &DEFAULT_SCENES, |path| {
        measure_scene(bench, path)
    })
}

/// One scene's tables and chart.
fn measure_scene(bench: &EqualTimeBench, path: &Path) -> Result<()> {
    let scene = crate::scene::Scene::open(path, &Default::default())?;
    let name = scene_name(path);
    let build = |volume_lights| {
        let options = StateOptions {
            volume_lights,
            ..StateOptions::default()
        };
        RenderState::build(&scene, Some(bench.resolution), options)
    };
    let (on, off) = (build(true)?, build(false)?);
    if !on.lights.has_volume_lights() {
        return Err(LabError::Failed(format!(
            "{}: no volume emits light (is its VDB missing? see docs/benchmarks.md for the \
             commands that write it)",
            path.display()
        )));
    }
    let key = reference_key(&scene, &name)?;
    drop(scene);
    println!("### {name}\n");
    let reference = cached_reference(&on, &bench.out, &key, bench.reference_spp)?;
    let floor = reference_noise(&on, bench, &key, &reference)?;
    let measurements = [
        measure(&on, true, bench, &reference),
        measure(&off, false, bench, &reference),
    ];
    print_measurements(bench, &measurements, floor);
    let curves: Vec<(String, Vec<(f64, f64)>)> = measurements
        .iter()
        .map(|m| (m.name().to_string(), m.curve.clone()))
        .collect();
    write_scene_charts(bench, ("fire", &name), &curves)?;
    Ok(())
}

/// The second reference's spp is the reference's over this.
const SECOND_REFERENCE_SHARE: u32 = 16;

/// The relMSE the reference's own noise adds to every error measured
/// against it, estimated from a second reference at 1/16 of its spp and
/// another seed (kept beside it; see the module doc).
fn reference_noise(
    state: &RenderState,
    bench: &EqualTimeBench,
    key: &str,
    reference_rgb: &[f32],
) -> Result<f64> {
    let spp = (bench.reference_spp / SECOND_REFERENCE_SHARE).max(1);
    let path = reference_path(&bench.out, &format!("{key}-second"), state.resolution, spp);
    let settings = base_settings(Budget::Samples(spp), REFERENCE_SEED + 1);
    let second = reference(state, &settings, &path)?;
    let ratio = f64::from(bench.reference_spp) / f64::from(spp);
    Ok(ErrorMetric::RelMse.error(&second, reference_rgb) / (1.0 + ratio))
}

/// Ladders of one way of rendering, one per seed, summarised.
fn measure(
    state: &RenderState,
    light_sampling: bool,
    bench: &EqualTimeBench,
    reference: &[f32],
) -> Measurement {
    let max_time = bench.max_time();
    let ladders: Vec<Vec<Rung>> = (0..bench.repeats.max(1))
        .map(|seed| {
            let settings = base_settings(Budget::Samples(1), u64::from(seed));
            ladder(state, reference, ErrorMetric::RelMse, &settings, max_time)
        })
        .collect();
    let (lookups, camera_rays) = ladders.iter().flatten().fold((0u64, 0u64), |(l, c), r| {
        (
            l + r.stats.tracking.density_lookups,
            c + r.stats.rays.camera,
        )
    });
    Measurement {
        light_sampling,
        errors: median_errors(&ladders, &bench.times),
        spp_per_second: median(ladders.iter().map(|l| spp_per_second(l)).collect()),
        lookups_per_camera_ray: lookups as f64 / camera_rays.max(1) as f64,
        curve: median_curve(&ladders),
    }
}

/// The per-method table, then the off / on relMSE ratios (with the cost of
/// a sample, on / off), then those ratios with the reference's noise
/// `floor` taken off both errors ("-" where an error is not above it).
fn print_measurements(bench: &EqualTimeBench, measurements: &[Measurement; 2], floor: f64) {
    let max_time = bench.max_time();
    let header = format!("| method | spp @ {max_time} s | ms per spp | lookups / camera ray |");
    print_error_header(
        (&header, "|---|---:|---:|---:|"),
        ErrorMetric::RelMse,
        &bench.times,
    );
    for m in measurements {
        println!(
            "| {} | {:.1} | {:.1} | {:.1} |{}",
            m.name(),
            m.spp_per_second * max_time,
            1000.0 / m.spp_per_second,
            m.lookups_per_camera_ray,
            error_cells(&m.errors)
        );
    }
    let [on, off] = measurements;
    let ratios: String = off
        .errors
        .iter()
        .zip(&on.errors)
        .map(|(a, b)| format!(" {:.2}x |", a / b))
        .collect();
    println!(
        "| relMSE off / on (ms per spp on / off) | | {:.2}x | |{ratios}",
        off.spp_per_second / on.spp_per_second
    );
    let above: String = off
        .errors
        .iter()
        .zip(&on.errors)
        .map(|(a, b)| match (a - floor, b - floor) {
            (a, b) if a > 0.0 && b > 0.0 => format!(" {:.2}x |", a / b),
            _ => " - |".to_string(),
        })
        .collect();
    println!("| the same less the reference's noise ({floor:.2e}) | | | |{above}\n");
}
