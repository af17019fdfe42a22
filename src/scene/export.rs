//! Running the USD exporter (`exporter/export_usd.py`, under a Python with
//! usd-core; [`Exporter::locate`] says where both are found) and caching its
//! output. Exports are atomic: the exporter writes a temporary folder beside
//! the target, which is renamed into place only when it succeeded, so a
//! reader never sees half a scene.

use std::ffi::OsString;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;

use super::load::MANIFEST_FILE;
use crate::motion::Shutter;

/// Why an export did not produce a scene folder.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The exporter's script, or a Python to run it, is in none of the places
    /// [`Exporter::locate`] looks.
    #[error("cannot find the USD exporter's {what}: looked at {looked} (set {EXPORTER_VAR} to the exporter folder or {HOME_VAR} to a Cirrus checkout, and {PYTHON_VAR} to a Python with usd-core unless a .venv, made by .ci/setup, is beside the exporter folder)", looked = listed(looked))]
    NotFound {
        /// `export_usd.py` or `Python`.
        what: &'static str,
        /// Every path tried, in order.
        looked: Vec<PathBuf>,
    },
    /// The exporter was found but could not be started.
    #[error("cannot run the USD exporter {python} {script}: {error} (set {PYTHON_VAR} to a Python with usd-core, or run .ci/setup in the checkout)", python = python.display(), script = script.display())]
    Spawn {
        /// The interpreter tried.
        python: PathBuf,
        /// The exporter's `export_usd.py`.
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
    export_with(&Exporter::find()?, input, out_dir, options)
}

