//! Equal-time error against a long reference, shared by the render,
//! volumes and fire benchmarks: the ladder of renders at 1, 2, 4, ... spp
//! whose error is read off at exact times (log-log interpolation), its
//! medians over seeds, and each scene's chart of error against time.

use std::path::{Path, PathBuf};

use glam::UVec2;

use super::chart::{write_chart, TIME_AXIS};
use super::machine::{machine_line, with_threads};
use super::metrics::ErrorMetric;
use super::reference::render;
use super::scenes::scenes_or_default;
use super::stats::median;
use super::Result;
use crate::file_error::FileError;
use crate::integrator::{Budget, RenderSettings, RenderStats, DEFAULT_MAX_DEPTH};
use crate::render_state::RenderState;

/// What an equal-time benchmark measures (`bench render`, `bench volumes`,
/// `bench fire`).
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
    /// Worker threads.
    pub threads: usize,
    /// Folder for references and charts.
    pub out: PathBuf,
    /// A folder that also receives each chart as
    /// `<benchmark>-<scene>-equal-time.svg` (the README's live in
    /// `docs/bench`), when given.
    pub charts: Option<PathBuf>,
}

/// What an equal-time benchmark's flags take when not given: each
/// benchmark's own (`render::DEFAULTS`, `volumes::DEFAULTS`, `fire::DEFAULTS`).
pub struct EqualTimeDefaults {
    /// Image size.
    pub resolution: UVec2,
    /// Samples per pixel of each scene's reference.
    pub reference_spp: u32,
    /// Equal-time budgets, seconds.
    pub times: &'static [f64],
    /// Folder for references and charts.
    pub out: &'static str,
    /// The `--quick` smoke check's (reference spp, budgets in seconds,
    /// seeds), for the benchmarks that offer one.
    pub quick: Option<(u32, &'static [f64], u32)>,
}

impl EqualTimeBench {
    /// From a benchmark's flags, each `None` taking `defaults`' value: its
    /// scenes, resolution, (reference spp, budgets in seconds, seeds), all
    /// three replaced by `defaults.quick` when `quick` (the `--quick` smoke
    /// check), worker threads, and the output and charts folders.
    pub fn new(
        defaults: &EqualTimeDefaults,
        scenes: Vec<PathBuf>,
        resolution: Option<UVec2>,
        (reference_spp, times, repeats): (Option<u32>, Option<Vec<f64>>, u32),
        quick: bool,
        threads: usize,
        (out, charts): (Option<PathBuf>, Option<PathBuf>),
    ) -> Self {
        let (reference_spp, times, repeats) = match defaults.quick.filter(|_| quick) {
            Some((spp, times, seeds)) => (spp, times.to_vec(), seeds),
            None => (
                reference_spp.unwrap_or(defaults.reference_spp),
                times.unwrap_or_else(|| defaults.times.to_vec()),
                repeats,
            ),
        };
        Self {
            scenes,
            resolution: resolution.unwrap_or(defaults.resolution),
            reference_spp,
            times,
            repeats,
            threads,
            out: out.unwrap_or_else(|| defaults.out.into()),
            charts,
        }
    }

    /// The largest time budget, seconds: where the ladders stop.
    pub(crate) fn max_time(&self) -> f64 {
        self.times.iter().copied().fold(0.0, f64::max)
    }

    /// On `threads` workers: [`start`](Self::start)s, then runs `study` on
    /// each scene (`defaults`, in `scenes/`, when none were given).
    pub(crate) fn run(
        &self,
        reference: &str,
        defaults: &[&str],
        study: impl Fn(&Path) -> Result<()> + Sync,
    ) -> Result<()> {
        with_threads(self.threads, || {
            self.start(reference)?;
            for path in &scenes_or_default(self.scenes.clone(), defaults) {
                study(path)?;
            }
            Ok(())
        })
    }

    /// Creates the output folder (and `charts`), then prints the machine
    /// line and the settings every render shares; `reference` names how
    /// the reference is rendered.
    fn start(&self, reference: &str) -> Result<()> {
        for dir in std::iter::once(self.out.as_path()).chain(self.charts.as_deref()) {
            std::fs::create_dir_all(dir).map_err(|e| FileError::new("create", dir, e))?;
        }
        println!("{}\n", machine_line());
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

/// One render of a [`ladder`]: its error and what it did (spp, time, rays,
/// media counters).
pub(crate) struct Rung {
    /// Error against the reference.
    pub error: f64,
    /// The render's statistics.
    pub stats: RenderStats,
}

impl Rung {
    /// Seconds of sampling.
    pub(crate) fn seconds(&self) -> f64 {
        self.stats.elapsed.as_secs_f64()
    }
}

/// One method's convergence: renders with `settings` at 1, 2, 4, ... spp,
/// each a separate render, up to the first that takes longer than
/// `max_seconds` (or reaches 65536 spp).
pub(crate) fn ladder(
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
pub(crate) fn error_at(ladder: &[Rung], t: f64) -> f64 {
    let points: Vec<(f64, f64)> = ladder.iter().map(|r| (r.seconds(), r.error)).collect();
    error_at_time(&points, t)
}

/// [`error_at`] on (seconds, error) points in increasing time.
pub(crate) fn error_at_time(points: &[(f64, f64)], t: f64) -> f64 {
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
pub(crate) fn spp_per_second(ladder: &[Rung]) -> f64 {
    let last = ladder.last().expect("a ladder has one render at least");
    f64::from(last.stats.samples_per_pixel) / last.seconds()
}

/// Per time in `times`, the median over `ladders` (one per seed) of the
/// error at that time.
pub(crate) fn median_errors(ladders: &[Vec<Rung>], times: &[f64]) -> Vec<f64> {
    times
        .iter()
        .map(|&t| median(ladders.iter().map(|l| error_at(l, t)).collect()))
        .collect()
}

/// The chart curve of the median ladder (by final error): (seconds, error)
/// per render.
pub(crate) fn median_curve(ladders: &[Vec<Rung>]) -> Vec<(f64, f64)> {
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

/// Writes the relMSE-against-time chart of scene `name` into the bench's
/// output folder and, when asked, into its `charts` folder as
/// `<prefix>-<name>-equal-time.svg`; one labelled curve per method.
pub(crate) fn write_scene_charts(
    bench: &EqualTimeBench,
    (prefix, name): (&str, &str),
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<()> {
    let mut paths = vec![bench.out.join(format!("{name}-equal-time.svg"))];
    paths.extend(
        bench
            .charts
            .as_ref()
            .map(|dir| dir.join(format!("{prefix}-{name}-equal-time.svg"))),
    );
    for chart in paths {
        write_chart(&chart, name, &TIME_AXIS, ErrorMetric::RelMse, curves)?;
        println!("Chart: {}", chart.display());
    }
    println!();
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::integrator::RayCounts;
    use crate::volumes::estimators::TrackingStats;

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
