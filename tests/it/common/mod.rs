//! Shared helpers for the integration tests: where the real assets and the
//! project's Python live, and scratch folders.

pub mod aovs;
pub mod motion;
pub mod render;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Debian's Python, which has pyopenvdb (the venv's does not).
pub const SYSTEM_PYTHON: &str = "/usr/bin/python3";

/// `cirrus render` of the stage `usda` into `dir/out.exr` at 8x8 and 4 spp,
/// beauty only, replacing any earlier output: the command's output.
pub fn render_tiny(usda: &Path, dir: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(["render".as_ref(), usda.as_os_str(), "-o".as_ref()])
        .arg(dir.join("out.exr"))
        .args(["--res", "8x8", "--spp", "4", "--aovs", "beauty"])
        .output()
        .unwrap()
}

/// `../shared/assets`: the real USD, VDB and texture assets the tests read,
/// beside the checkout (not part of the repository).
fn shared_assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets")
}

/// Whether `../shared/assets` is there for the calling test. When it is not,
/// says that the test is skipped and why, or panics where
/// `CIRRUS_REQUIRE_SHARED=1` (CI sets it, so a missing asset folder cannot
/// pass unnoticed there). Called through [`needs_shared!`].
pub fn shared_present() -> bool {
    let dir = shared_assets();
    if dir.is_dir() {
        return true;
    }
    let test = std::thread::current().name().unwrap_or("?").to_owned();
    let why = format!(
        "{} is missing (the shared assets are checked out beside the repository as ../shared)",
        dir.display()
    );
    assert!(
        std::env::var_os("CIRRUS_REQUIRE_SHARED").is_none(),
        "{test}: {why}, and CIRRUS_REQUIRE_SHARED is set"
    );
    eprintln!("{test}: skipped: {why}");
    false
}

/// Returns from the calling test, saying so, when `../shared/assets` is
/// missing ([`shared_present`]); the first line of every test that reads it.
macro_rules! needs_shared {
    () => {
        if !$crate::common::shared_present() {
            return;
        }
    };
}

/// A file under `../shared/assets`, checked to exist.
pub fn asset(rel: &str) -> PathBuf {
    let p = shared_assets().join(rel);
    assert!(p.exists(), "missing shared asset {}", p.display());
    p
}

