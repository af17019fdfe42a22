//! `cirrus converge`: the convergence harness of issue 7. For each scene and
//! method (`cirrus render`'s defaults with one flag changed), renders at 1,
//! 2, 4, ... spp with K seeds each and measures every image against a
//! high-spp reference of the default method: relMSE, RMSE and the mean bias
//! (mean over pixels and channels of image - reference) with its 95%
//! confidence interval across the seeds. Writes `converge.csv` (one row per
//! render), `summary.csv` (per budget: medians over the seeds and the bias
//! interval) and per scene two log-log SVG charts, relMSE against wall time
//! and against spp; prints a Markdown summary with machine, date and commit.
//!
//! An unbiased method's relMSE falls as 1/spp (slope -1 on the spp chart; QMC
//! can fall faster), until it reaches the reference's own noise, about the
//! 1-spp relMSE / reference spp. A bias interval that excludes 0 while the
//! relMSE stops falling marks a biased method (or a biased reference).
//!
//! `--peers` adds peer renderers (Mitsuba 3, Blender Cycles) as more series,
//! rendered at the same budgets and seeds through
//! `scenes/peers/render_peer.py` from the same exported scene. Their error is
//! measured against our reference (`relmse`) and against their own reference
//! at the same spp (`relmse_own`, a third chart), and `equal_time.md` gives
//! our default method's relMSE over each peer's at the peer's render times
//! (the default method goes on doubling its spp past --spp-max until it
//! takes as long as the slowest peer render, so that those times are
//! matched, not extrapolated).
//! Time is the same kind for all: the render call alone (Cirrus: sampling,
//! the scene loaded and its BVH built; a peer: its timed render call after an
//! untimed warm-up, without process start, scene conversion, load, BVH build
//! or JIT compilation); `total_seconds` adds a peer's whole process.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::UVec2;

use super::bench::{machine_line, median, scenes_or_default, value_name, with_threads};
use super::bench_equal_time::{
    base_settings, cached_reference, error_at_time, read_rgb, reference_key, reference_path,
    render, scene_name, write_chart, ChartAxis, ErrorMetric, REFERENCE_SEED, TIME_AXIS,
};
use cirrus::integrator::{Budget, RenderSettings, Strategy, VolumeEstimator, DEFAULT_MAX_DEPTH};
use cirrus::render_state::{RenderState, StateOptions};
use cirrus::sampling::SamplerKind;
use cirrus::volumes::MajorantKind;

/// `cirrus converge` arguments.
#[derive(clap::Args, Debug)]
pub struct ConvergeArgs {
    /// Scenes (USD or exported); default: scenes/bench/smoke.usda and the
    /// StandardShaderBall.
    scenes: Vec<PathBuf>,
    /// Comma-separated methods: default, sampler-independent, strategy-bsdf,
    /// strategy-nee, majorant-global, estimator-ratio,
    /// estimator-residual-ratio, estimator-track-length, no-equiangular
    /// [all that apply to each scene: the volume ones where it has volumes,
    /// no-equiangular where it also has lights that equiangular sampling
    /// targets].
    #[arg(long, value_delimiter = ',', value_parser = parse_method)]
    methods: Vec<Method>,
    /// Largest budget: renders at 1, 2, 4, ... spp up to this (itself last
    /// when not a power of two).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp_max: u32,
    /// Seeds per budget (at least 2: the bias interval needs a spread).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(2..))]
    seeds: u32,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "160x90", value_parser = super::render::parse_resolution)]
    res: UVec2,
    /// Samples per pixel of each scene's reference (default method, kept in
    /// --out by scene, size and spp: delete it after changing the renderer).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..))]
    reference_spp: u32,
    /// Worker threads (Cirrus' and each peer's).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Comma-separated peer renderers, rendered at the same budgets and
    /// seeds through scenes/peers/render_peer.py (installed by
    /// scenes/peers/install [--cycles]); each also renders its own
    /// reference.
    #[arg(long, value_delimiter = ',')]
    peers: Vec<Peer>,
    /// Samples per pixel of each peer's own reference [default:
    /// --reference-spp].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    peer_reference_spp: Option<u32>,
    /// Folder for the CSVs, the charts and the references.
    #[arg(long, default_value = "out/converge")]
    out: PathBuf,
}

