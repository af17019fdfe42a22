//! `cirrus converge`: the convergence study. For each scene and method
//! (`cirrus render`'s defaults with one flag changed), renders at 1, 2, 4,
//! ... spp with K seeds each and measures every image against a high-spp
//! reference of the default method: relMSE, RMSE and the mean bias (mean
//! over pixels and channels of image - reference) with its 95% confidence
//! interval across the seeds. Writes `converge.csv` (one row per render),
//! `summary.csv` (per budget: medians over the seeds and the bias interval)
//! and per scene two log-log SVG charts, relMSE against wall time and
//! against spp; prints a Markdown summary with machine, date and commit.
//!
//! An unbiased method's relMSE falls as 1/spp (slope -1 on the spp chart; QMC
//! can fall faster), until it reaches the reference's own noise, about the
//! 1-spp relMSE / reference spp. A bias interval that excludes 0 while the
//! relMSE stops falling marks a biased method (or a biased reference).
//!
//! Peers (Mitsuba 3, Blender Cycles; [`crate::lab::peers`]) add more
//! series, rendered at the same budgets and seeds from the same exported
//! scene. Their error is measured against our reference (`relmse`) and
//! against their own reference at the same spp (`relmse_own`, a third
//! chart), and `equal_time.md` gives our default method's relMSE over each
//! peer's at the peer's render times (the default method goes on doubling
//! its spp past the largest budget until it takes as long as the slowest
//! peer render, so that those times are matched, not extrapolated), then
//! the seconds each renderer takes to reach relMSE 1e-3 and 1e-4 against
//! its own reference (issue 20's equal-time report). Time is
//! the same kind for all: the render call alone (Cirrus: sampling, the
//! scene loaded and its BVH built; a peer: its timed render call);
//! `total_seconds` adds a peer's whole process.

mod method;
mod report;
mod rows;

use std::path::{Path, PathBuf};

use glam::UVec2;

use method::{budgets, Series, METHODS};
pub use method::{parse_method, Method};
use report::{equal_time_rows, print_summary, time_to_error_rows, write_charts, write_equal_time};
use rows::{summarise, write_csvs, Row};

use crate::file_error::FileError;
use crate::integrator::Budget;
use crate::lab::machine::{machine_line, with_threads};
use crate::lab::peers::{check_peer, exported_folder, Peer, PeerBudget, PeerRun};
use crate::lab::reference::{base_settings, cached_reference, reference_key, render};
use crate::lab::scenes::{scene_name, scenes_or_default};
use crate::lab::stats::median;
use crate::lab::Result;
use crate::render_state::{RenderState, StateOptions};
use crate::volumes::majorant::MajorantKind;

/// What the study renders.
pub struct ConvergeOptions {
    /// Scenes (USD or exported); none: [`DEFAULT_SCENES`].
    pub scenes: Vec<PathBuf>,
    /// Methods; none: every method that applies to each scene
    /// ([`Method::applies_to`]).
    pub methods: Vec<Method>,
    /// Largest budget: renders at 1, 2, 4, ... spp up to this (itself last
    /// when not a power of two).
    pub spp_max: u32,
    /// Seeds per budget (at least 2: the bias interval needs a spread).
    pub seeds: u32,
    /// Image size.
    pub resolution: UVec2,
    /// Samples per pixel of each scene's reference (default method, kept in
    /// `out` by scene, size and spp).
    pub reference_spp: u32,
    /// Worker threads (Cirrus' and each peer's).
    pub threads: usize,
    /// Peer renderers, rendered at the same budgets and seeds; each also
    /// renders its own reference.
    pub peers: Vec<Peer>,
    /// Samples per pixel of each peer's own reference (none:
    /// `reference_spp`).
    pub peer_reference_spp: Option<u32>,
    /// Folder for the CSVs, the charts and the references.
    pub out: PathBuf,
}

/// Default scenes, in `scenes/`: the smoke plume of `cirrus bench volumes`.
const DEFAULT_SCENES: [&str; 1] = ["bench/smoke.usda"];

