//! The study's measurements: one [`Row`] per render (`converge.csv`) and
//! one [`Summary`] per scene, method and budget over the seeds
//! (`summary.csv`).

use std::path::Path;

use super::method::Series;
use crate::lab::files::write_csv;
use crate::lab::metrics::ErrorMetric;
use crate::lab::stats::{median, MeanInterval};
use crate::lab::Result;

/// One render of the study: a row of `converge.csv`.
pub(crate) struct Row {
    pub scene: String,
    pub method: Series,
    pub spp: u32,
    pub seed: u64,
    /// Wall time of the render call, seconds: Cirrus' sampling (the scene's
    /// load and BVH build, done once per scene, are not in it); a peer's
    /// timed render call (see [`crate::lab::peers`]).
    pub seconds: f64,
    /// Cirrus: `seconds`; a peer: its whole process, wall clock.
    pub total_seconds: f64,
    /// [`ErrorMetric::RelMse`] against our reference.
    pub relmse: f64,
    /// Root of [`ErrorMetric::Mse`] against our reference (radiance).
    pub rmse: f64,
    /// [`ErrorMetric::Bias`] against our reference (radiance).
    pub bias: f64,
    /// [`ErrorMetric::RelMse`] against the renderer's own reference (ours
    /// for our methods: `relmse`).
    pub relmse_own: f64,
}

/// The header of `converge.csv`.
const ROWS_HEADER: &str = "scene,method,spp,seed,seconds,relmse,rmse,bias,relmse_own,total_seconds";

impl Row {
    /// A row from an image's errors against our reference and its renderer's own.
    pub(crate) fn new(
        key: (&str, Series, u32, u64),
        rgb: &[f32],
        reference: &[f32],
        own_reference: &[f32],
        (seconds, total_seconds): (f64, f64),
    ) -> Self {
        let (scene, method, spp, seed) = key;
        Self {
            scene: scene.to_owned(),
            method,
            spp,
            seed,
            seconds,
            total_seconds,
            relmse: ErrorMetric::RelMse.error(rgb, reference),
            rmse: ErrorMetric::Mse.error(rgb, reference).sqrt(),
            bias: ErrorMetric::Bias.error(rgb, reference),
            relmse_own: ErrorMetric::RelMse.error(rgb, own_reference),
        }
    }

    fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.6},{:.6e},{:.6e},{:.6e},{:.6e},{:.6}",
            self.scene,
            self.method.name(),
            self.spp,
            self.seed,
            self.seconds,
            self.relmse,
            self.rmse,
            self.bias,
            self.relmse_own,
            self.total_seconds
        )
    }
}

/// The seeds of one scene, method and budget: a row of `summary.csv`.
pub(crate) struct Summary {
    pub scene: String,
    pub method: Series,
    pub spp: u32,
    /// How many seeds were rendered.
    pub seeds: usize,
    /// Medians over the seeds of the [`Row`] fields of the same names.
    pub seconds: f64,
    pub relmse: f64,
    pub rmse: f64,
    pub relmse_own: f64,
    pub total_seconds: f64,
    /// The per-seed biases' mean and 95% interval.
    pub bias: MeanInterval,
}

/// The header of `summary.csv`.
const SUMMARY_HEADER: &str = "scene,method,spp,seeds,median_seconds,median_relmse,median_rmse,mean_bias,bias_ci95_low,bias_ci95_high,median_relmse_own,median_total_seconds";

impl Summary {
    /// Summarises `rows`, the seeds of one scene, method and budget.
    pub(crate) fn of(rows: &[Row]) -> Self {
        let column = |f: fn(&Row) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
        Self {
            scene: rows[0].scene.clone(),
            method: rows[0].method,
            spp: rows[0].spp,
            seeds: rows.len(),
            seconds: median(column(|r| r.seconds)),
            relmse: median(column(|r| r.relmse)),
            rmse: median(column(|r| r.rmse)),
            relmse_own: median(column(|r| r.relmse_own)),
            total_seconds: median(column(|r| r.total_seconds)),
            bias: MeanInterval::of(&column(|r| r.bias)),
        }
    }

    fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.6},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6}",
            self.scene,
            self.method.name(),
            self.spp,
            self.seeds,
            self.seconds,
            self.relmse,
            self.rmse,
            self.bias.mean,
            self.bias.mean - self.bias.half_width,
            self.bias.mean + self.bias.half_width,
            self.relmse_own,
            self.total_seconds
        )
    }
}

/// One summary per scene, method and budget of `rows` (grouped as rendered).
pub(crate) fn summarise(rows: &[Row]) -> Vec<Summary> {
    rows.chunk_by(|a, b| a.scene == b.scene && a.method == b.method && a.spp == b.spp)
        .map(Summary::of)
        .collect()
}

/// Writes `converge.csv` (`rows`) and `summary.csv` (`summaries`) into `out`.
pub(crate) fn write_csvs(out: &Path, rows: &[Row], summaries: &[Summary]) -> Result<()> {
    let rows: Vec<String> = rows.iter().map(Row::csv).collect();
    write_csv(&out.join("converge.csv"), ROWS_HEADER, &rows)?;
    let summaries: Vec<String> = summaries.iter().map(Summary::csv).collect();
    write_csv(&out.join("summary.csv"), SUMMARY_HEADER, &summaries)
}