/// A method of the study: the reference's settings ([`base_settings`],
/// which are `cirrus render`'s defaults but a box filter) with at most one
/// `cirrus render` flag changed, through the same option types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Method {
    /// No flag changed: the reference's own estimator.
    Default,
    /// `--sampler`.
    Sampler(SamplerKind),
    /// `--strategy`.
    Strategy(Strategy),
    /// `--majorant`.
    Majorant(MajorantKind),
    /// `--volume-estimator`.
    Estimator(VolumeEstimator),
    /// `--no-equiangular`.
    NoEquiangular,
}

/// Every method, in table and chart order.
const METHODS: [Method; 9] = [
    Method::Default,
    Method::Sampler(SamplerKind::Independent),
    Method::Strategy(Strategy::Bsdf),
    Method::Strategy(Strategy::Nee),
    Method::Majorant(MajorantKind::Global),
    Method::Estimator(VolumeEstimator::Ratio),
    Method::Estimator(VolumeEstimator::ResidualRatio),
    Method::Estimator(VolumeEstimator::TrackLength),
    Method::NoEquiangular,
];

impl Method {
    /// The name in `--methods`, the CSVs and the charts: the flag's name
    /// (volume estimators shortened to `estimator`) and value.
    fn name(self) -> String {
        match self {
            Self::Default => "default".into(),
            Self::Sampler(s) => format!("sampler-{s}"),
            Self::Strategy(s) => format!("strategy-{s}"),
            Self::Majorant(m) => format!("majorant-{m}"),
            Self::Estimator(e) => format!("estimator-{e}"),
            Self::NoEquiangular => "no-equiangular".into(),
        }
    }

    /// The `cirrus render` flag this method adds (empty for `default`).
    fn flag(self) -> String {
        match self {
            Self::Default => String::new(),
            Self::Sampler(s) => format!("--sampler {s}"),
            Self::Strategy(s) => format!("--strategy {s}"),
            Self::Majorant(m) => format!("--majorant {m}"),
            Self::Estimator(e) => format!("--volume-estimator {e}"),
            Self::NoEquiangular => "--no-equiangular".into(),
        }
    }

    /// Whether the method differs from `default` on this scene: volume
    /// methods need volumes, and `no-equiangular` also a light that
    /// equiangular sampling targets ([`cirrus::lights::Lights::has_equiangular_target`]).
    fn applies_to(self, state: &RenderState) -> bool {
        let volumes = !state.media.is_empty();
        match self {
            Self::Default | Self::Sampler(_) | Self::Strategy(_) => true,
            Self::Majorant(_) | Self::Estimator(_) => volumes,
            Self::NoEquiangular => volumes && state.lights.has_equiangular_target(),
        }
    }

    /// `base` with this method's flag applied, as `cirrus render` applies it.
    fn settings(self, base: RenderSettings) -> RenderSettings {
        let mut s = base;
        match self {
            Self::Default | Self::Majorant(_) => {}
            Self::Sampler(sampler) => s.sampler = sampler,
            Self::Strategy(strategy) => s.path.strategy = strategy,
            Self::Estimator(estimator) => s.path.volume_estimator = estimator,
            Self::NoEquiangular => s.path.equiangular = false,
        }
        s
    }

    /// The majorants the render state is built with.
    fn majorant(self) -> MajorantKind {
        match self {
            Self::Majorant(m) => m,
            _ => MajorantKind::Grid,
        }
    }
}

/// A peer renderer of `--peers` (issue 7), by its name in
/// scenes/peers/render_peer.py, the CSVs and the charts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Peer {
    /// Mitsuba 3 `scalar_rgb`.
    MitsubaScalar,
    /// Mitsuba 3 `llvm_ad_rgb` (Debian's libllvm19).
    MitsubaLlvm,
    /// Blender 3.4 Cycles on the CPU.
    Cycles,
}

/// What one row of the study rendered: a method of ours or a peer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Series {
    Ours(Method),
    Peer(Peer),
}

impl Series {
    /// The name in the CSVs and charts: the method's or the peer's.
    fn name(self) -> String {
        match self {
            Self::Ours(m) => m.name(),
            Self::Peer(p) => value_name(p),
        }
    }

    /// How it is rendered: the `cirrus render` flag, or the peer's script.
    fn flag(self) -> String {
        match self {
            Self::Ours(m) => m.flag(),
            Self::Peer(p) => format!("render_peer.py {}", value_name(p)),
        }
    }
}

