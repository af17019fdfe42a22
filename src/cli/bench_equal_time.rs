//! Equal-time error against a long reference, shared by `cirrus bench
//! render` and `cirrus bench volumes`: the cached reference render, the
//! error metrics, the ladder of renders at 1, 2, 4, ... spp whose error is
//! read off at exact times (log-log interpolation), the Markdown columns of
//! those errors, and the SVG chart of error against time (or spp). `cirrus
//! converge` reuses the reference, the metrics and the chart.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::UVec2;

use super::bench::median;
use cirrus::film::AovSet;
use cirrus::film::FilterKind;
use cirrus::image::read_image;
use cirrus::integrator::{
    self, Budget, PathSettings, RenderSettings, RenderStats, Strategy, VolumeEstimator,
    DEFAULT_MAX_DEPTH,
};
use cirrus::render_state::RenderState;
use cirrus::sampling::SamplerKind;
use cirrus::scene::Scene;

/// What an equal-time benchmark measures (`bench render`, `bench volumes`).
pub struct EqualTimeBench {
    /// Scenes (USD or exported).
    pub scenes: Vec<PathBuf>,
    /// Image size.
    pub resolution: UVec2,
    /// Samples per pixel of each scene's reference.
    pub reference_spp: u32,
    /// Equal-time budgets, seconds.
    pub times: Vec<f64>,
    /// Seeds per method; the tables show the median error.
    pub repeats: u32,
    /// Folder for references and charts.
    pub out: PathBuf,
}

impl EqualTimeBench {
    /// From a benchmark's flags: its scenes, resolution, and (reference spp,
    /// budgets in seconds, seeds), replaced by `quick`'s when given (the
    /// `--quick` smoke check).
    pub fn new(
        scenes: Vec<PathBuf>,
        resolution: UVec2,
        settings: (u32, Vec<f64>, u32),
        quick: Option<(u32, Vec<f64>, u32)>,
        out: PathBuf,
    ) -> Self {
        let (reference_spp, times, repeats) = quick.unwrap_or(settings);
        Self {
            scenes,
            resolution,
            reference_spp,
            times,
            repeats,
            out,
        }
    }

    /// Creates the output folder (and `charts`), then prints the machine
    /// line and the settings every render shares; `reference` names how
    /// the reference is rendered.
    pub(super) fn start(&self, charts: Option<&Path>, reference: &str) -> Result<()> {
        for dir in std::iter::once(self.out.as_path()).chain(charts) {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
        }
        println!("{}\n", super::bench::machine_line());
        println!(
            "Threads: {}; {}x{} pixels; max depth {DEFAULT_MAX_DEPTH}; MIS + Sobol; box filter; {} seed(s) per method; reference: {reference}, {} spp. relMSE = mean (x - ref)^2 / (ref^2 + 0.01).\n",
            rayon::current_num_threads(),
            self.resolution.x,
            self.resolution.y,
            self.repeats.max(1),
            self.reference_spp
        );
        Ok(())
    }
}

/// Seed of every reference render, apart from the seeds of the measured ones
/// (0, 1, 2, ...).
pub(super) const REFERENCE_SEED: u64 = 1 << 20;

/// Settings of every benchmark and convergence render unless the measured
/// method changes them: `cirrus render`'s defaults (MIS, Sobol, max depth
/// [`DEFAULT_MAX_DEPTH`], null-scattering MIS with equiangular sampling, no clamp)
/// but a box filter, so each sample lands in its own pixel only, and the
/// beauty alone.
pub(super) fn base_settings(budget: Budget, seed: u64) -> RenderSettings {
    RenderSettings {
        budget,
        seed,
        sampler: SamplerKind::Sobol,
        filter: FilterKind::Box,
        path: PathSettings {
            strategy: Strategy::Mis,
            max_depth: DEFAULT_MAX_DEPTH,
            clamp: None,
            volume_estimator: VolumeEstimator::NullScatteringMis,
            equiangular: true,
        },
        aovs: AovSet::beauty_only(),
    }
}

/// How an image's error against the reference is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ErrorMetric {
    /// Mean squared error over pixels and RGB channels.
    Mse,
    /// Relative MSE: mean over pixels and channels of (x - r)^2 / (r^2 +
    /// 0.01), as in Rousselle et al. 2011 and most denoising and path
    /// guiding papers, so bright and dark regions weigh alike (the 0.01
    /// keeps black reference pixels finite).
    RelMse,
    /// Mean signed difference x - r over pixels and channels (radiance): the
    /// image's bias against the reference, positive when too bright. Not an
    /// error to chart on a log axis.
    Bias,
}

