//! The files a render of `-o OUT.exr` writes, and the refusal to overwrite
//! a finished output or drop an unfinished render unless asked (`--force`).

use std::path::{Path, PathBuf};

use super::FarmError;
use crate::file_error::FileError;
use crate::film::AovSet;
use crate::output::AovFiles;

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

impl OutputFiles {
    /// The files of a render to `exr` (or to a film state, `.film`) with
    /// the AOVs `aovs`.
    pub fn new(exr: &Path, files: AovFiles, aovs: &AovSet) -> Self {
        let mut finals = vec![exr.to_path_buf()];
        if !is_film_output(exr) {
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
    pub fn refuse_existing(&self, force: bool) -> Result<(), FarmError> {
        match self.finals.iter().find(|p| p.exists()) {
            Some(existing) if !force => Err(FarmError::Refused(format!(
                "{} exists; pass --force to overwrite it",
                existing.display()
            ))),
            _ => Ok(()),
        }
    }

    /// Refuses to start a render that would overwrite a finished output or
    /// drop an unfinished one, unless `force`; `resume` needs the checkpoint.
    /// With `force` and no `resume`, a stale checkpoint is removed.
    pub fn claim(&self, force: bool, resume: bool) -> Result<(), FarmError> {
        if resume && !self.checkpoint.exists() {
            return Err(FarmError::Refused(format!(
                "--resume: there is no checkpoint {} to continue",
                self.checkpoint.display()
            )));
        }
        if force {
            if !resume {
                remove_if_present(&self.checkpoint)?;
            }
            return Ok(());
        }
        self.refuse_existing(force)?;
        if !resume && self.checkpoint.exists() {
            return Err(FarmError::Refused(format!(
                "{} holds an unfinished render: pass --resume to continue it, or --force to start over",
                self.checkpoint.display()
            )));
        }
        Ok(())
    }

    /// Removes the checkpoint and the partial image once the render is done.
    pub fn finish(&self) -> Result<(), FarmError> {
        remove_if_present(&self.checkpoint)?;
        remove_if_present(&self.partial)
    }
}

fn remove_if_present(path: &Path) -> Result<(), FarmError> {
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