/// Parses one `--methods` name.
fn parse_method(s: &str) -> Result<Method, String> {
    METHODS.into_iter().find(|m| m.name() == s).ok_or_else(|| {
        let names: Vec<String> = METHODS.iter().map(|m| m.name()).collect();
        format!("{s:?}: expected one of {}", names.join(", "))
    })
}

/// The budgets: 1, 2, 4, ... spp up to `spp_max`, which comes last when it
/// is not a power of two.
fn budgets(spp_max: u32) -> Vec<u32> {
    let mut spp: Vec<u32> = std::iter::successors(Some(1u32), |&n| n.checked_mul(2))
        .take_while(|&n| n <= spp_max)
        .collect();
    if !spp_max.is_power_of_two() {
        spp.push(spp_max);
    }
    spp
}

/// One render of the study: a row of `converge.csv`.
struct Row {
    scene: String,
    method: Series,
    spp: u32,
    seed: u64,
    /// Wall time of the render call, seconds: Cirrus' sampling (the scene's
    /// load and BVH build, done once per scene, are not in it); a peer's
    /// timed render call (see the module doc).
    seconds: f64,
    /// Cirrus: `seconds`; a peer: its whole process, wall clock.
    total_seconds: f64,
    /// [`ErrorMetric::RelMse`] against our reference.
    relmse: f64,
    /// Root of [`ErrorMetric::Mse`] against our reference (radiance).
    rmse: f64,
    /// [`ErrorMetric::Bias`] against our reference (radiance).
    bias: f64,
    /// [`ErrorMetric::RelMse`] against the renderer's own reference (ours
    /// for our methods: `relmse`).
    relmse_own: f64,
}

/// The header of `converge.csv`.
const ROWS_HEADER: &str = "scene,method,spp,seed,seconds,relmse,rmse,bias,relmse_own,total_seconds";

impl Row {
    /// A row from an image's errors against our reference and its renderer's own.
    fn new(
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

/// Two-sided 95% quantiles of Student's t for 1 to 30 degrees of freedom.
const T_975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];

/// The 97.5% quantile of Student's t with `dof` degrees of freedom: the
/// table up to 30, then the normal quantile 1.96 with its first
/// Cornish-Fisher correction, 1.96 + (1.96^3 + 1.96) / (4 dof), within 0.2%.
fn t_975(dof: usize) -> f64 {
    match dof {
        0 => f64::NAN,
        1..=30 => T_975[dof - 1],
        _ => 1.96 + (1.96f64.powi(3) + 1.96) / (4.0 * dof as f64),
    }
}

/// The mean of per-seed biases and the half width of its 95% confidence
/// interval (Student's t over the seeds, which are independent renders).
#[derive(Clone, Copy, Debug)]
struct BiasInterval {
    mean: f64,
    half_width: f64,
}

impl BiasInterval {
    fn of(biases: &[f64]) -> Self {
        let n = biases.len();
        let mean = biases.iter().sum::<f64>() / n as f64;
        let variance =
            biases.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0).max(1.0);
        Self {
            mean,
            half_width: t_975(n - 1) * (variance / n as f64).sqrt(),
        }
    }
}

/// The seeds of one scene, method and budget: a row of `summary.csv`.
struct Summary {
    scene: String,
    method: Series,
    spp: u32,
    /// How many seeds were rendered.
    seeds: usize,
    /// Medians over the seeds of the [`Row`] fields of the same names.
    seconds: f64,
    relmse: f64,
    rmse: f64,
    relmse_own: f64,
    total_seconds: f64,
    /// The per-seed biases' mean and 95% interval.
    bias: BiasInterval,
}

/// The header of `summary.csv`.
const SUMMARY_HEADER: &str = "scene,method,spp,seeds,median_seconds,median_relmse,median_rmse,mean_bias,bias_ci95_low,bias_ci95_high,median_relmse_own,median_total_seconds";

