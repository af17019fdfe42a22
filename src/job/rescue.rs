//! A finished render is never lost: its outputs are written (atomically),
//! and when that fails (a full disk, a folder gone or made read-only
//! mid-render) its film state is saved somewhere writable with the command
//! that writes the image from it once the problem is fixed. An interrupted
//! render saves its checkpoint and partial image (`--resume` continues it).

use std::path::{Path, PathBuf};

use super::files::is_film_output;
use super::{write_snapshot, JobError, OutputFiles, RenderIdentity};
use crate::image::Compression;
use crate::integrator::{RenderStats, Snapshot};
use crate::output::{preview_path, write_film, write_film_preview, AovFiles, Layers};

/// How the image of a render is written.
#[derive(Clone, Copy, Debug)]
pub struct ImageFormat<'a> {
    /// One multi-channel EXR, or one per AOV.
    pub aov_files: AovFiles,
    /// EXR compression.
    pub compression: Compression,
    /// The layers and their names.
    pub layers: &'a Layers,
}

/// Writes the finished render `end` to `files` (the film state of a part,
/// or the EXRs and the PNG preview) and removes its checkpoint and partial
/// image; returns the files written. A film of a window of the image (a
/// render product's `dataWindowNDC`) is written as the EXRs' data window;
/// the PNG preview shows that window alone. When writing fails, the film
/// state is saved by [`rescue`] and the error says where and how to write
/// the image.
pub fn write_finished(
    files: &OutputFiles,
    identity: &RenderIdentity,
    end: &Snapshot,
    stats: &RenderStats,
    format: ImageFormat<'_>,
) -> Result<Vec<PathBuf>, JobError> {
    let output = files.output();
    let written = if is_film_output(output) {
        write_snapshot(output, identity, end).map(|()| vec![output.to_path_buf()])
    } else {
        let preview = preview_path(output);
        write_film(
            output,
            format.aov_files,
            &end.film,
            &identity.exr,
            stats,
            format.compression,
            format.layers,
        )
        .and_then(|()| write_film_preview(&preview, &end.film))
        .map(|()| vec![output.to_path_buf(), preview])
        .map_err(JobError::from)
    };
    match written {
        Ok(written) => files.finish().map(|()| written),
        Err(error) => Err(rescue(files, identity, end, format, error)),
    }
}

/// Saves the film state of the finished render `end`, whose outputs could
/// not be written (`error`), in the first writable place of: its checkpoint
/// beside the output, `$XDG_CACHE_HOME/cirrus/rescued` (else
/// `~/.cache/cirrus/rescued`), the system temporary folder. Returns
/// [`JobError::Rescued`] with the command that writes the image from it.
fn rescue(
    files: &OutputFiles,
    identity: &RenderIdentity,
    end: &Snapshot,
    format: ImageFormat<'_>,
    error: JobError,
) -> JobError {
    let output = files.output();
    let mut identity = identity.clone();
    // `cirrus merge` writes the layers this file was to have.
    identity.exr = identity.exr.with_layers(format.layers);
    if !is_film_output(output) {
        // The whole frame as one finished part, so `cirrus merge` takes it
        // alone: the samples taken (known only now for a --time render).
        let taken = end.progress.first_sample..end.progress.next_sample();
        identity.part.frame_spp = taken.end;
        identity.part.samples = taken;
    }
    let name = output.file_stem().unwrap_or_default().to_string_lossy();
    let elsewhere = format!("{name}.{}.film", std::process::id());
    let places = [
        files.checkpoint.clone(),
        crate::scene::cache_root().join("rescued").join(&elsewhere),
        std::env::temp_dir().join(&elsewhere),
    ];
    let saved = places.into_iter().find(|state| {
        let folder = state.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(folder).is_ok() && write_snapshot(state, &identity, end).is_ok()
    });
    let Some(state) = saved else {
        return error;
    };
    let absolute = std::path::absolute(output);
    let output = absolute.as_deref().unwrap_or(output);
    let command = if is_film_output(output) {
        format!("mv {} {}", shell_word(&state), shell_word(output))
    } else {
        format!(
            "cirrus merge {} -o {} --aov-files {} --compression {}",
            shell_word(&state),
            shell_word(output),
            format.aov_files,
            format.compression
        )
    };
    let mut why = error.to_string();
    let mut cause = std::error::Error::source(&error);
    while let Some(c) = cause {
        why += &format!(": {c}");
        cause = c.source();
    }
    JobError::Rescued {
        error: why,
        state,
        command,
    }
}

/// `path` as one shell word: bare when it is plainly safe, else quoted.
fn shell_word(path: &Path) -> String {
    let text = path.to_string_lossy();
    let safe = |c: char| c.is_ascii_alphanumeric() || "/._-+,:=@".contains(c);
    if !text.is_empty() && text.chars().all(safe) {
        text.into_owned()
    } else {
        shell_quote(&text)
    }
}

/// `s` quoted for bash: one word, whatever it holds.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// Saves the checkpoint and the partial EXR of a render stopped at `end`
/// (a signal), for `--resume`; the partial EXR has the layers the
/// checkpoint's header records (the first product's).
pub fn save_interrupted(
    files: &OutputFiles,
    identity: &RenderIdentity,
    end: &Snapshot,
    stats: &RenderStats,
    compression: Compression,
) -> Result<(), JobError> {
    write_snapshot(&files.checkpoint, identity, end)?;
    let (film, header) = (&end.film, &identity.exr);
    let layers = header.layers().map_err(JobError::Refused)?;
    write_film(
        &files.partial,
        AovFiles::Single,
        film,
        header,
        stats,
        compression,
        &layers,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quotes_escape() {
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
    }
}
