//! Long renders lose nothing: a render stopped by SIGTERM or SIGINT
//! saves a checkpoint and a partial EXR and resumes to an image bit-identical
//! to an uninterrupted one; damaged or foreign checkpoints are refused;
//! an unfinished render's checkpoint is continued only with `--resume`, and a
//! render killed while writing leaves the previous file whole.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use exr::prelude::*;

/// A scene with surfaces, a volume, several materials and lights, so every
/// AOV accumulator (sums, depth, Cryptomatte) is exercised.
fn scene() -> PathBuf {
    common::exported_test_scene("aovs_mixed", "reliability")
}

/// `cirrus render` of the test scene to `out` at `spp` with `extra` flags;
/// 96x64, all AOVs and seed 3 unless `extra` sets them.
fn command(out: &Path, spp: u32, extra: &[&str]) -> Command {
    command_for(&scene(), out, spp, extra)
}

/// [`command`] for another scene.
fn command_for(scene: &Path, out: &Path, spp: u32, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    c.arg("render").arg(scene).arg("-o").arg(out);
    for (flag, value) in [("--res", "96x64"), ("--aovs", "all"), ("--seed", "3")] {
        if !extra.contains(&flag) {
            c.args([flag, value]);
        }
    }
    c.args(["--spp", &spp.to_string()])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// The text attribute `name` of an EXR's first layer.
fn text_attribute(path: &Path, name: &str) -> String {
    let meta = MetaData::read_from_file(path, false).unwrap();
    match meta.headers[0].own_attributes.other.get(&Text::from(name)) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{}: no text attribute {name}: {other:?}", path.display()),
    }
}