impl Summary {
    /// Summarises `rows`, the seeds of one scene, method and budget.
    fn of(rows: &[Row]) -> Self {
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
            bias: BiasInterval::of(&column(|r| r.bias)),
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
fn summarise(rows: &[Row]) -> Vec<Summary> {
    rows.chunk_by(|a, b| a.scene == b.scene && a.method == b.method && a.spp == b.spp)
        .map(Summary::of)
        .collect()
}

/// Runs `cirrus converge`.
pub fn run(args: ConvergeArgs) -> Result<()> {
    let scenes = scenes_or_default(args.scenes.clone(), default_scenes);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    for &peer in &args.peers {
        check_peer(peer)?;
    }
    with_threads(args.threads, || {
        let machine = machine_line();
        println!("{machine}\n");
        println!(
            "Threads: {}; {}x{} pixels; {} seeds per budget; box filter; reference: default method at {} spp. relMSE = mean (x - ref)^2 / (ref^2 + 0.01); bias = mean (x - ref) with its 95% interval over the seeds.\n",
            rayon::current_num_threads(),
            args.res.x,
            args.res.y,
            args.seeds,
            args.reference_spp
        );
        let (mut rows, mut summaries, mut equal_time) = (Vec::new(), Vec::new(), Vec::new());
        for path in &scenes {
            let name = scene_name(path);
            let scene_rows = converge_scene(&args, path, &name)?;
            let scene_summaries = summarise(&scene_rows);
            print_summary(&name, &scene_summaries);
            write_charts(&args.out, &name, &scene_summaries)?;
            equal_time.extend(equal_time_rows(&scene_summaries));
            rows.extend(scene_rows);
            summaries.extend(scene_summaries);
            // Rewritten after every scene, so a long study keeps what it has.
            write_csvs(&args.out, &rows, &summaries)?;
            if !args.peers.is_empty() {
                write_equal_time(&args.out, &machine, &equal_time)?;
            }
        }
        Ok(())
    })
}

/// Every render of one scene: per method, per budget, per seed.
fn converge_scene(args: &ConvergeArgs, path: &Path, name: &str) -> Result<Vec<Row>> {
    let scene = super::load_scene(path, None)?;
    let grid = RenderState::build(&scene, Some(args.res), StateOptions::default())?;
    let methods: Vec<Method> = if args.methods.is_empty() {
        METHODS
            .into_iter()
            .filter(|m| m.applies_to(&grid))
            .collect()
    } else {
        args.methods.clone()
    };
    let global = if methods.iter().any(|m| m.majorant() == MajorantKind::Global) {
        Some(RenderState::build(
            &scene,
            Some(args.res),
            StateOptions::global_majorant(),
        )?)
    } else {
        None
    };
    let key = reference_key(&scene, name)?;
    drop(scene);
    let reference = cached_reference(&grid, &args.out, &key, args.reference_spp)?;
    let study = Study {
        name,
        seeds: args.seeds,
        reference: &reference,
    };
    let mut rows = Vec::new();
    for method in methods {
        let state = match method.majorant() {
            MajorantKind::Grid => &grid,
            MajorantKind::Global => global.as_ref().expect("built when a method needs it"),
        };
        for spp in budgets(args.spp_max) {
            rows.extend(study.render_seeds(state, method, spp));
        }
    }
    if !args.peers.is_empty() {
        let folder = exported_folder(path)?;
        let mut peer_rows = Vec::new();
        for &peer in &args.peers {
            let scene = (name, key.as_str());
            peer_rows.extend(converge_peer(args, peer, &folder, scene, &reference)?);
        }
        let longest = peer_rows.iter().map(|r| r.seconds).fold(0.0, f64::max);
        study.extend_default(&grid, longest, &mut rows);
        rows.extend(peer_rows);
    }
    Ok(rows)
}

/// What every render of ours on one scene shares.
struct Study<'a> {
    name: &'a str,
    seeds: u32,
    reference: &'a [f32],
}

impl Study<'_> {
    /// One budget of one method: a render per seed, measured against the
    /// reference (which is also our own).
    fn render_seeds(&self, state: &RenderState, method: Method, spp: u32) -> Vec<Row> {
        (0..u64::from(self.seeds))
            .map(|seed| {
                let settings = method.settings(base_settings(Budget::Samples(spp), seed));
                let (rgb, stats) = render(state, &settings);
                let seconds = stats.elapsed.as_secs_f64();
                let key = (self.name, Series::Ours(method), spp, seed);
                Row::new(
                    key,
                    &rgb,
                    self.reference,
                    self.reference,
                    (seconds, seconds),
                )
            })
            .collect()
    }

