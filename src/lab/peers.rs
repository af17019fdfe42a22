//! Peer renderers (Mitsuba 3, Blender Cycles) driven through
//! `scenes/peers/render_peer.py` in the project's `.venv`: whether one can
//! run here, one render of an exported scene at a budget and seed, and a
//! peer's own reference, kept on disk like ours.
//!
//! Time is the same kind as ours: the peer's timed render call after an
//! untimed warm-up, without process start, scene conversion, load, BVH
//! build or JIT compilation; `total_seconds` adds its whole process.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::UVec2;

use super::reference::{read_rgb, reference_path, REFERENCE_SEED};
use super::{LabError, Result};
use crate::integrator::DEFAULT_MAX_DEPTH;
use crate::scene::is_usd;

/// A peer renderer, by its name in scenes/peers/render_peer.py, the CSVs
/// and the charts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Peer {
    /// Mitsuba 3 `scalar_rgb`.
    MitsubaScalar,
    /// Mitsuba 3 `llvm_ad_rgb` (Debian's libllvm19).
    MitsubaLlvm,
    /// Blender 5.0 Cycles on the CPU (the `bpy` wheel in `.venv-cycles`).
    Cycles,
    /// Debian's Blender 3.4 Cycles on the CPU, where installed.
    Cycles34,
}

impl Peer {
    /// Every peer, in `--help` order.
    pub const ALL: [Peer; 4] = [
        Self::MitsubaScalar,
        Self::MitsubaLlvm,
        Self::Cycles,
        Self::Cycles34,
    ];

    /// The name in `--peers`, render_peer.py, the CSVs and the charts.
    pub fn name(self) -> &'static str {
        match self {
            Self::MitsubaScalar => "mitsuba-scalar",
            Self::MitsubaLlvm => "mitsuba-llvm",
            Self::Cycles => "cycles",
            Self::Cycles34 => "cycles-3.4",
        }
    }

    /// What the peer is, for `--help`.
    pub fn about(self) -> &'static str {
        match self {
            Self::MitsubaScalar => "Mitsuba 3 `scalar_rgb`",
            Self::MitsubaLlvm => "Mitsuba 3 `llvm_ad_rgb` (Debian's libllvm19)",
            Self::Cycles => "Blender 5.0 Cycles on the CPU (the bpy wheel)",
            Self::Cycles34 => "Debian's Blender 3.4 Cycles on the CPU (ray-marched volumes)",
        }
    }
}

impl fmt::Display for Peer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Peer {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|p| p.name()).collect();
                format!("{s:?}: expected one of {}", names.join(", "))
            })
    }
}

/// scenes/peers/render_peer.py in the project's `.venv`.
fn render_peer_command() -> std::process::Command {
    let root = super::scenes::repo_root();
    let mut command = std::process::Command::new(root.join(".venv/bin/python"));
    command.arg(root.join("scenes/peers/render_peer.py"));
    command
}

/// The error of a render_peer.py that could not be started.
fn cannot_run_render_peer(source: std::io::Error) -> LabError {
    LabError::system(
        "cannot run scenes/peers/render_peer.py with .venv/bin/python",
        source,
    )
}

/// Fails, with render_peer.py's reason, when `peer` cannot run here.
pub(crate) fn check_peer(peer: Peer) -> Result<()> {
    let out = render_peer_command()
        .args(["--available", peer.name()])
        .output()
        .map_err(cannot_run_render_peer)?;
    if !out.status.success() {
        return Err(LabError::Failed(format!(
            "peer {peer} is not available: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(())
}

/// The exported scene folder the peers convert: a USD file's export in the
/// cache (the one `load_scene` rendered), else the folder given (or the
/// folder of the scene.json given).
pub(crate) fn exported_folder(path: &Path) -> Result<PathBuf> {
    if is_usd(path) {
        Ok(crate::scene::export_cached(path, &Default::default())?.dir)
    } else if path.is_dir() {
        Ok(path.to_owned())
    } else {
        Ok(path.parent().unwrap_or(Path::new(".")).to_owned())
    }
}

/// One peer render: its RGB, its times and the converter's warnings.
pub(crate) struct PeerRender {
    pub rgb: Vec<f32>,
    /// The timed render call, seconds (render_peer.py's `render_seconds`).
    pub seconds: f64,
    /// The whole peer process, seconds (`total_seconds`).
    pub total_seconds: f64,
    /// `warning: ...` lines: what the converter approximated.
    pub warnings: Vec<String>,
}

/// What one peer render is asked for.
#[derive(Clone, Copy)]
pub(crate) struct PeerBudget {
    pub spp: u32,
    pub seed: u64,
    /// Whether an untimed warm-up render comes first (timed renders; a
    /// reference needs no timing).
    pub warmup: bool,
}

/// One peer on one exported scene, at an image size and a thread count.
pub(crate) struct PeerRun<'a> {
    pub peer: Peer,
    /// The exported scene folder ([`exported_folder`]).
    pub folder: &'a Path,
    pub resolution: UVec2,
    pub threads: usize,
}

impl PeerRun<'_> {
    /// The peer's own reference of the scene whose reference key is `key`
    /// at `spp`: kept in `out` as `<key>-<peer>-<w>x<h>-ref<spp>.exr`, like
    /// ours, and rendered (without warm-up, with our reference seed) when
    /// not there yet.
    pub(crate) fn own_reference(&self, out: &Path, key: &str, spp: u32) -> Result<Vec<f32>> {
        let path = reference_path(out, &format!("{key}-{}", self.peer), self.resolution, spp);
        if let Some(rgb) = read_rgb(&path, self.resolution) {
            return Ok(rgb);
        }
        let budget = PeerBudget {
            spp,
            seed: REFERENCE_SEED,
            warmup: false,
        };
        let r = self.render(&path, budget)?;
        eprintln!("reference {}: {:.1} s", path.display(), r.seconds);
        Ok(r.rgb)
    }

    /// Renders the scene into `output` at `budget`, with our max depth.
    pub(crate) fn render(&self, output: &Path, budget: PeerBudget) -> Result<PeerRender> {
        let (peer, res) = (self.peer, self.resolution);
        let mut command = render_peer_command();
        if !budget.warmup {
            command.arg("--no-warmup");
        }
        let out = command
            .arg(peer.name())
            .arg(self.folder)
            .arg(output)
            .args(["--spp", &budget.spp.to_string()])
            .args(["--seed", &budget.seed.to_string()])
            .args(["--threads", &self.threads.to_string()])
            .args(["--res", &format!("{}x{}", res.x, res.y)])
            .args(["--max-depth", &DEFAULT_MAX_DEPTH.to_string()])
            .output()
            .map_err(cannot_run_render_peer)?;
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        if !out.status.success() {
            return Err(LabError::Failed(format!(
                "{peer} failed on {}:\n{stderr}",
                self.folder.display()
            )));
        }
        let line = stdout
            .lines()
            .rev()
            .find(|l| l.starts_with("peer="))
            .ok_or_else(|| {
                LabError::Failed(format!("render_peer.py printed no timing line:\n{stdout}"))
            })?;
        let field = |key: &str| -> Result<f64> {
            line.split_whitespace()
                .find_map(|w| w.strip_prefix(key))
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| LabError::Failed(format!("no {key} in {line:?}")))
        };
        let rgb = read_rgb(output, res).ok_or_else(|| {
            LabError::Failed(format!(
                "{} is not a {}x{} RGB EXR",
                output.display(),
                res.x,
                res.y
            ))
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
}