/// [`export`] by `exporter`.
fn export_with(
    exporter: &Exporter,
    input: &Path,
    out_dir: &Path,
    options: &ExportOptions,
) -> Result<(), ExportError> {
    let tmp = beside(out_dir, "tmp");
    remove_dir(&tmp)?;
    let result = exporter.run(input, &tmp, options).and_then(|()| {
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
    let exporter = Exporter::find()?;
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
    exporter.sources().hash(&mut hasher);
    let stem = abs.file_stem().unwrap_or_default().to_string_lossy();
    let cache = cache_root();
    let dir = cache.join(format!("{stem}-{:016x}", hasher.finish()));
    if dir.join(MANIFEST_FILE).is_file() {
        return Ok(CachedExport { dir, reused: true });
    }
    std::fs::create_dir_all(&cache).map_err(io(&cache))?;
    match export_with(&exporter, &abs, &dir, options) {
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

/// USD file extensions: such inputs are exported (through the cache) first.
const USD_EXTENSIONS: &[&str] = &["usd", "usda", "usdc", "usdz"];

/// Whether `path` names a USD file by its extension.
pub fn is_usd(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| USD_EXTENSIONS.contains(&e))
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

/// The variable naming the exporter folder (the one holding `export_usd.py`).
const EXPORTER_VAR: &str = "CIRRUS_EXPORTER";
/// The variable naming a Cirrus checkout, whose `exporter/` is used.
const HOME_VAR: &str = "CIRRUS_HOME";
/// The variable naming the Python that runs the exporter.
const PYTHON_VAR: &str = "CIRRUS_PYTHON";
/// The exporter's entry point, in its folder.
const SCRIPT: &str = "export_usd.py";

/// The USD exporter: its folder and the Python that runs it.
#[derive(Debug, PartialEq)]
struct Exporter {
    /// The folder holding `export_usd.py` and `cirrus_export/`.
    folder: PathBuf,
    /// A Python with usd-core, OpenEXR, numpy and MaterialX.
    python: PathBuf,
}

impl Exporter {
    /// The exporter of this process: [`Exporter::locate`] with its environment
    /// and its executable.
    fn find() -> Result<Self, ExportError> {
        let exe = std::env::current_exe().ok();
        let built_from = Path::new(env!("CARGO_MANIFEST_DIR"));
        Self::locate(
            |name| std::env::var_os(name),
            exe.as_deref(),
            Some(built_from),
        )
    }

    /// Finds the exporter folder, the first of these holding `export_usd.py`:
    /// 1. `$CIRRUS_EXPORTER` when set (then the only place looked);
    /// 2. else `$CIRRUS_HOME/exporter` when set (a Cirrus checkout; the only
    ///    place looked);
    /// 3. else beside the executable `exe`, PREFIX/bin/cirrus or
    ///    CHECKOUT/target/PROFILE/cirrus: `PREFIX/share/cirrus/exporter`
    ///    (installed by `.ci/install`), `CHECKOUT/exporter` (cargo's build
    ///    tree), and `CHECKOUT/exporter` for cargo's test binaries, one folder
    ///    deeper (`target/PROFILE/deps/`);
    /// 4. else, last, the `exporter/` of `built_from`, the checkout this binary
    ///    was built from, for a build whose target folder lies elsewhere
    ///    (`CARGO_TARGET_DIR`); an installed binary never reaches it.
    ///
    /// Then its Python: `$CIRRUS_PYTHON` when set (a path, or a name looked
    /// up on `PATH`), else `.venv/bin/python` beside the exporter folder (the
    /// checkout's `.venv` made by `.ci/setup`; `PREFIX/share/cirrus/.venv`
    /// installed). `var` reads an environment variable; an empty one counts
    /// as unset. Nothing found: [`ExportError::NotFound`], naming every place
    /// looked.
    fn locate(
        var: impl Fn(&str) -> Option<OsString>,
        exe: Option<&Path>,
        built_from: Option<&Path>,
    ) -> Result<Self, ExportError> {
        let var = |name: &str| var(name).filter(|v| !v.is_empty()).map(PathBuf::from);
        let beside_exe = |up: usize, rel: &str| exe?.ancestors().nth(up).map(|p| p.join(rel));
        let folders: Vec<PathBuf> = if let Some(folder) = var(EXPORTER_VAR) {
            vec![folder]
        } else if let Some(home) = var(HOME_VAR) {
            vec![home.join("exporter")]
        } else {
            [
                beside_exe(2, "share/cirrus/exporter"),
                beside_exe(3, "exporter"),
                beside_exe(4, "exporter"),
                built_from.map(|checkout| checkout.join("exporter")),
            ]
            .into_iter()
            .flatten()
            .collect()
        };
        let Some(folder) = folders.iter().find(|f| f.join(SCRIPT).is_file()) else {
            return Err(ExportError::NotFound {
                what: SCRIPT,
                looked: folders.iter().map(|f| f.join(SCRIPT)).collect(),
            });
        };
        // Absolute, so that the folder beside it is known for a relative one (`.`).
        let folder = std::path::absolute(folder).unwrap_or_else(|_| folder.clone());
        let python = match var(PYTHON_VAR) {
            Some(python) => python,
            None => {
                let venv = folder.parent().unwrap_or(&folder).join(".venv/bin/python");
                if !venv.is_file() {
                    return Err(ExportError::NotFound {
                        what: "Python",
                        looked: vec![venv],
                    });
                }
                venv
            }
        };
        Ok(Self { folder, python })
    }

    /// The exporter's Python sources, so that a changed exporter re-exports.
    fn sources(&self) -> Vec<Vec<u8>> {
        let package = std::fs::read_dir(self.folder.join("cirrus_export"))
            .into_iter()
            .flatten()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "py"));
        let mut files: Vec<PathBuf> = package.chain([self.folder.join(SCRIPT)]).collect();
        files.sort();
        files.iter().filter_map(|f| std::fs::read(f).ok()).collect()
    }

    /// Exports `input` into `out_dir` as `options` say.
    fn run(
        &self,
        input: &Path,
        out_dir: &Path,
        options: &ExportOptions,
    ) -> Result<(), ExportError> {
        let (python, script) = (&self.python, self.folder.join(SCRIPT));
        let mut cmd = Command::new(python);
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
            script,
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
            message: message
                .unwrap_or_else(|| format!("the exporter exited with {}", output.status)),
        })
    }
}