    /// Renders our default method at twice, four times, ... its largest
    /// budget until its median time passes `seconds` (the peers' longest
    /// render; at most 65536 spp), so that `equal_time.md` reads our error at
    /// every peer time between measured points rather than extrapolating.
    /// The new rows go right after the default method's.
    fn extend_default(&self, state: &RenderState, seconds: f64, rows: &mut Vec<Row>) {
        let default = Series::Ours(Method::Default);
        let Some(last) = rows.iter().rposition(|r| r.method == default) else {
            return;
        };
        let mut spp = rows[last].spp;
        let mut extra: Vec<Row> = Vec::new();
        let mut reached = median(
            rows.iter()
                .filter(|r| r.method == default && r.spp == spp)
                .map(|r| r.seconds)
                .collect(),
        );
        while reached < seconds && spp < 1 << 16 {
            spp *= 2;
            let batch = self.render_seeds(state, Method::Default, spp);
            reached = median(batch.iter().map(|r| r.seconds).collect());
            extra.extend(batch);
        }
        rows.splice(last + 1..last + 1, extra);
    }
}

/// The exported scene folder the peers convert: a USD file's export in the
/// cache (the one `load_scene` rendered), else the folder given (or the
/// folder of the scene.json given).
fn exported_folder(path: &Path) -> Result<PathBuf> {
    if cirrus::scene::is_usd(path) {
        Ok(cirrus::scene::export_cached(path, None)?.dir)
    } else if path.is_dir() {
        Ok(path.to_owned())
    } else {
        Ok(path.parent().unwrap_or(Path::new(".")).to_owned())
    }
}

/// Every render of one peer on one scene (its name and [`reference_key`]):
/// its own reference (kept in --out as `<key>-<peer>-<w>x<h>-ref<spp>.exr`,
/// like ours), then each budget and seed, measured against our reference
/// and its own.
fn converge_peer(
    args: &ConvergeArgs,
    peer: Peer,
    folder: &Path,
    (name, key): (&str, &str),
    reference: &[f32],
) -> Result<Vec<Row>> {
    let label = value_name(peer);
    let own_spp = args.peer_reference_spp.unwrap_or(args.reference_spp);
    let own_path = reference_path(&args.out, &format!("{key}-{label}"), args.res, own_spp);
    let own = match read_rgb(&own_path, args.res) {
        Some(rgb) => rgb,
        None => {
            let budget = PeerBudget {
                spp: own_spp,
                seed: REFERENCE_SEED,
                warmup: false,
            };
            let r = render_peer(args, peer, folder, &own_path, budget)?;
            eprintln!("reference {}: {:.1} s", own_path.display(), r.seconds);
            r.rgb
        }
    };
    // Each render overwrites the last; the CSV keeps what was measured.
    let image = args.out.join(format!("{name}-{label}-last.exr"));
    let mut rows = Vec::new();
    for spp in budgets(args.spp_max) {
        for seed in 0..u64::from(args.seeds) {
            let budget = PeerBudget {
                spp,
                seed,
                warmup: true,
            };
            let r = render_peer(args, peer, folder, &image, budget)?;
            if rows.is_empty() {
                for warning in &r.warnings {
                    eprintln!("{label}: {warning}");
                }
            }
            let key = (name, Series::Peer(peer), spp, seed);
            rows.push(Row::new(
                key,
                &r.rgb,
                reference,
                &own,
                (r.seconds, r.total_seconds),
            ));
        }
    }
    Ok(rows)
}

/// scenes/peers/render_peer.py in the project's `.venv`.
fn render_peer_command() -> std::process::Command {
    let root = cirrus::scene::repo_root();
    let mut command = std::process::Command::new(root.join(".venv/bin/python"));
    command.arg(root.join("scenes/peers/render_peer.py"));
    command
}

/// Fails, with render_peer.py's reason, when `peer` cannot run here.
fn check_peer(peer: Peer) -> Result<()> {
    let out = render_peer_command()
        .args(["--available", &value_name(peer)])
        .output()
        .context("cannot run scenes/peers/render_peer.py with .venv/bin/python")?;
    anyhow::ensure!(
        out.status.success(),
        "peer {} is not available: {}",
        value_name(peer),
        String::from_utf8_lossy(&out.stderr).trim()
    );
    Ok(())
}

/// One peer render: its RGB, its times and the converter's warnings.
struct PeerRender {
    rgb: Vec<f32>,
    /// The timed render call, seconds (render_peer.py's `render_seconds`).
    seconds: f64,
    /// The whole peer process, seconds (`total_seconds`).
    total_seconds: f64,
    /// `warning: ...` lines: what the converter approximated.
    warnings: Vec<String>,
}