/// A fresh scratch folder for one test, under cargo's per-target tmp dir.
/// Every module's tests run in this one process, in parallel: a name that
/// another test already claimed in this run panics rather than letting two
/// tests share a folder (the same test may take its folder afresh).
pub fn scratch(test: &str) -> PathBuf {
    static CLAIMED: std::sync::Mutex<std::collections::BTreeMap<String, String>> =
        std::sync::Mutex::new(std::collections::BTreeMap::new());
    let me = test_name();
    let owner = CLAIMED
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(test.to_owned())
        .or_insert_with(|| me.clone())
        .clone();
    assert_eq!(owner, me, "scratch folder {test:?} is {owner}'s already");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The running test's name, `module_test` (libtest names each test's thread
/// `module::test`): for the scratch folder of a helper that several tests call.
pub fn test_name() -> String {
    std::thread::current()
        .name()
        .unwrap_or("unnamed")
        .replace("::", "_")
}

/// Runs the `cirrus` binary with `args` and returns its stdout; panics with
/// its stderr when it fails.
pub fn cirrus_ok(args: &[&std::ffi::OsStr]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "cirrus {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The USD layer `text` written to `dir/stage.usda` and exported by
/// `cirrus export` into `dir/out`, which it returns.
pub fn export_usda(dir: &Path, text: &str) -> PathBuf {
    let usda = dir.join("stage.usda");
    std::fs::write(&usda, text).unwrap();
    let out = dir.join("out");
    cirrus_ok(&[
        "export".as_ref(),
        usda.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    out
}

/// The project's venv Python (usd-core, OpenEXR, numpy), made by `.ci/setup`.
pub fn venv_python() -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
    assert!(
        p.exists(),
        "{} is missing: run .ci/setup first",
        p.display()
    );
    p
}

/// Runs a Python script with arguments and returns its stdout; panics with
/// stderr on failure.
pub fn run_python(python: &Path, script: &Path, args: &[&str]) -> String {
    let out = Command::new(python)
        .arg(script)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{} {} failed:\n{}",
        python.display(),
        script.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// A script under `tests/python/`.
pub fn python_script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(name)
}

/// The mean of independent samples and its standard error.
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    pub mean: f64,
    pub sigma: f64,
}

/// Mean of `samples` and its standard error std / sqrt(n) (std with n - 1),
/// accumulated by Welford's update so large means do not cancel.
pub fn estimate<T: std::borrow::Borrow<f64>>(samples: impl IntoIterator<Item = T>) -> Estimate {
    let (mut n, mut mean, mut m2) = (0.0f64, 0.0f64, 0.0f64);
    for x in samples {
        let x = *x.borrow();
        n += 1.0;
        let delta = x - mean;
        mean += delta / n;
        m2 += delta * (x - mean);
    }
    assert!(n >= 2.0, "too few samples for a statistic");
    Estimate {
        mean,
        sigma: (m2 / (n - 1.0) / n).sqrt(),
    }
}

/// Asserts `measured` is within 4 sigma of `expected`, where sigma also
/// counts f32 rounding, `rounding` relative to `expected` (at least 1e-3 in
/// magnitude), so that a noise-free estimate is not asked for more digits
/// than f32 has; prints both on stderr.
pub fn assert_within_4_sigma(what: &str, measured: Estimate, expected: f64, rounding: f64) {
    let tolerance = 4.0 * measured.sigma.hypot(rounding * expected.abs().max(1e-3));
    eprintln!(
        "{what}: expected {expected:.6}, measured {:.6}, sigma {:.2e}",
        measured.mean, measured.sigma
    );
    assert!(
        (measured.mean - expected).abs() <= tolerance,
        "{what}: measured {:.6} +- {:.2e} (1 sigma), expected {expected:.6}",
        measured.mean,
        measured.sigma
    );
}

/// `scenes/tests/NAME.usda` exported once per test process into the scratch
/// folder `group/NAME` (tests running in parallel share it; the exporter
/// cache in the home folder is not involved, so a stale or concurrent export
/// cannot leak in).
pub fn exported_test_scene(name: &str, group: &str) -> PathBuf {
    static EXPORTS: std::sync::Mutex<std::collections::BTreeMap<String, PathBuf>> =
        std::sync::Mutex::new(std::collections::BTreeMap::new());
    let mut exports = EXPORTS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(dir) = exports.get(name) {
        return dir.clone();
    }
    let usda = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/tests")
        .join(format!("{name}.usda"));
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    cirrus_ok(&[
        "export".as_ref(),
        usda.as_os_str(),
        "-o".as_ref(),
        dir.as_os_str(),
    ]);
    exports.insert(name.to_owned(), dir.clone());
    dir
}

/// One line of `scenes/shared_scenes.txt`: a shared USD scene to export.
pub struct SharedScene {
    /// The asset path under `../shared/assets`.
    pub asset: String,
    /// The USD time code passed as `--frame`; empty for the stage's default time.
    pub frame: String,
}

/// Every shared USD scene the exporter must handle, from `scenes/shared_scenes.txt`
/// (`ASSET [FRAME]` per line, `#` starts a comment): what the exporter test
/// exports and the gallery renders.
pub fn shared_scenes() -> Vec<SharedScene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/shared_scenes.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    let scenes: Vec<SharedScene> = text
        .lines()
        .filter_map(|line| {
            let words: Vec<&str> = line.split('#').next().unwrap().split_whitespace().collect();
            let scene = |asset: &str, frame: &str| SharedScene {
                asset: asset.to_owned(),
                frame: frame.to_owned(),
            };
            match words[..] {
                [] => None,
                [asset] => Some(scene(asset, "")),
                [asset, frame] => Some(scene(asset, frame)),
                _ => panic!("{}: expected 'ASSET [FRAME]': {line:?}", path.display()),
            }
        })
        .collect();
    assert!(!scenes.is_empty(), "{} lists no scene", path.display());
    scenes
}

/// Every channel of an EXR as raw bits, by name.
pub fn channel_bits(path: &Path) -> Vec<(String, Vec<u32>)> {
    use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};
    let image =
        read_all_flat_layers_from_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = Vec::new();
    for layer in &image.layer_data {
        for channel in &layer.channel_data.list {
            let bits: Vec<u32> = match &channel.sample_data {
                FlatSamples::F16(v) => v.iter().map(|h| u32::from(h.to_bits())).collect(),
                FlatSamples::F32(v) => v.iter().map(|f| f.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
            };
            out.push((channel.name.to_string(), bits));
        }
    }
    out.sort();
    out
}

/// Runs `command`, panicking with its stderr unless it succeeds; its output.
pub fn succeeds(mut command: Command) -> Output {
    let out = command.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Starts `command`, a render writing `checkpoint` often, waits (at most a
/// minute) for its first checkpoint, then sends it `signal` ("TERM" or
/// "INT") and checks it stopped as an interrupted render does (exit code
/// 128 + the signal's number), not by finishing first.
pub fn interrupted_after_checkpoint(mut command: Command, checkpoint: &Path, signal: &str) {
    let child = command.spawn().unwrap();
    let start = std::time::Instant::now();
    while !checkpoint.exists() {
        assert!(
            start.elapsed().as_secs() < 60,
            "no checkpoint {}",
            checkpoint.display()
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let killed = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    let code = match signal {
        "INT" => 130,
        "TERM" => 143,
        other => panic!("no exit code known for SIG{other}"),
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "finished first? {stderr}");
}

/// Per band of `band` columns of `width` x `height` images (each a plane of
/// values and one of their variances): the mean over the images' pixels in
/// the band and the variance of that mean.
pub fn column_bands(
    images: &[(Vec<f64>, Vec<f64>)],
    (width, height): (usize, usize),
    band: usize,
) -> Vec<(f64, f64)> {
    let n = (images.len() * band * height) as f64;
    (0..width / band)
        .map(|b| {
            let (mut sum, mut variance) = (0.0, 0.0);
            for (value, var) in images {
                for y in 0..height {
                    for x in b * band..(b + 1) * band {
                        sum += value[y * width + x];
                        variance += var[y * width + x];
                    }
                }
            }
            (sum / n, variance / (n * n))
        })
        .collect()
}

/// Asserts every band of `a` (mean, variance of the mean) lies within 4
/// sigma of the same band of `b` (sigma from both variances, at least 1e-5
/// of the mean so noise-free bands are not asked for more digits than f32
/// has), printing each; `what` names the pair in messages.
pub fn assert_bands_agree(what: &str, a: &[(f64, f64)], b: &[(f64, f64)]) {
    assert_eq!(a.len(), b.len(), "{what}: band counts differ");
    for (band, ((x, vx), (y, vy))) in a.iter().zip(b).enumerate() {
        let sigma = (vx + vy).sqrt().max(1e-5 * x.abs());
        eprintln!("{what} band {band}: {x:.5} vs {y:.5}, sigma {sigma:.1e}");
        assert!(
            (x - y).abs() <= 4.0 * sigma,
            "{what} band {band}: {x} vs {y} (sigma {sigma})"
        );
    }
}

/// The widest gap between the same bands of `a` and `b`, in sigmas of
/// their difference: how clearly two renders differ somewhere.
pub fn widest_gap(a: &[(f64, f64)], b: &[(f64, f64)]) -> f64 {
    a.iter()
        .zip(b)
        .map(|((x, vx), (y, vy))| (x - y).abs() / (vx + vy).sqrt().max(1e-9))
        .fold(0.0, f64::max)
}
