//! Running the USD exporter (`exporter/export_usd.py`, under the project's
//! `.venv` Python) and caching its output. Exports are atomic: the exporter
//! writes a temporary folder beside the target, which is renamed into place
//! only when it succeeded, so a reader never sees half a scene.

use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;

use super::load::MANIFEST_FILE;
use crate::motion::Shutter;

/// Why an export did not produce a scene folder.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The exporter could not be started (no `.venv`, no script).
    #[error("cannot run the USD exporter {python} {script}: {error} (set CIRRUS_HOME to the Cirrus checkout, and run .ci/setup there)", python = python.display(), script = script.display())]
    Spawn {
        /// The interpreter tried (the project's `.venv` Python).
        python: PathBuf,
        /// `exporter/export_usd.py`.
        script: PathBuf,
        /// Why it did not start.
        error: std::io::Error,
    },
    /// The exporter ran and refused the input; `message` is its own message,
    /// without a Python traceback.
    #[error("{input}: export failed: {message}", input = input.display())]
    Failed {
        /// The USD file.
        input: PathBuf,
        /// The exporter's `error:` line.
        message: String,
    },
    /// A file system step (input, cache or output folder) failed.
    #[error("{path}: {error}", path = path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
}

/// What an export takes of the stage; the defaults are the stage's own.
#[derive(Clone, Copy, Debug, Default)]
pub struct ExportOptions<'a> {
    /// USD time code to export (default: the stage's start time, else the default time).
    pub frame: Option<f64>,
    /// Camera prim (default: the render product's or settings' camera, else
    /// the first); a path that is not a camera fails, listing the stage's cameras.
    pub camera: Option<&'a str>,
    /// `UsdRender.Settings` prim (default: the stage's `renderSettingsPrimPath`,
    /// else the only one); a path that is not one fails, listing them.
    pub settings: Option<&'a str>,
    /// Shutter interval, frames (default: the camera's).
    pub shutter: Option<Shutter>,
}

/// Exports `input` (any USD file) to the scene folder `out_dir` as
/// `options` say, replacing `out_dir` if it exists. The exporter's warnings
/// go to stderr as it wrote them.
pub fn export(input: &Path, out_dir: &Path, options: &ExportOptions) -> Result<(), ExportError> {
    let tmp = beside(out_dir, "tmp");
    remove_dir(&tmp)?;
    let result = run_exporter(input, &tmp, options).and_then(|()| {
        let old = beside(out_dir, "old");
        if out_dir.exists() {
            rename(out_dir, &old)?;
        }
        rename(&tmp, out_dir)?;
        remove_dir(&old)
    });
    if result.is_err() {
        // Best effort: the error being returned matters more than a stray temp folder.
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

/// Exports `input` into the cache (`$XDG_CACHE_HOME/cirrus`, else
/// `~/.cache/cirrus`) unless an export of the same absolute path, modification
/// time and `options`, by the same exporter sources, is already there, and
/// returns the scene folder and whether it was already there (its warnings
/// were then printed by an earlier run; the manifest keeps them). (Layers the
/// file references are not part of the key: after editing only a sublayer,
/// touch the top file or run `cirrus export`.)
pub fn export_cached(input: &Path, options: &ExportOptions) -> Result<CachedExport, ExportError> {
    let io = |path: &Path| {
        let path = path.to_owned();
        move |error| ExportError::Io { path, error }
    };
    let abs = std::fs::canonicalize(input).map_err(io(input))?;
    let mtime = std::fs::metadata(&abs)
        .and_then(|m| m.modified())
        .map_err(io(&abs))?;
    let mut hasher = DefaultHasher::new();
    let o = options;
    let shutter_bits = o.shutter.map(|s| (s.open.to_bits(), s.close.to_bits()));
    let frame_bits = o.frame.map(f64::to_bits);
    (&abs, mtime, frame_bits, o.camera, o.settings, shutter_bits).hash(&mut hasher);
    exporter_sources().hash(&mut hasher);
    let stem = abs.file_stem().unwrap_or_default().to_string_lossy();
    let cache = cache_root();
    let dir = cache.join(format!("{stem}-{:016x}", hasher.finish()));
    if dir.join(MANIFEST_FILE).is_file() {
        return Ok(CachedExport { dir, reused: true });
    }
    std::fs::create_dir_all(&cache).map_err(io(&cache))?;
    match export(&abs, &dir, options) {
        // Another process may have exported the same file at the same time.
        Err(_) if dir.join(MANIFEST_FILE).is_file() => Ok(CachedExport { dir, reused: true }),
        result => result.map(|()| CachedExport { dir, reused: false }),
    }
}

/// Where [`export_cached`] put a scene.
#[derive(Debug)]
pub struct CachedExport {
    /// The exported scene folder in the cache.
    pub dir: PathBuf,
    /// True when an earlier run had exported it (this run printed no warnings).
    pub reused: bool,
}

/// The exporter's Python sources, so that a changed exporter re-exports.
fn exporter_sources() -> Vec<Vec<u8>> {
    let folder = repo_root().join("exporter");
    let package = std::fs::read_dir(folder.join("cirrus_export"))
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "py"));
    let mut files: Vec<PathBuf> = package.chain([folder.join("export_usd.py")]).collect();
    files.sort();
    files.iter().filter_map(|f| std::fs::read(f).ok()).collect()
}