/// What one peer render is asked for.
#[derive(Clone, Copy)]
struct PeerBudget {
    spp: u32,
    seed: u64,
    /// Whether an untimed warm-up render comes first (timed renders; a
    /// reference needs no timing).
    warmup: bool,
}

/// Renders the exported scene `folder` with `peer` into `output` at --res
/// and `budget`, with --threads and our max depth.
fn render_peer(
    args: &ConvergeArgs,
    peer: Peer,
    folder: &Path,
    output: &Path,
    budget: PeerBudget,
) -> Result<PeerRender> {
    let mut command = render_peer_command();
    if !budget.warmup {
        command.arg("--no-warmup");
    }
    let out = command
        .arg(value_name(peer))
        .arg(folder)
        .arg(output)
        .args(["--spp", &budget.spp.to_string()])
        .args(["--seed", &budget.seed.to_string()])
        .args(["--threads", &args.threads.to_string()])
        .args(["--res", &format!("{}x{}", args.res.x, args.res.y)])
        .args(["--max-depth", &DEFAULT_MAX_DEPTH.to_string()])
        .output()
        .context("cannot run scenes/peers/render_peer.py with .venv/bin/python")?;
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    anyhow::ensure!(
        out.status.success(),
        "{} failed on {}:\n{stderr}",
        value_name(peer),
        folder.display()
    );
    let line = stdout
        .lines()
        .rev()
        .find(|l| l.starts_with("peer="))
        .with_context(|| format!("render_peer.py printed no timing line:\n{stdout}"))?;
    let field = |key: &str| -> Result<f64> {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .and_then(|v| v.parse().ok())
            .with_context(|| format!("no {key} in {line:?}"))
    };
    let rgb = read_rgb(output, args.res).with_context(|| {
        format!(
            "{} is not a {}x{} RGB EXR",
            output.display(),
            args.res.x,
            args.res.y
        )
    })?;
    Ok(PeerRender {
        rgb,
        seconds: field("render_seconds=")?,
        total_seconds: field("total_seconds=")?,
        warnings: stderr
            .lines()
            .filter(|l| l.starts_with("warning: "))
            .map(str::to_owned)
            .collect(),
    })
}

/// Writes `converge.csv` (`rows`) and `summary.csv` (`summaries`) into `out`.
fn write_csvs(out: &Path, rows: &[Row], summaries: &[Summary]) -> Result<()> {
    let table = |header: &str, lines: Vec<String>| format!("{header}\n{}\n", lines.join("\n"));
    let files = [
        (
            "converge.csv",
            table(ROWS_HEADER, rows.iter().map(Row::csv).collect()),
        ),
        (
            "summary.csv",
            table(SUMMARY_HEADER, summaries.iter().map(Summary::csv).collect()),
        ),
    ];
    for (file, text) in files {
        let path = out.join(file);
        cirrus::image::write_file(&path, text.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("Wrote {}", path.display());
    }
    Ok(())
}

/// Least-squares slope of ln median relMSE against ln spp over one method's
/// budgets: -1 for plain Monte Carlo, lower for QMC, flatter where the
/// reference's noise or a bias dominates.
fn spp_slope(summaries: &[Summary]) -> f64 {
    let points: Vec<(f64, f64)> = summaries
        .iter()
        .map(|s| (f64::from(s.spp).ln(), s.relmse.ln()))
        .collect();
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.0 / n, y + p.1 / n));
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(sxy, sxx), (x, y)| {
        (sxy + (x - mx) * (y - my), sxx + (x - mx).powi(2))
    });
    sxy / sxx
}

/// The summaries of each method of one scene (its budgets, in the order
/// rendered).
fn by_method(summaries: &[Summary]) -> impl Iterator<Item = &[Summary]> {
    summaries.chunk_by(|a, b| a.method == b.method)
}

/// One Markdown line per method: its largest budget's medians, the bias
/// interval there, and the relMSE slope over all budgets.
fn print_summary(name: &str, summaries: &[Summary]) {
    println!("### {name}\n");
    println!(
        "| method | flag | spp | seconds | relMSE | RMSE | bias (95% CI) | relMSE slope vs spp |"
    );
    println!("|---|---|---:|---:|---:|---:|---|---:|");
    for list in by_method(summaries) {
        let last = list.last().expect("a method has one budget at least");
        let method = last.method;
        println!(
            "| {} | {} | {} | {:.3} | {:.3e} | {:.3e} | {:.2e} ± {:.2e} | {:.2} |",
            method.name(),
            method.flag(),
            last.spp,
            last.seconds,
            last.relmse,
            last.rmse,
            last.bias.mean,
            last.bias.half_width,
            spp_slope(list)
        );
    }
    println!();
}