impl ErrorMetric {
    /// The error of `image` against `reference` (same layout, linear RGB).
    pub(super) fn error(self, image: &[f32], reference: &[f32]) -> f64 {
        let sum: f64 = image
            .iter()
            .zip(reference)
            .map(|(&a, &b)| {
                let difference = f64::from(a - b);
                match self {
                    Self::Mse => difference.powi(2),
                    Self::RelMse => difference.powi(2) / (f64::from(b).powi(2) + 0.01),
                    Self::Bias => difference,
                }
            })
            .sum();
        sum / image.len() as f64
    }

    /// The metric's name in tables and charts.
    pub(super) fn name(self) -> &'static str {
        match self {
            Self::Mse => "MSE",
            Self::RelMse => "relMSE",
            Self::Bias => "bias",
        }
    }
}

/// One render of a [`ladder`]: its error and what it did (spp, time, rays,
/// media counters).
pub(super) struct Rung {
    /// Error against the reference.
    pub error: f64,
    /// The render's statistics.
    pub stats: RenderStats,
}

impl Rung {
    /// Seconds of sampling.
    pub fn seconds(&self) -> f64 {
        self.stats.elapsed.as_secs_f64()
    }
}

/// Renders `state` with `settings`; the film's RGB and the statistics.
pub(super) fn render(state: &RenderState, settings: &RenderSettings) -> (Vec<f32>, RenderStats) {
    let (film, stats) = integrator::render(state, settings, &|_| {});
    (film.rgb(), stats)
}

/// A scene's name in tables, charts and file names: its file stem.
pub(super) fn scene_name(path: &Path) -> String {
    path.file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
}

/// The name under which references of `scene` (called `name`) are kept:
/// the name and a CRC-32 of the exported scene (`scene.json` and
/// `scene.bin`), so a reference rendered before the scene changed is never
/// read back (a stale smoke reference, from before its ground lost its
/// specular lobe, once made every method look stuck at relMSE 0.13).
pub(super) fn reference_key(scene: &Scene, name: &str) -> Result<String> {
    let crc = scene
        .content_crc()
        .with_context(|| format!("cannot read the scene in {}", scene.dir.display()))?;
    Ok(format!("{name}-{crc:08x}"))
}

/// The reference of the scene whose [`reference_key`] is `key`:
/// [`base_settings`] at `spp` with [`REFERENCE_SEED`], kept in `out` by
/// [`reference`] at [`reference_path`].
pub(super) fn cached_reference(
    state: &RenderState,
    out: &Path,
    key: &str,
    spp: u32,
) -> Result<Vec<f32>> {
    let path = reference_path(out, key, state.resolution, spp);
    let settings = base_settings(Budget::Samples(spp), REFERENCE_SEED);
    reference(state, &settings, &path)
}

/// Where the reference of the scene keyed `key` ([`reference_key`]) at this
/// resolution and spp is kept: `<out>/<key>-<w>x<h>-ref<spp>.exr`. The key
/// holds neither the settings, nor the renderer's version, nor the VDB
/// files' contents: delete the file after changing any of them.
pub(super) fn reference_path(out: &Path, key: &str, resolution: UVec2, spp: u32) -> PathBuf {
    out.join(format!(
        "{key}-{}x{}-ref{spp}.exr",
        resolution.x, resolution.y
    ))
}

/// The reference image at `path`, read back when it exists with the right
/// size, else rendered with `settings` (a sample budget) and written there.
fn reference(state: &RenderState, settings: &RenderSettings, path: &Path) -> Result<Vec<f32>> {
    if let Some(rgb) = read_rgb(path, state.resolution) {
        return Ok(rgb);
    }
    let (rgb, stats) = render(state, settings);
    eprintln!(
        "reference {}: {:.1} s",
        path.display(),
        stats.elapsed.as_secs_f64()
    );
    let header = cirrus::output::ExrHeader::new(state, settings);
    cirrus::output::write_beauty(path, state.resolution, &rgb, &header, &stats)?;
    Ok(rgb)
}

/// The RGB pixels of the EXR at `path` when it exists, holds 3 channels and
/// has this `resolution`; None otherwise.
pub(super) fn read_rgb(path: &Path, resolution: UVec2) -> Option<Vec<f32>> {
    let image = read_image(path, cirrus::scene::ColorSpace::Raw).ok()?;
    (image.channels == 3 && UVec2::new(image.width, image.height) == resolution)
        .then_some(image.pixels)
}