/// Paths, comma separated, for a message.
fn listed(paths: &[PathBuf]) -> String {
    let shown: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    shown.join(", ")
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

    /// An empty file at `root/rel`, its folders made.
    fn touch(root: &Path, rel: &str) {
        let path = root.join(rel);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, "").unwrap();
    }

    #[test]
    fn the_exporter_is_found_where_its_search_order_says() {
        let root = std::env::temp_dir().join(format!("cirrus-locate-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let (checkout, prefix) = (root.join("checkout"), root.join("prefix"));
        for rel in ["exporter/export_usd.py", ".venv/bin/python"] {
            touch(&checkout, rel);
            touch(&prefix, &format!("share/cirrus/{rel}"));
        }
        touch(&root, "copy/export_usd.py");
        let vars = |pairs: &'static [(&'static str, &'static str)]| {
            let root = root.clone();
            move |name: &str| {
                let (_, value) = pairs.iter().find(|(n, _)| *n == name)?;
                Some(root.join(value).into_os_string())
            }
        };
        let found = |folder: &Path, python: &Path| Exporter {
            folder: folder.to_owned(),
            python: python.to_owned(),
        };
        let venv = |base: &Path| base.join(".venv/bin/python");
        let build_exe = checkout.join("target/release/cirrus");

        // Beside the executable: the build tree, a test binary, an install.
        let in_checkout = found(&checkout.join("exporter"), &venv(&checkout));
        let locate = |exe: &Path| Exporter::locate(|_| None, Some(exe), None).unwrap();
        assert_eq!(locate(&build_exe), in_checkout);
        assert_eq!(
            locate(&checkout.join("target/release/deps/t-1")),
            in_checkout
        );
        let share = prefix.join("share/cirrus");
        let installed = found(&share.join("exporter"), &venv(&share));
        assert_eq!(locate(&prefix.join("bin/cirrus")), installed);

        // CIRRUS_HOME, then CIRRUS_EXPORTER, win over the executable's place;
        // CIRRUS_PYTHON over the .venv.
        let home = Exporter::locate(vars(&[("CIRRUS_HOME", "checkout")]), Some(&prefix), None);
        assert_eq!(home.unwrap(), in_checkout);
        let both = &[
            ("CIRRUS_HOME", "prefix"),
            ("CIRRUS_EXPORTER", "checkout/exporter"),
        ];
        assert_eq!(
            Exporter::locate(vars(both), None, None).unwrap(),
            in_checkout
        );
        let copy = &[("CIRRUS_EXPORTER", "copy"), ("CIRRUS_PYTHON", "py")];
        let copied = Exporter::locate(vars(copy), Some(&build_exe), None).unwrap();
        assert_eq!(copied, found(&root.join("copy"), &root.join("py")));

        // Not found: every place looked, and the variables to set.
        let message = |result: Result<Exporter, ExportError>| result.unwrap_err().to_string();
        let far = root.join("far/target/release/cirrus");
        // Last, the checkout the binary was built from (a target folder elsewhere).
        let built_elsewhere = Exporter::locate(|_| None, Some(&far), Some(&checkout));
        assert_eq!(built_elsewhere.unwrap(), in_checkout);
        let nowhere = message(Exporter::locate(|_| None, Some(&far), None));
        for looked in [
            "far/target/share/cirrus/exporter",
            "far/exporter",
            "exporter",
        ] {
            let path = root.join(looked).join("export_usd.py");
            assert!(nowhere.contains(&path.display().to_string()), "{nowhere}");
        }
        for var in ["CIRRUS_EXPORTER", "CIRRUS_HOME", "CIRRUS_PYTHON"] {
            assert!(nowhere.contains(var), "{nowhere}");
        }
        let missing = message(Exporter::locate(
            vars(&[("CIRRUS_EXPORTER", "none")]),
            Some(&build_exe),
            None,
        ));
        let expected = format!("looked at {} (", root.join("none/export_usd.py").display());
        assert!(missing.contains(&expected), "{missing}");
        let no_python = message(Exporter::locate(
            vars(&[("CIRRUS_EXPORTER", "copy")]),
            None,
            None,
        ));
        assert!(
            no_python.contains(&venv(&root).display().to_string()),
            "{no_python}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