/// Samples per pixel: the x axis of the convergence charts against spp.
const SPP_AXIS: ChartAxis = ChartAxis {
    quantity: "samples per pixel",
    unit: "spp",
};

/// The charts of one scene, median relMSE over the seeds per series:
/// `<scene>-relmse-time.svg` (against median seconds) and
/// `<scene>-relmse-spp.svg`, both against our reference; with peers also
/// `<scene>-relmse-own-time.svg`, each renderer against its own reference.
fn write_charts(out: &Path, name: &str, summaries: &[Summary]) -> Result<()> {
    let curves = |x: fn(&Summary) -> f64, y: fn(&Summary) -> f64| {
        by_method(summaries)
            .map(|list| {
                let points = list.iter().map(|s| (x(s), y(s))).collect();
                (list[0].method.name(), points)
            })
            .collect::<Vec<(String, Vec<(f64, f64)>)>>()
    };
    let seconds = |s: &Summary| s.seconds;
    let relmse = |s: &Summary| s.relmse;
    let mut charts = vec![
        ("time", name.to_owned(), &TIME_AXIS, curves(seconds, relmse)),
        (
            "spp",
            name.to_owned(),
            &SPP_AXIS,
            curves(|s| f64::from(s.spp), relmse),
        ),
    ];
    if summaries
        .iter()
        .any(|s| matches!(s.method, Series::Peer(_)))
    {
        let title = format!("{name}, each renderer against its own reference");
        charts.push((
            "own-time",
            title,
            &TIME_AXIS,
            curves(seconds, |s| s.relmse_own),
        ));
    }
    for (suffix, title, axis, curves) in charts {
        let path = out.join(format!("{name}-relmse-{suffix}.svg"));
        write_chart(&path, &title, axis, ErrorMetric::RelMse, &curves)?;
        println!("Chart: {}", path.display());
    }
    println!();
    Ok(())
}

/// One peer budget of `equal_time.md`: the peer's medians and our default
/// method's at the same render time.
struct EqualTime {
    scene: String,
    peer: Peer,
    spp: u32,
    /// The peer's median render seconds.
    seconds: f64,
    /// The peer's median relMSE against our reference and against its own.
    peer_relmse: f64,
    peer_relmse_own: f64,
    /// Our default method's median relMSE at `seconds` (log-log in time).
    ours_relmse: f64,
    /// Whether `seconds` lies within our default method's measured times
    /// (else `ours_relmse` is extrapolated from the end segment).
    within: bool,
}

/// The equal-time comparisons of one scene: for each peer budget, our
/// default method's median relMSE read off at the peer's median time with
/// [`error_at_time`] (our error is against our reference, which is also our
/// own). Empty without peers or without the default method.
fn equal_time_rows(summaries: &[Summary]) -> Vec<EqualTime> {
    let ours: Vec<(f64, f64)> = summaries
        .iter()
        .filter(|s| s.method == Series::Ours(Method::Default))
        .map(|s| (s.seconds, s.relmse))
        .collect();
    let Some(((first, _), (last, _))) = ours.first().zip(ours.last()) else {
        return Vec::new();
    };
    summaries
        .iter()
        .filter_map(|s| match s.method {
            Series::Peer(peer) => Some(EqualTime {
                scene: s.scene.clone(),
                peer,
                spp: s.spp,
                seconds: s.seconds,
                peer_relmse: s.relmse,
                peer_relmse_own: s.relmse_own,
                ours_relmse: error_at_time(&ours, s.seconds),
                within: (*first..=*last).contains(&s.seconds),
            }),
            Series::Ours(_) => None,
        })
        .collect()
}

