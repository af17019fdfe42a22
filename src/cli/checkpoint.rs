//! Long renders lose nothing: the files a render writes and the refusal to
//! overwrite them without `--force`, checkpoints (`--checkpoint-every`,
//! SIGINT/SIGTERM) and `--resume`, refused when the checkpoint belongs to
//! another scene or other settings.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use glam::UVec2;
use serde::{Deserialize, Serialize};

use super::split::PartInfo;
use cirrus::film::AovSet;
use cirrus::film::Film;
use cirrus::film::{read_film_state, write_film_state};
use cirrus::integrator::{Budget, FilmState, RenderProgress, RenderSettings};
use cirrus::output::{AovFiles, ExrHeader};
use cirrus::render_state::StateOptions;
use cirrus::scene::{Scene, MANIFEST_FILE};

/// The files a render of `-o OUT.exr` writes.
pub(super) struct OutputFiles {
    /// The output and everything written beside it on success: for an EXR,
    /// the PNG preview and, with `--aov-files separate`, one EXR per AOV.
    pub finals: Vec<PathBuf>,
    /// `OUT.checkpoint`: the film state of an unfinished render.
    pub checkpoint: PathBuf,
    /// `OUT.partial.exr`: the image so far of an interrupted render.
    pub partial: PathBuf,
}

impl OutputFiles {
    /// The files of a render to `exr` (or to a film state, `.film`) with
    /// the AOVs `aovs`.
    pub fn new(exr: &Path, files: AovFiles, aovs: &AovSet) -> Self {
        let mut finals = vec![exr.to_path_buf()];
        if !super::split::is_film_output(exr) {
            finals.push(exr.with_extension("png"));
            if files == AovFiles::Separate {
                let per_aov = aovs.aovs().iter();
                finals.extend(per_aov.map(|a| exr.with_extension(format!("{}.exr", a.name()))));
            }
        }
        Self {
            finals,
            checkpoint: exr.with_extension("checkpoint"),
            partial: exr.with_extension("partial.exr"),
        }
    }

    /// Refuses to overwrite a finished output unless `force`.
    pub fn refuse_existing(&self, force: bool) -> Result<()> {
        match self.finals.iter().find(|p| p.exists()) {
            Some(existing) if !force => bail!(
                "{} exists; pass --force to overwrite it",
                existing.display()
            ),
            _ => Ok(()),
        }
    }

    /// Refuses to start a render that would overwrite a finished output or
    /// drop an unfinished one, unless `force`; `resume` needs the checkpoint.
    /// With `force` and no `resume`, a stale checkpoint is removed.
    pub fn claim(&self, force: bool, resume: bool) -> Result<()> {
        if resume && !self.checkpoint.exists() {
            bail!(
                "--resume: there is no checkpoint {} to continue",
                self.checkpoint.display()
            );
        }
        if force {
            if !resume {
                remove_if_present(&self.checkpoint)?;
            }
            return Ok(());
        }
        self.refuse_existing(force)?;
        if !resume && self.checkpoint.exists() {
            bail!(
                "{} holds an unfinished render: pass --resume to continue it, or --force to start over",
                self.checkpoint.display()
            );
        }
        Ok(())
    }

    /// Removes the checkpoint and the partial image once the render is done.
    pub fn finish(&self) -> Result<()> {
        remove_if_present(&self.checkpoint)?;
        remove_if_present(&self.partial)
    }
}

fn remove_if_present(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("cannot remove {}", path.display()))
        }
        _ => Ok(()),
    }
}

/// Everything a checkpoint must match to be resumed, by name: the scene's
/// content, the files it reads, and every setting that changes pixels
/// (not the thread count, which does not).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(super) struct Fingerprint(BTreeMap<String, String>);

impl Fingerprint {
    /// The fingerprint of rendering `scene` at `resolution` with `settings`.
    pub fn new(
        scene: &Scene,
        resolution: UVec2,
        settings: &RenderSettings,
        options: StateOptions,
    ) -> Result<Self> {
        let p = &settings.path;
        let entries = [
            ("cirrus", env!("CARGO_PKG_VERSION").to_string()),
            ("scene", scene_hash(scene)?),
            ("scene files", files_hash(scene)),
            ("resolution", format!("{}x{}", resolution.x, resolution.y)),
            (
                "budget",
                match settings.budget {
                    Budget::Samples(n) => format!("--spp {n}"),
                    Budget::Time(t) => format!("--time {}", t.as_secs_f64()),
                },
            ),
            ("seed", settings.seed.to_string()),
            ("sampler", format!("{:?}", settings.sampler)),
            ("filter", format!("{:?}", settings.filter)),
            ("strategy", format!("{:?}", p.strategy)),
            ("max-depth", p.max_depth.to_string()),
            ("clamp", format!("{:?}", p.clamp)),
            ("volume-estimator", format!("{:?}", p.volume_estimator)),
            ("equiangular", p.equiangular.to_string()),
            ("majorant", format!("{:?}", options.majorant)),
            ("volume-light-sampling", options.volume_lights.to_string()),
            ("aovs", settings.aovs.to_string()),
        ];
        Ok(Self(
            entries
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
        ))
    }