/// Runs the study and prints its summary.
pub fn run(options: &ConvergeOptions) -> Result<()> {
    let scenes = scenes_or_default(options.scenes.clone(), &DEFAULT_SCENES);
    std::fs::create_dir_all(&options.out).map_err(|e| FileError::new("create", &options.out, e))?;
    for &peer in &options.peers {
        check_peer(peer)?;
    }
    with_threads(options.threads, || {
        let machine = machine_line();
        println!("{machine}\n");
        println!(
            "Threads: {}; {}x{} pixels; {} seeds per budget; box filter; reference: default method at {} spp. relMSE = mean (x - ref)^2 / (ref^2 + 0.01); bias = mean (x - ref) with its 95% interval over the seeds.\n",
            rayon::current_num_threads(),
            options.resolution.x,
            options.resolution.y,
            options.seeds,
            options.reference_spp
        );
        let (mut rows, mut summaries) = (Vec::new(), Vec::new());
        let (mut equal_time, mut times) = (Vec::new(), Vec::new());
        for path in &scenes {
            let name = scene_name(path);
            let scene_rows = converge_scene(options, path, &name)?;
            let scene_summaries = summarise(&scene_rows);
            print_summary(&name, &scene_summaries);
            write_charts(&options.out, &name, &scene_summaries)?;
            equal_time.extend(equal_time_rows(&scene_summaries));
            times.extend(time_to_error_rows(&scene_summaries));
            rows.extend(scene_rows);
            summaries.extend(scene_summaries);
            // Rewritten after every scene, so a long study keeps what it has.
            write_csvs(&options.out, &rows, &summaries)?;
            if !options.peers.is_empty() {
                write_equal_time(&options.out, &machine, &equal_time, &times)?;
            }
        }
        Ok(())
    })
}

/// Every render of one scene: per method, per budget, per seed.
fn converge_scene(options: &ConvergeOptions, path: &Path, name: &str) -> Result<Vec<Row>> {
    let scene = crate::scene::Scene::open(path, &Default::default())?;
    let grid = RenderState::build(&scene, Some(options.resolution), StateOptions::default())?;
    let methods: Vec<Method> = if options.methods.is_empty() {
        METHODS
            .into_iter()
            .filter(|m| m.applies_to(&grid))
            .collect()
    } else {
        options.methods.clone()
    };
    // One render state per other majorant a method needs.
    let mut others: Vec<(MajorantKind, RenderState)> = Vec::new();
    for kind in methods.iter().map(|m| m.majorant()) {
        if kind != MajorantKind::Grid && others.iter().all(|(k, _)| *k != kind) {
            let state_options = StateOptions {
                majorant: kind,
                ..StateOptions::default()
            };
            let state = RenderState::build(&scene, Some(options.resolution), state_options)?;
            others.push((kind, state));
        }
    }
    let key = reference_key(&scene, name)?;
    drop(scene);
    let reference = cached_reference(&grid, &options.out, &key, options.reference_spp)?;
    let study = Study {
        name,
        seeds: options.seeds,
        reference: &reference,
    };
    let mut rows = Vec::new();
    for method in methods {
        let kind = method.majorant();
        let state = others
            .iter()
            .find(|(k, _)| *k == kind)
            .map_or(&grid, |(_, state)| state);
        for spp in budgets(options.spp_max) {
            rows.extend(study.render_seeds(state, method, spp));
        }
    }
    if !options.peers.is_empty() {
        let folder = exported_folder(path)?;
        let mut peer_rows = Vec::new();
        for &peer in &options.peers {
            let scene = (name, key.as_str());
            peer_rows.extend(converge_peer(options, peer, &folder, scene, &reference)?);
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

/// Every render of one peer on one scene (its name and [`reference_key`]):
/// its own reference (kept in --out as `<key>-<peer>-<w>x<h>-ref<spp>.exr`,
/// like ours), then each budget and seed, measured against our reference
/// and its own.
fn converge_peer(
    options: &ConvergeOptions,
    peer: Peer,
    folder: &Path,
    (name, key): (&str, &str),
    reference: &[f32],
) -> Result<Vec<Row>> {
    let run = PeerRun {
        peer,
        folder,
        resolution: options.resolution,
        threads: options.threads,
    };
    let own_spp = options.peer_reference_spp.unwrap_or(options.reference_spp);
    let own = run.own_reference(&options.out, key, own_spp)?;
    // Each render overwrites the last; the CSV keeps what was measured.
    let image = options.out.join(format!("{name}-{peer}-last.exr"));
    let mut rows = Vec::new();
    for spp in budgets(options.spp_max) {
        for seed in 0..u64::from(options.seeds) {
            let budget = PeerBudget {
                spp,
                seed,
                warmup: true,
            };
            let r = run.render(&image, budget)?;
            if rows.is_empty() {
                for warning in &r.warnings {
                    eprintln!("{peer}: {warning}");
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