/// One method's convergence: renders with `settings` at 1, 2, 4, ... spp,
/// each a separate render, up to the first that takes longer than
/// `max_seconds` (or reaches 65536 spp).
pub(super) fn ladder(
    state: &RenderState,
    reference: &[f32],
    metric: ErrorMetric,
    settings: &RenderSettings,
    max_seconds: f64,
) -> Vec<Rung> {
    let mut rungs = Vec::new();
    let mut spp = 1;
    loop {
        let s = RenderSettings {
            budget: Budget::Samples(spp),
            ..settings.clone()
        };
        let (rgb, stats) = render(state, &s);
        let rung = Rung {
            error: metric.error(&rgb, reference),
            stats,
        };
        let seconds = rung.seconds();
        rungs.push(rung);
        if seconds > max_seconds || spp >= 1 << 16 {
            return rungs;
        }
        spp *= 2;
    }
}

/// The error at `t` seconds: log error interpolated linearly in log time
/// between the two rungs around `t` (extrapolated from the end segments), so
/// times are equal exactly rather than rounded to whole passes.
pub(super) fn error_at(ladder: &[Rung], t: f64) -> f64 {
    let points: Vec<(f64, f64)> = ladder.iter().map(|r| (r.seconds(), r.error)).collect();
    error_at_time(&points, t)
}

