//! What identifies a render in its film-state files, so a checkpoint is
//! resumed only by the render that made it and parts are merged only with
//! parts of their frame: the scene's content, the files it reads and every
//! setting that changes pixels ([`Fingerprint`]), the header of the EXRs
//! written from it, and the samples it takes of its frame.

use std::collections::BTreeMap;
use std::path::Path;

use glam::UVec2;
use serde::{Deserialize, Serialize};

use super::{JobError, PartInfo};
use crate::file_error::FileError;
use crate::film::{read_film_state, write_film_state, Film};
use crate::integrator::{Budget, RenderProgress, RenderSettings, Snapshot};
use crate::output::ExrHeader;
use crate::render_state::{RenderState, StateOptions};
use crate::scene::{Scene, MANIFEST_FILE};

/// Everything a checkpoint must match to be resumed, by name: the scene's
/// content, the files it reads, and every setting that changes pixels
/// (not the thread count, which does not).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fingerprint(BTreeMap<String, String>);

impl Fingerprint {
    /// The fingerprint of rendering `scene` at `resolution` with `settings`.
    pub fn new(
        scene: &Scene,
        resolution: UVec2,
        settings: &RenderSettings,
        options: StateOptions,
    ) -> Result<Self, JobError> {
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
            (
                "shutter",
                options
                    .shutter
                    .map_or_else(|| "the camera's".into(), |s| s.to_string()),
            ),
            ("aovs", settings.aovs.to_string()),
        ];
        // Only adaptive renders name it, so older checkpoints still match.
        let adaptive = settings.adaptive.map(|a| {
            let value = format!("{} (--min-spp {})", a.threshold, a.min_samples);
            ("noise-threshold", value)
        });
        Ok(Self(
            entries
                .into_iter()
                .chain(adaptive)
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
fn scene_hash(scene: &Scene) -> Result<String, JobError> {
    let crc = scene
        .content_crc()
        .map_err(|e| FileError::new("read", scene.dir.join(MANIFEST_FILE), e))?;
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
pub struct RenderIdentity {
    /// Scene content and every setting that changes pixels.
    pub fingerprint: Fingerprint,
    /// The header of the EXRs written from it.
    pub exr: ExrHeader,
    /// The samples it takes of its frame.
    pub part: PartInfo,
}

impl RenderIdentity {
    /// This identity with its EXR header naming every Cryptomatte id of
    /// `film` (a film of the render of `state`): what a film state or an
    /// image written from `film` carries.
    pub fn named(&self, state: &RenderState, film: &Film) -> Self {
        Self {
            exr: self.exr.named(state, film),
            ..self.clone()
        }
    }
}

/// A snapshot's film-state file header: the render's identity and progress.
#[derive(Debug, Deserialize)]
pub struct SnapshotHeader {
    /// Whose film it is.
    #[serde(flatten)]
    pub identity: RenderIdentity,
    /// How far it got.
    pub progress: RenderProgress,
}

/// [`SnapshotHeader`] borrowed, for writing.
#[derive(Serialize)]
struct SnapshotHeaderRef<'a> {
    #[serde(flatten)]
    identity: &'a RenderIdentity,
    progress: &'a RenderProgress,
}

/// Writes `snapshot` of the render `identity` to `path` (atomically): a
/// checkpoint, or a finished part for `cirrus merge`.
pub fn write_snapshot(
    path: &Path,
    identity: &RenderIdentity,
    snapshot: &Snapshot,
) -> Result<(), JobError> {
    let header = SnapshotHeaderRef {
        identity,
        progress: &snapshot.progress,
    };
    Ok(write_film_state(path, &snapshot.film, &header)?)
}

/// Reads a snapshot's film-state file.
pub fn read_snapshot(path: &Path) -> Result<(SnapshotHeader, Film), JobError> {
    Ok(read_film_state::<SnapshotHeader>(path)?)
}

/// Reads the checkpoint at `path` to continue the render `identity`, which
/// starts from `fresh`; refuses a damaged one or one made by another scene,
/// other settings or another part, listing every difference.
pub fn resume(
    path: &Path,
    identity: &RenderIdentity,
    fresh: &Snapshot,
    settings: &RenderSettings,
) -> Result<Snapshot, JobError> {
    let (header, film) = read_snapshot(path)?;
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
        return Err(JobError::Refused(format!(
            "{} was made by another render; resume it with its settings, or run without --resume to start over:\n  {}",
            path.display(),
            differences.join("\n  ")
        )));
    }
    let snapshot = Snapshot {
        film,
        progress: header.progress,
    };
    snapshot
        .check(fresh, settings)
        .map_err(|e| JobError::Refused(format!("{}: {e}", path.display())))?;
    Ok(snapshot)
}
