//! `cirrus bench render`: the rendering-core benchmark of issue 4. Per scene:
//! camera-ray and full-path ray rates and samples per second, then the
//! equal-time mean squared error of every estimator (BSDF-only, NEE-only,
//! MIS) with every sampler (Sobol, independent) against a high-spp MIS +
//! Sobol reference, as a Markdown table and an SVG chart of error against
//! time. References are kept in the output folder, named by scene,
//! resolution and spp: delete them after changing the renderer.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::UVec2;

use super::bench::{machine_line, median};
use crate::integrator::{self, Budget, PathSettings, RenderSettings, RenderStats, Strategy};
use crate::output::filter::FilterKind;
use crate::output::{read_image, Compression};
use crate::render_state::RenderState;
use crate::sampling::SamplerKind;
use crate::volumes::{MajorantKind, TransmittanceEstimator};

/// The estimator and sampler pairs compared at equal time.
const METHODS: [(Strategy, SamplerKind); 6] = [
    (Strategy::Bsdf, SamplerKind::Independent),
    (Strategy::Bsdf, SamplerKind::Sobol),
    (Strategy::Nee, SamplerKind::Independent),
    (Strategy::Nee, SamplerKind::Sobol),
    (Strategy::Mis, SamplerKind::Independent),
    (Strategy::Mis, SamplerKind::Sobol),
];

/// Path depth used throughout the benchmark (the CLI's default).
const MAX_DEPTH: u32 = 16;

/// What to measure.
pub struct RenderBench {
    /// Scenes (USD or exported).
    pub scenes: Vec<PathBuf>,
    /// Image size.
    pub resolution: UVec2,
    /// Samples per pixel of the reference.
    pub reference_spp: u32,
    /// Equal-time budgets, seconds.
    pub times: Vec<f64>,
    /// Seeds per (method, time); the table shows the median error.
    pub repeats: u32,
    /// Folder for references and charts.
    pub out: PathBuf,
}

/// Runs the benchmark and prints its tables.
pub fn run(bench: &RenderBench) -> Result<()> {
    std::fs::create_dir_all(&bench.out)
        .with_context(|| format!("cannot create {}", bench.out.display()))?;
    println!("{}\n", machine_line());
    println!(
        "Threads: {}; {}x{} pixels; max depth {MAX_DEPTH}; box filter; reference: MIS + Sobol at {} spp.\n",
        rayon::current_num_threads(),
        bench.resolution.x,
        bench.resolution.y,
        bench.reference_spp
    );
    for path in &bench.scenes {
        let scene = super::load_scene(path, None)?;
        let state = RenderState::build(&scene, Some(bench.resolution), MajorantKind::Grid)?;
        drop(scene);
        let name = path
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        println!("### {name}\n");
        throughput(&state, bench.repeats);
        let reference = reference(&state, bench, &name)?;
        equal_time(&state, bench, &name, &reference)?;
    }
    Ok(())
}

/// Settings for one benchmark render.
fn settings(
    budget: Budget,
    strategy: Strategy,
    sampler: SamplerKind,
    seed: u64,
    max_depth: u32,
) -> RenderSettings {
    RenderSettings {
        budget,
        seed,
        sampler,
        filter: FilterKind::Box,
        path: PathSettings {
            strategy,
            max_depth,
            clamp: None,
            transmittance: TransmittanceEstimator::Ratio,
        },
    }
}