    /// One line per entry that differs from `other`, e.g. `seed:
    /// checkpoint 3, this render 4` with `labels` ["checkpoint", "this render"].
    pub fn differences(&self, other: &Fingerprint, labels: [&str; 2]) -> Vec<String> {
        let keys: std::collections::BTreeSet<&String> =
            self.0.keys().chain(other.0.keys()).collect();
        let show = |m: &BTreeMap<String, String>, k: &String| {
            m.get(k).cloned().unwrap_or_else(|| "(none)".into())
        };
        keys.into_iter()
            .filter(|k| self.0.get(*k) != other.0.get(*k))
            .map(|k| {
                format!(
                    "{k}: {} {}, {} {}",
                    labels[0],
                    show(&self.0, k),
                    labels[1],
                    show(&other.0, k)
                )
            })
            .collect()
    }
}

/// [`Scene::content_crc`] as hex.
fn scene_hash(scene: &Scene) -> Result<String> {
    let crc = scene
        .content_crc()
        .with_context(|| format!("cannot read {}", scene.dir.join(MANIFEST_FILE).display()))?;
    Ok(format!("{crc:08x}"))
}

/// The VDB and texture files the scene reads: their count and a CRC-32 of
/// their paths, sizes and modification times (a changed file changes it).
fn files_hash(scene: &Scene) -> String {
    let m = &scene.manifest;
    let files: Vec<&Path> = m
        .volumes
        .iter()
        .flat_map(|v| v.fields.values().map(|f| f.file.as_path()))
        .chain(m.textures.iter().map(|t| t.file.as_path()))
        .collect();
    let mut crc = crc32fast::Hasher::new();
    for file in &files {
        crc.update(file.as_os_str().as_encoded_bytes());
        if let Ok(meta) = std::fs::metadata(file) {
            crc.update(&meta.len().to_le_bytes());
            let modified = meta.modified().ok();
            let since = modified.and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok());
            crc.update(&since.unwrap_or_default().as_nanos().to_le_bytes());
        }
    }
    format!("{} files, {:08x}", files.len(), crc.finalize())
}

/// What identifies a render in its film-state files: the scene and
/// settings, the EXR header its image will carry, and its place in the frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(super) struct RenderIdentity {
    /// Scene content and every setting that changes pixels.
    pub fingerprint: Fingerprint,
    /// The header of the EXRs written from it.
    pub exr: ExrHeader,
    /// The samples it takes of its frame.
    pub part: PartInfo,
}

/// A film-state file's header: the render's identity and progress.
#[derive(Debug, Deserialize)]
pub(super) struct FilmStateHeader {
    /// Whose film it is.
    #[serde(flatten)]
    pub identity: RenderIdentity,
    /// How far it got.
    pub progress: RenderProgress,
}

/// [`FilmStateHeader`] borrowed, for writing.
#[derive(Serialize)]
struct FilmStateHeaderRef<'a> {
    #[serde(flatten)]
    identity: &'a RenderIdentity,
    progress: &'a RenderProgress,
}

/// Writes `state` of the render `identity` to `path` (atomically): a
/// checkpoint, or a finished part for `cirrus merge`.
pub(super) fn write(path: &Path, identity: &RenderIdentity, state: &FilmState) -> Result<()> {
    let header = FilmStateHeaderRef {
        identity,
        progress: &state.progress,
    };
    Ok(write_film_state(path, &state.film, &header)?)
}

/// Reads a film-state file.
pub(super) fn read(path: &Path) -> Result<(FilmStateHeader, Film)> {
    Ok(read_film_state::<FilmStateHeader>(path)?)
}

/// Reads the checkpoint at `path` to continue the render `identity`, which
/// starts from `fresh`; refuses a damaged one or one made by another scene,
/// other settings or another part, listing every difference.
pub(super) fn load(
    path: &Path,
    identity: &RenderIdentity,
    fresh: &FilmState,
    settings: &RenderSettings,
) -> Result<FilmState> {
    let (header, film) = read(path)?;
    let saved = &header.identity;
    let mut differences = saved
        .fingerprint
        .differences(&identity.fingerprint, ["checkpoint", "this render"]);
    if saved.part != identity.part {
        differences.push(format!(
            "part: checkpoint samples {:?}, this render {:?}",
            saved.part.samples, identity.part.samples
        ));
    }
    if !differences.is_empty() {
        bail!(
            "{} was made by another render; resume with its settings or pass --force to start over:\n  {}",
            path.display(),
            differences.join("\n  ")
        );
    }
    let state = FilmState {
        film,
        progress: header.progress,
    };
    state
        .check(fresh, settings)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(state)
}

/// SIGINT and SIGTERM: the first asks the render to stop after the tiles
/// in flight (it then saves a checkpoint); a second one exits at once.
pub(super) struct StopSignal {
    stop: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

impl StopSignal {
    /// Installs the handlers.
    pub fn install() -> Result<Self> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let stop = Arc::new(AtomicBool::new(false));
        let signal = Arc::new(AtomicUsize::new(0));
        for sig in [SIGINT, SIGTERM] {
            // Registered first, so it sees the flag as the previous signal left it.
            signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&stop))?;
            signal_hook::flag::register(sig, Arc::clone(&stop))?;
            signal_hook::flag::register_usize(sig, Arc::clone(&signal), sig as usize)?;
        }
        Ok(Self { stop, signal })
    }

    /// Whether a stop was asked.
    pub fn requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The signal that asked, if any (for the exit code, 128 + signal).
    pub fn signal(&self) -> Option<i32> {
        match self.signal.load(Ordering::Relaxed) {
            0 => None,
            s => Some(s as i32),
        }
    }
}

/// A render stopped by a signal after saving its checkpoint: exits with
/// 128 + the signal number, like a shell reports it.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub(super) struct Interrupted {
    /// The signal that stopped the render.
    pub signal: i32,
    /// What was saved and how to resume.
    pub message: String,
}