/// Waits until `ready` holds (polling), panicking after a minute.
fn wait_for(what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Sends `signal` (e.g. "TERM") to the child and waits for it.
fn signal_and_wait(child: Child, signal: &str) -> (ExitStatus, String) {
    let status = Command::new("kill")
        .args([format!("-{signal}"), child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "kill -{signal} failed");
    let out = child.wait_with_output().unwrap();
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn modified(path: &Path) -> Option<std::time::SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// Interrupted twice (SIGTERM, then SIGINT after resuming on another thread
/// count) and resumed: every channel equals the uninterrupted render's, bit
/// for bit; each stop exits with 128 + the signal, leaves a checkpoint and a
/// readable partial EXR marked incomplete, and nothing under the final name.
#[test]
fn interrupted_and_resumed_renders_are_bit_identical() {
    let dir = common::scratch("reliability_resume");
    let spp = 192;
    let whole = dir.join("whole.exr");
    common::succeeds(command(&whole, spp, &["--threads", "2"]));

    let exr = dir.join("resumed.exr");
    let checkpoint = dir.join("resumed.checkpoint");
    let partial = dir.join("resumed.partial.exr");
    let mut last_checkpoint = None;
    for (run, (signal, code, threads)) in [("TERM", 143, "2"), ("INT", 130, "1")]
        .into_iter()
        .enumerate()
    {
        let mut flags = vec!["--threads", threads, "--checkpoint-every", "0.2"];
        if run > 0 {
            flags.push("--resume");
        }
        let child = command(&exr, spp, &flags).spawn().unwrap();
        wait_for("a new checkpoint", || {
            let now = modified(&checkpoint);
            now.is_some() && now != last_checkpoint
        });
        let (status, stderr) = signal_and_wait(child, signal);
        assert_eq!(status.code(), Some(code), "SIG{signal}: {stderr}");
        assert!(stderr.contains("--resume"), "SIG{signal}: {stderr}");
        assert!(
            !exr.exists() && !exr.with_extension("png").exists(),
            "SIG{signal}: wrote the final output"
        );
        assert_eq!(text_attribute(&partial, "cirrus/complete"), "false");
        let taken: u32 = text_attribute(&partial, "cirrus/spp").parse().unwrap();
        assert!(taken < spp, "SIG{signal}: the render finished first");
        last_checkpoint = modified(&checkpoint);
    }
    common::succeeds(command(&exr, spp, &["--threads", "2", "--resume"]));
    assert!(
        !checkpoint.exists() && !partial.exists(),
        "checkpoint or partial EXR left behind after finishing"
    );
    assert_eq!(text_attribute(&exr, "cirrus/complete"), "true");
    let (a, b) = (common::channel_bits(&whole), common::channel_bits(&exr));
    assert_eq!(a.len(), b.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "channel {name} differs after resuming");
    }
}

/// Runs `cirrus` expecting failure with exit code 1; returns its stderr.
fn fails(mut command: Command) -> String {
    let out = command.output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A checkpoint of another scene or other settings, a damaged or truncated
/// one, or none at all: `--resume` refuses with an error naming the file
/// and every difference, and writes nothing.
#[test]
fn foreign_and_damaged_checkpoints_are_refused() {
    let dir = common::scratch("reliability_refuse");
    let exr = dir.join("out.exr");
    let checkpoint = dir.join("out.checkpoint");
    let stderr = fails(command(&exr, 8, &["--resume"]));
    assert!(stderr.contains("no checkpoint"), "{stderr}");

    let child = command(&exr, 4096, &["--checkpoint-every", "0.1"])
        .spawn()
        .unwrap();
    wait_for("a checkpoint", || checkpoint.exists());
    let (status, stderr) = signal_and_wait(child, "TERM");
    assert_eq!(status.code(), Some(143), "{stderr}");
    let good = std::fs::read(&checkpoint).unwrap();

    let resume =
        |spp: u32, extra: &[&str]| fails(command(&exr, spp, &[extra, &["--resume"]].concat()));
    for (extra, wanted) in [
        (&["--seed", "4"][..], "seed: checkpoint 3, this render 4"),
        (&["--max-depth", "3"][..], "max-depth: checkpoint 1024"),
        (&["--aovs", "default"][..], "aovs: checkpoint"),
        (&["--res", "32x32"][..], "resolution: checkpoint 96x64"),
    ] {
        let stderr = resume(4096, extra);
        assert!(
            stderr.contains("out.checkpoint") && stderr.contains(wanted),
            "{extra:?}: {stderr}"
        );
    }
    assert!(resume(64, &[]).contains("budget: checkpoint --spp 4096, this render --spp 64"));
    let other = common::exported_test_scene("aovs_lambert_sun", "reliability");
    let stderr = fails(command_for(&other, &exr, 4096, &["--resume"]));
    assert!(stderr.contains("scene: checkpoint"), "{stderr}");

    let mut flipped = good.clone();
    flipped[good.len() / 3] ^= 0x10;
    for (name, bytes, wanted) in [
        ("flipped", flipped, "checksum mismatch"),
        (
            "truncated",
            good[..good.len() / 2].to_vec(),
            "checksum mismatch",
        ),
        (
            "foreign",
            b"not a checkpoint".to_vec(),
            "not a valid Cirrus film state",
        ),
    ] {
        std::fs::write(&checkpoint, bytes).unwrap();
        let stderr = resume(4096, &[]);
        assert!(
            stderr.contains("out.checkpoint") && stderr.contains(wanted),
            "{name}: {stderr}"
        );
    }
    assert!(!exr.exists(), "a refused resume wrote the output");
}

/// Without `--resume`, an unfinished render's checkpoint is dropped and the
/// render starts over (as husk does without `--autoresume`), saying so.
#[test]
fn a_stale_checkpoint_is_dropped_without_resume() {
    let dir = common::scratch("reliability_stale");
    let exr = dir.join("out.exr");
    std::fs::write(dir.join("out.checkpoint"), b"stale").unwrap();
    std::fs::write(dir.join("out.partial.exr"), b"stale").unwrap();
    let out = command(&exr, 2, &[]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("out.checkpoint: starting over") && stderr.contains("--resume"),
        "{stderr}"
    );
    assert!(!dir.join("out.checkpoint").exists() && !dir.join("out.partial.exr").exists());
    assert!(exr.exists());
}

/// SIGKILL while the EXR is being written (its temporary file exists): the
/// previous output stays whole under the final name.
#[test]
fn a_render_killed_while_writing_leaves_the_old_output_whole() {
    let dir = common::scratch("reliability_atomic");
    let exr = dir.join("out.exr");
    // Large and cheap: writing takes long enough to be caught in the act.
    let big = ["--res", "1600x1200", "--compression", "zip"];
    common::succeeds(command(&exr, 1, &big));
    let before = std::fs::read(&exr).unwrap();
    let child = command(&exr, 1, &[&big[..], &["--seed", "9"]].concat())
        .spawn()
        .unwrap();
    let temp = dir.join(format!(".out.{}.tmp.exr", child.id()));
    wait_for("the temporary EXR", || temp.exists());
    let (status, _) = signal_and_wait(child, "KILL");
    assert!(!status.success());
    assert_eq!(
        std::fs::read(&exr).unwrap(),
        before,
        "the output changed under a killed write"
    );
    common::channel_bits(&exr);
}

/// `--preview-every`: the PNG preview appears while the render runs (an
/// interrupted render writes none of its own), rewritten whole each time:
/// a PNG of the render's size.
#[test]
fn the_preview_is_rewritten_while_rendering() {
    let dir = common::scratch("reliability_preview");
    let exr = dir.join("out.exr");
    let png = exr.with_extension("png");
    let child = command(&exr, 1 << 20, &["--preview-every", "0.1"])
        .spawn()
        .unwrap();
    wait_for("the first preview", || png.exists());
    let first = modified(&png);
    wait_for("a rewritten preview", || modified(&png) != first);
    let (status, stderr) = signal_and_wait(child, "INT");
    assert_eq!(status.code(), Some(130), "{stderr}");
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let size = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!((size(16), size(20)), (96, 64), "IHDR width and height");
}