/// Writes `equal_time.md`: per scene, peer and budget, our relMSE over the
/// peer's at the peer's render time (below 1: we are more accurate in the
/// same time), against our reference and against each one's own.
fn write_equal_time(out: &Path, machine: &str, rows: &[EqualTime]) -> Result<()> {
    let mut text = format!(
        "# Equal-time relMSE, Cirrus (default method) against peers\n\n{machine}\n\n\
         At each peer budget, Cirrus' median relMSE at the peer's median render time (read \
         off Cirrus' curve, log-log in time; `*` = extrapolated past Cirrus' measured times) \
         over the peer's. Below 1: Cirrus is more accurate in the same time. Against our \
         reference, and against each renderer's own reference.\n\n\
         | scene | peer | peer spp | seconds | peer relMSE | Cirrus relMSE | ratio Cirrus/peer | peer relMSE (own ref) | ratio (own refs) |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        let mark = if r.within { "" } else { "*" };
        text.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.3e} | {:.3e}{mark} | {:.3}{mark} | {:.3e} | {:.3}{mark} |\n",
            r.scene,
            value_name(r.peer),
            r.spp,
            r.seconds,
            r.peer_relmse,
            r.ours_relmse,
            r.ours_relmse / r.peer_relmse,
            r.peer_relmse_own,
            r.ours_relmse / r.peer_relmse_own
        ));
    }
    let path = out.join("equal_time.md");
    cirrus::image::write_file(&path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    println!("{text}\nWrote {}", path.display());
    Ok(())
}

/// Default scenes: the smoke plume of `cirrus bench volumes` and the
/// StandardShaderBall of `cirrus bench render`.
fn default_scenes(repo: &Path) -> Vec<PathBuf> {
    vec![
        repo.join("scenes/bench/smoke.usda"),
        repo.join(
            "../shared/assets/usd-wg/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_names_parse_back_and_are_unique() {
        for m in METHODS {
            assert_eq!(parse_method(&m.name()), Ok(m));
        }
        let names: std::collections::HashSet<String> = METHODS.iter().map(|m| m.name()).collect();
        assert_eq!(names.len(), METHODS.len());
        assert!(parse_method("estimator-delta").is_err());
        assert_eq!(
            Method::Estimator(VolumeEstimator::ResidualRatio).name(),
            "estimator-residual-ratio"
        );
    }

    #[test]
    fn each_method_changes_only_its_field() {
        let base = base_settings(Budget::Samples(4), 7);
        let s = Method::Sampler(SamplerKind::Independent).settings(base.clone());
        assert_eq!(s.sampler, SamplerKind::Independent);
        assert_eq!(s.path.strategy, base.path.strategy);
        let s = Method::NoEquiangular.settings(base.clone());
        assert!(!s.path.equiangular && base.path.equiangular);
        assert_eq!(s.seed, 7);
        let s = Method::Majorant(MajorantKind::Global).settings(base.clone());
        assert_eq!(s.path.volume_estimator, base.path.volume_estimator);
        assert_eq!(
            Method::Majorant(MajorantKind::Global).majorant(),
            MajorantKind::Global
        );
    }

    #[test]
    fn budgets_double_up_to_the_largest() {
        assert_eq!(budgets(1), [1]);
        assert_eq!(budgets(16), [1, 2, 4, 8, 16]);
        assert_eq!(budgets(12), [1, 2, 4, 8, 12]);
    }

    #[test]
    fn bias_interval_is_students_t() {
        // Mean 2, sample standard deviation 1, 3 seeds: 4.303 / sqrt(3).
        let i = BiasInterval::of(&[1.0, 2.0, 3.0]);
        assert!((i.mean - 2.0).abs() < 1e-12);
        assert!((i.half_width - 4.303 / 3f64.sqrt()).abs() < 1e-9);
        // Past the table, within 0.2% of the exact quantiles.
        for (dof, exact) in [(31, 2.0395), (40, 2.0211), (120, 1.9799)] {
            assert!((t_975(dof) / exact - 1.0).abs() < 2e-3, "{dof}");
        }
    }

    #[test]
    fn slope_of_a_power_law_is_its_exponent() {
        let summaries: Vec<Summary> = [1, 2, 4, 8]
            .iter()
            .map(|&spp| Summary {
                scene: "s".into(),
                method: Series::Ours(Method::Default),
                spp,
                seeds: 2,
                seconds: 1.0,
                relmse: 0.5 / f64::from(spp),
                rmse: 0.0,
                relmse_own: 0.5 / f64::from(spp),
                total_seconds: 1.0,
                bias: BiasInterval::of(&[0.0, 0.0]),
            })
            .collect();
        assert!((spp_slope(&summaries) + 1.0).abs() < 1e-12);
    }
}
