//! The files a render of `-o OUT.exr` writes, and what happens to earlier
//! ones: a finished output is overwritten (atomically, when the new one is
//! whole) unless `--skip-existing` keeps it; an unfinished render's
//! checkpoint is continued with `--resume` and otherwise dropped.

use std::path::{Path, PathBuf};

use super::JobError;
use crate::file_error::FileError;
use crate::film::AovSet;
use crate::output::{preview_path, AovFiles};

/// The files a render of `-o OUT.exr` writes.
pub struct OutputFiles {
    /// The output and everything written beside it on success: for an EXR,
    /// the PNG preview and, with `--aov-files separate`, one EXR per AOV.
    pub finals: Vec<PathBuf>,
    /// `OUT.checkpoint`: the film state of an unfinished render.
    pub checkpoint: PathBuf,
    /// `OUT.partial.exr`: the image so far of an interrupted render.
    pub partial: PathBuf,
}

/// What [`OutputFiles::claim`] decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Claim {
    /// Render (over any finished output).
    Render,
    /// `--skip-existing` and the output is complete: render nothing.
    Complete,
}

impl OutputFiles {
    /// The files of a render to `exr` (or to a film state, `.film`) with
    /// the AOVs `aovs`.
    pub fn new(exr: &Path, files: AovFiles, aovs: &AovSet) -> Self {
        let mut finals = vec![exr.to_path_buf()];
        if !is_film_output(exr) {
            finals.push(preview_path(exr));
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

    /// The output: the EXR, or the film state of a part.
    pub fn output(&self) -> &Path {
        &self.finals[0]
    }

    /// Whether the output is complete: it exists and no checkpoint of an
    /// unfinished render lies beside it.
    pub fn is_complete(&self) -> bool {
        self.output().is_file() && !self.checkpoint.exists()
    }

    /// Decides, before anything is loaded, whether to render: not when
    /// `skip_existing` and the output is complete. Otherwise checks that the
    /// output can be written ([`prepare_folder`]) and, unless `resume` (which
    /// needs the checkpoint), drops an unfinished render's checkpoint and
    /// partial image: the render starts over, as husk does without
    /// `--autoresume`.
    pub fn claim(&self, skip_existing: bool, resume: bool) -> Result<Claim, JobError> {
        if resume && !self.checkpoint.exists() {
            return Err(JobError::Refused(format!(
                "--resume: there is no checkpoint {} to continue",
                self.checkpoint.display()
            )));
        }
        if skip_existing && !resume && self.is_complete() {
            return Ok(Claim::Complete);
        }
        prepare_folder(self.output())?;
        if !resume && self.checkpoint.exists() {
            log::warn!(
                "{}: starting over, dropping an unfinished render's checkpoint (--resume continues it)",
                self.checkpoint.display()
            );
            remove_if_present(&self.checkpoint)?;
            remove_if_present(&self.partial)?;
        }
        Ok(Claim::Render)
    }

    /// Removes the checkpoint and the partial image once the render is done.
    pub fn finish(&self) -> Result<(), JobError> {
        remove_if_present(&self.checkpoint)?;
        remove_if_present(&self.partial)
    }
}

/// Makes `output` writable before a render spends any time on it: refuses a
/// folder in its place, creates its missing folders (as husk does), and
/// creates and removes a probe file there, so an unwritable folder fails at
/// once with its name.
pub fn prepare_folder(output: &Path) -> Result<(), JobError> {
    if output.is_dir() {
        return Err(JobError::Refused(format!(
            "{} is a folder; -o names the file to write",
            output.display()
        )));
    }
    let folder = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(folder).map_err(|e| FileError::new("create the folder", folder, e))?;
    let probe = folder.join(format!(".cirrus-probe.{}", std::process::id()));
    std::fs::write(&probe, b"")
        .and_then(|()| std::fs::remove_file(&probe))
        .map_err(|e| FileError::new("write to the folder", folder, e))?;
    Ok(())
}

pub(super) fn remove_if_present(path: &Path) -> Result<(), JobError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(FileError::new("remove", path, e).into())
        }
        _ => Ok(()),
    }
}

/// Whether `-o` names a film state (`.film`) rather than an image.
pub fn is_film_output(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "film")
}