/// [`error_at`] on (seconds, error) points in increasing time.
pub(super) fn error_at_time(points: &[(f64, f64)], t: f64) -> f64 {
    if points.len() == 1 {
        return points[0].1;
    }
    let logs: Vec<(f64, f64)> = points.iter().map(|&(s, e)| (s.ln(), e.ln())).collect();
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

/// Samples per pixel per second of a ladder's largest (longest) render.
pub(super) fn spp_per_second(ladder: &[Rung]) -> f64 {
    let last = ladder.last().expect("a ladder has one render at least");
    f64::from(last.stats.samples_per_pixel) / last.seconds()
}

/// Per time in `times`, the median over `ladders` (one per seed) of the
/// error at that time.
pub(super) fn median_errors(ladders: &[Vec<Rung>], times: &[f64]) -> Vec<f64> {
    times
        .iter()
        .map(|&t| median(ladders.iter().map(|l| error_at(l, t)).collect()))
        .collect()
}

/// The chart curve of the median ladder (by final error): (seconds, error)
/// per render.
pub(super) fn median_curve(ladders: &[Vec<Rung>]) -> Vec<(f64, f64)> {
    let mut order: Vec<&Vec<Rung>> = ladders.iter().collect();
    order.sort_by(|a, b| last_error(a).total_cmp(&last_error(b)));
    order[order.len() / 2]
        .iter()
        .map(|r| (r.seconds(), r.error))
        .collect()
}

fn last_error(ladder: &[Rung]) -> f64 {
    ladder.last().map_or(f64::NAN, |r| r.error)
}

/// The Markdown header cells and rule cells of one error column per time:
/// `" MSE @ 1 s |"` and `"---:|"` each.
pub(super) fn error_columns(metric: ErrorMetric, times: &[f64]) -> (String, String) {
    let mut header = String::new();
    for t in times {
        let _ = write!(header, " {} @ {t} s |", metric.name());
    }
    (header, "---:|".repeat(times.len()))
}

/// The Markdown cells of `errors`, one per time of [`error_columns`].
pub(super) fn error_cells(errors: &[f64]) -> String {
    errors.iter().map(|e| format!(" {e:.3e} |")).collect()
}

/// The x axis of a [`write_chart`]: what it shows, in the title, and its
/// unit, under the axis.
pub(super) struct ChartAxis {
    /// The quantity, e.g. "render time".
    pub quantity: &'static str,
    /// Its unit, e.g. "seconds".
    pub unit: &'static str,
}

/// Render time in seconds: the x axis of the equal-time charts.
pub(super) const TIME_AXIS: ChartAxis = ChartAxis {
    quantity: "render time",
    unit: "seconds",
};

/// Writes the relMSE-against-time chart of scene `name` into the bench's
/// output folder and, when asked, into `charts` as
/// `<prefix>-<name>-equal-time.svg` (the README's charts live in
/// docs/bench); one labelled curve per method.
pub(super) fn write_scene_charts(
    bench: &EqualTimeBench,
    charts: Option<&Path>,
    (prefix, name): (&str, &str),
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<()> {
    let mut paths = vec![bench.out.join(format!("{name}-equal-time.svg"))];
    paths.extend(charts.map(|dir| dir.join(format!("{prefix}-{name}-equal-time.svg"))));
    for chart in paths {
        write_chart(&chart, name, &TIME_AXIS, ErrorMetric::RelMse, curves)?;
        println!("Chart: {}", chart.display());
    }
    println!();
    Ok(())
}

/// Writes (atomically) a log-log SVG chart of the error against `x`
/// (seconds, in the equal-time benchmarks) to `path`: one line with its
/// measured points per labelled curve of (x, error) points, drawn with
/// plotters' SVG backend (decade ticks and labels, a legend). Only curves
/// are drawn with stroke width 2, so `stroke-width="2"` polylines count them.
pub(super) fn write_chart(
    path: &Path,
    title: &str,
    x_axis: &ChartAxis,
    metric: ErrorMetric,
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<()> {
    let svg = svg_chart(title, x_axis, metric, curves)
        .map_err(|e| anyhow::anyhow!("cannot draw chart {}: {e}", path.display()))?;
    cirrus::image::write_file(path, svg.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))
}

/// The chart of [`write_chart`] as SVG text.
fn svg_chart(
    title: &str,
    x_axis: &ChartAxis,
    metric: ErrorMetric,
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<String, Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    /// Dark2 (ColorBrewer), one colour per curve.
    const COLOURS: [RGBColor; 8] = [
        RGBColor(0x1b, 0x9e, 0x77),
        RGBColor(0xd9, 0x5f, 0x02),
        RGBColor(0x75, 0x70, 0xb3),
        RGBColor(0xe7, 0x29, 0x8a),
        RGBColor(0x66, 0xa6, 0x1e),
        RGBColor(0xe6, 0xab, 0x02),
        RGBColor(0xa6, 0x76, 0x1d),
        RGBColor(0x66, 0x66, 0x66),
    ];
    let positive = |&(x, y): &(f64, f64)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite();
    let points = || {
        curves
            .iter()
            .flat_map(|(_, c)| c.iter().copied())
            .filter(positive)
    };
    let range = |values: Vec<f64>| {
        let lo = values.iter().copied().fold(f64::MAX, f64::min);
        let hi = values.iter().copied().fold(f64::MIN, f64::max);
        if lo > hi {
            return 0.1..1.0;
        }
        // A little room around the data, and never an empty range.
        lo / 1.25..(hi * 1.25).max(lo * 1.5)
    };
    let xs = range(points().map(|(x, _)| x).collect());
    let ys = range(points().map(|(_, y)| y).collect());
    let metric = metric.name();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 420)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{title}: {metric} vs {} (log-log)", x_axis.quantity),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
        chart
            .configure_mesh()
            .x_desc(x_axis.unit)
            .y_desc(metric)
            .x_label_formatter(&|x| format!("{x:.3}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .label_style(("sans-serif", 12))
            .draw()?;
        for (i, (label, curve)) in curves.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let curve: Vec<(f64, f64)> = curve.iter().copied().filter(positive).collect();
            chart
                .draw_series(LineSeries::new(
                    curve.iter().copied(),
                    colour.stroke_width(2),
                ))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 4), (x + 16, y + 4)], colour.filled())
                });
            chart.draw_series(curve.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use cirrus::integrator::RayCounts;
    use cirrus::volumes::TrackingStats;

    fn rung(seconds: f64, error: f64) -> Rung {
        Rung {
            error,
            stats: RenderStats {
                samples_per_pixel: 1,
                elapsed: Duration::from_secs_f64(seconds),
                rays: RayCounts::default(),
                non_finite: Default::default(),
                tracking: TrackingStats::default(),
                complete: true,
            },
        }
    }

    #[test]
    fn metrics_match_their_formulas() {
        let reference = [0.0, 1.0, 3.0];
        let image = [0.1, 1.5, 2.0];
        let mse = (0.01 + 0.25 + 1.0) / 3.0;
        let rel = (0.01 / 0.01 + 0.25 / 1.01 + 1.0 / 9.01) / 3.0;
        assert!((ErrorMetric::Mse.error(&image, &reference) - mse).abs() < 1e-7);
        assert!((ErrorMetric::RelMse.error(&image, &reference) - rel).abs() < 1e-7);
        let bias = (0.1 + 0.5 - 1.0) / 3.0;
        assert!((ErrorMetric::Bias.error(&image, &reference) - bias).abs() < 1e-7);
    }

    #[test]
    fn error_at_follows_a_power_law_between_and_beyond_rungs() {
        // error = 1 / t exactly: the log-log interpolation reproduces it,
        // between rungs and extrapolated past both ends.
        let ladder: Vec<Rung> = [0.5, 1.0, 2.0, 4.0]
            .iter()
            .map(|&t| rung(t, 1.0 / t))
            .collect();
        for t in [0.25, 0.7, 1.5, 3.0, 8.0] {
            let e = error_at(&ladder, t);
            assert!((e * t - 1.0).abs() < 1e-6, "t {t}: {e}");
        }
        assert_eq!(error_at(&ladder[..1], 3.0), 2.0);
    }
}