/// USD file extensions: such inputs are exported (through the cache) first.
const USD_EXTENSIONS: &[&str] = &["usd", "usda", "usdc", "usdz"];

/// Whether `path` names a USD file by its extension.
pub fn is_usd(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| USD_EXTENSIONS.contains(&e))
}

/// The Cirrus checkout holding `.venv`, `exporter/` and `scenes/`: `$CIRRUS_HOME`, else the
/// source folder this binary was built from.
pub fn repo_root() -> PathBuf {
    std::env::var_os("CIRRUS_HOME")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
}

/// Cirrus's cache folder: `$XDG_CACHE_HOME/cirrus`, else `~/.cache/cirrus`,
/// else `cirrus` in the system temporary folder.
pub fn cache_root() -> PathBuf {
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    base.join("cirrus")
}

fn run_exporter(input: &Path, out_dir: &Path, options: &ExportOptions) -> Result<(), ExportError> {
    let root = repo_root();
    let python = root.join(".venv/bin/python");
    let script = root.join("exporter/export_usd.py");
    let mut cmd = Command::new(&python);
    cmd.arg(&script).arg(input).arg("-o").arg(out_dir);
    if let Some(f) = options.frame {
        cmd.arg("--frame").arg(f.to_string());
    }
    if let Some(c) = options.camera {
        cmd.arg("--camera").arg(c);
    }
    if let Some(s) = options.settings {
        cmd.arg("--settings").arg(s);
    }
    if let Some(s) = options.shutter {
        cmd.arg(format!("--shutter={s}"));
    }
    let output = cmd.output().map_err(|error| ExportError::Spawn {
        python: python.clone(),
        script: script.clone(),
        error,
    })?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    if output.status.success() {
        eprint!("{stderr}");
        return Ok(());
    }
    let (warnings, message) = split_failure(&stderr);
    eprint!("{warnings}");
    // The exporter's messages open with the input, which ours names already.
    let named = format!("{}: ", input.display());
    let message = message.map(|m| m.strip_prefix(&named).map_or(m.clone(), str::to_owned));
    Err(ExportError::Failed {
        input: input.to_owned(),
        message: message.unwrap_or_else(|| format!("the exporter exited with {}", output.status)),
    })
}

/// Splits a failed export's stderr into what to pass through (warnings, from
/// the exporter or USD) and the error message: the exporter's `error: ` lines
/// (prefix dropped, as ours precedes it), else the last line of a Python
/// traceback (`ValueError: ...`, never the traceback itself), else all of it.
fn split_failure(stderr: &str) -> (String, Option<String>) {
    let (before, traceback) = match stderr.find("Traceback (most recent call last):") {
        Some(at) => stderr.split_at(at),
        None => (stderr, ""),
    };
    let (errors, warnings): (Vec<&str>, Vec<&str>) = before
        .lines()
        .filter(|l| !l.trim().is_empty())
        .partition(|l| l.starts_with("error: "));
    let warnings: String = warnings.iter().map(|l| format!("{l}\n")).collect();
    let last_traceback_line = traceback.lines().rev().find(|l| !l.trim().is_empty());
    if !errors.is_empty() {
        let message = errors
            .iter()
            .map(|l| &l["error: ".len()..])
            .collect::<Vec<_>>();
        (warnings, Some(message.join("\n")))
    } else if let Some(line) = last_traceback_line {
        (warnings, Some(line.trim().to_owned()))
    } else if !warnings.is_empty() {
        (String::new(), Some(warnings.trim_end().to_owned()))
    } else {
        (String::new(), None)
    }
}

/// A sibling of `path` for temporary use: `.NAME.PID.TAG`.
fn beside(path: &Path, tag: &str) -> PathBuf {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!(".{name}.{}.{tag}", std::process::id()))
}

fn rename(from: &Path, to: &Path) -> Result<(), ExportError> {
    std::fs::rename(from, to).map_err(|error| ExportError::Io {
        path: to.to_owned(),
        error,
    })
}

/// Removes a folder if it exists.
fn remove_dir(path: &Path) -> Result<(), ExportError> {
    match std::fs::remove_dir_all(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(ExportError::Io {
            path: path.to_owned(),
            error: e,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failure_message_is_the_exporters_error_line() {
        let usd_warning = "Warning: in _ReportErrors at line 3326: could not open asset\n";
        let (warnings, message) = split_failure(&format!("{usd_warning}error: x.usda: no mesh\n"));
        assert_eq!(warnings, usd_warning);
        assert_eq!(message.unwrap(), "x.usda: no mesh");

        let traceback =
            "Traceback (most recent call last):\n  File \"x.py\", line 3\nValueError: bad\n";
        let (warnings, message) = split_failure(&format!("{usd_warning}{traceback}"));
        assert_eq!(warnings, usd_warning);
        assert_eq!(message.unwrap(), "ValueError: bad");

        assert_eq!(
            split_failure("Segmentation fault\n").1.unwrap(),
            "Segmentation fault"
        );
        assert_eq!(split_failure("  \n"), (String::new(), None));
    }
}