fn render(state: &RenderState, s: &RenderSettings) -> (Vec<f32>, RenderStats) {
    let (film, stats) = integrator::render(state, s, &|_| {});
    (film.rgb(), stats)
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
    let rays = rate(MAX_DEPTH, Strategy::Mis, |s| s.rays.closest + s.rays.shadow);
    let samples = rate(MAX_DEPTH, Strategy::Mis, |s| s.rays.camera);
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

/// The reference image, rendered once and kept in the output folder (the
/// file name holds the resolution and spp).
fn reference(state: &RenderState, bench: &RenderBench, name: &str) -> Result<Vec<f32>> {
    let r = state.resolution;
    let path = bench.out.join(format!(
        "{name}-{}x{}-ref{}.exr",
        r.x, r.y, bench.reference_spp
    ));
    if let Ok(image) = read_image(&path, crate::scene::ColorSpace::Raw) {
        if image.channels == 3 && UVec2::new(image.width, image.height) == r {
            return Ok(image.pixels);
        }
    }
    let s = settings(
        Budget::Samples(bench.reference_spp),
        Strategy::Mis,
        SamplerKind::Sobol,
        1 << 20,
        MAX_DEPTH,
    );
    let (rgb, stats) = render(state, &s);
    eprintln!(
        "reference {}: {:.1} s",
        path.display(),
        stats.elapsed.as_secs_f64()
    );
    super::render::write_beauty(&path, r, &rgb, Compression::Zip, &s, &stats)?;
    Ok(rgb)
}

/// Mean squared error over pixels and channels.
fn mse(image: &[f32], reference: &[f32]) -> f64 {
    let sum: f64 = image
        .iter()
        .zip(reference)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum();
    sum / image.len() as f64
}

/// One method's convergence: (seconds, MSE) after 1, 2, 4, ... spp, each a
/// separate render, up to the first that takes longer than `max_seconds`.
fn convergence(
    state: &RenderState,
    reference: &[f32],
    (strategy, sampler): (Strategy, SamplerKind),
    seed: u64,
    max_seconds: f64,
) -> Vec<(f64, f64)> {
    let mut points = Vec::new();
    let mut spp = 1;
    loop {
        let s = settings(Budget::Samples(spp), strategy, sampler, seed, MAX_DEPTH);
        let (rgb, stats) = render(state, &s);
        let seconds = stats.elapsed.as_secs_f64();
        points.push((seconds, mse(&rgb, reference)));
        if seconds > max_seconds || spp >= 1 << 16 {
            return points;
        }
        spp *= 2;
    }
}

/// log MSE interpolated linearly in log time between the two points of
/// `curve` around `t` (extrapolated from the end segments).
fn mse_at(curve: &[(f64, f64)], t: f64) -> f64 {
    let logs: Vec<(f64, f64)> = curve.iter().map(|&(x, y)| (x.ln(), y.ln())).collect();
    if logs.len() == 1 {
        return curve[0].1;
    }
    let i = logs
        .windows(2)
        .position(|w| t.ln() <= w[1].0)
        .unwrap_or(logs.len() - 2);
    let ((x0, y0), (x1, y1)) = (logs[i], logs[i + 1]);
    let f = if x1 > x0 {
        (t.ln() - x0) / (x1 - x0)
    } else {
        0.0
    };
    (y0 + f * (y1 - y0)).exp()
}

/// The equal-time table and chart: every method renders at 1, 2, 4, ... spp
/// (per seed) until one render exceeds the largest budget; its MSE at each
/// budget is interpolated log-log between the renders around it, so the
/// times are equal exactly rather than rounded to whole passes.
fn equal_time(
    state: &RenderState,
    bench: &RenderBench,
    name: &str,
    reference: &[f32],
) -> Result<()> {
    let max_time = bench.times.iter().copied().fold(0.0, f64::max);
    let pixels = f64::from(state.resolution.x * state.resolution.y);
    let mut header = String::from("| estimator | sampler | samples/s (M) |");
    let mut rule = String::from("|---|---|---:|");
    for t in &bench.times {
        write!(header, " MSE @ {t} s |")?;
        rule.push_str("---:|");
    }
    println!("{header}\n{rule}");
    let mut curves = Vec::new();
    let mut at_times = Vec::new();
    for method in METHODS {
        let runs: Vec<Vec<(f64, f64)>> = (0..bench.repeats.max(1))
            .map(|seed| convergence(state, reference, method, u64::from(seed), max_time))
            .collect();
        let errors: Vec<f64> = bench
            .times
            .iter()
            .map(|&t| median(runs.iter().map(|c| mse_at(c, t)).collect()))
            .collect();
        // Samples per second from each run's largest render.
        let rate = median(
            runs.iter()
                .map(|c| {
                    let &(seconds, _) = c.last().expect("one render at least");
                    pixels * (1u64 << (c.len() - 1)) as f64 / seconds
                })
                .collect(),
        );
        let (strategy, sampler) = method;
        let mut row = format!("| {strategy:?} | {sampler:?} | {:.3} |", rate / 1e6);
        for e in &errors {
            write!(row, " {e:.3e} |")?;
        }
        println!("{row}");
        // The chart shows the median run (by its final error).
        let mut runs = runs;
        runs.sort_by(|a, b| a.last().unwrap().1.total_cmp(&b.last().unwrap().1));
        curves.push((
            format!("{strategy:?} + {sampler:?}"),
            runs.swap_remove(runs.len() / 2),
        ));
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
    std::fs::write(&chart, svg_chart(name, &curves))
        .with_context(|| format!("cannot write {}", chart.display()))?;
    println!("Chart: {}\n", chart.display());
    Ok(())
}

/// A log-log chart of MSE against seconds, one polyline per method.
fn svg_chart(title: &str, curves: &[(String, Vec<(f64, f64)>)]) -> String {
    const COLOURS: [&str; 6] = [
        "#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02",
    ];
    let (w, h, margin) = (640.0, 400.0, 60.0);
    let points = curves.iter().flat_map(|(_, c)| c.iter().copied());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in points.filter(|(x, y)| *x > 0.0 && *y > 0.0) {
        (x0, x1, y0, y1) = (
            x0.min(x.log10()),
            x1.max(x.log10()),
            y0.min(y.log10()),
            y1.max(y.log10()),
        );
    }
    let (x1, y1) = (x1.max(x0 + 1e-3), y1.max(y0 + 1e-3));
    let sx = |x: f64| margin + (x.log10() - x0) / (x1 - x0) * (w - 2.0 * margin);
    let sy = |y: f64| h - margin - (y.log10() - y0) / (y1 - y0) * (h - 2.0 * margin);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{margin}\" y=\"20\">{title}: MSE vs render time (log-log)</text>\n\
         <text x=\"{}\" y=\"{}\">seconds (10^{x0:.2} .. 10^{x1:.2})</text>\n\
         <text x=\"5\" y=\"{}\">MSE 10^{y0:.1} .. 10^{y1:.1}</text>\n\
         <rect x=\"{margin}\" y=\"{margin}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n",
        w / 2.0 - 60.0,
        h - 20.0,
        margin - 10.0,
        w - 2.0 * margin,
        h - 2.0 * margin
    );
    for (i, (label, curve)) in curves.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let pts: Vec<String> = curve
            .iter()
            .filter(|(x, y)| *x > 0.0 && *y > 0.0)
            .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y)))
            .collect();
        let _ = writeln!(
            svg,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"2\"/>",
            pts.join(" ")
        );
        let _ = writeln!(
            svg,
            "<text x=\"{}\" y=\"{}\" fill=\"{c}\">{label}</text>",
            w - margin - 150.0,
            margin + 15.0 + 15.0 * i as f64
        );
    }
    svg.push_str("</svg>\n");
    svg
}

/// Default scenes of the benchmark, from the shared assets.
pub fn default_scenes(repo: &Path) -> Vec<PathBuf> {
    let assets = repo.join("../shared/assets/usd-wg");
    vec![
        assets.join("full_assets/StandardShaderBall/standard_shader_ball_scene.usda"),
        assets.join("intent-vfx/scenes/teapotScene.usd"),
    ]
}
