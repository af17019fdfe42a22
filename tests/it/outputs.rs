//! What a render does with its output path (issue 25): it overwrites a
//! finished output (atomically), `--skip-existing` keeps a complete one,
//! missing folders are created and an unwritable place fails before any
//! rendering, and a finished render whose image cannot be written is saved
//! as a film state with the command that writes the image from it.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn scene() -> PathBuf {
    common::exported_test_scene("aovs_mixed", "outputs")
}

/// `cirrus render` of the test scene to `out` at 32x24, 4 spp, all AOVs,
/// then `extra` (later flags win).
fn render(out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    c.arg("render").arg(scene()).arg("-o").arg(out);
    c.args(["--res", "32x24", "--aovs", "all"]);
    if !extra.contains(&"--spp") {
        c.args(["--spp", "4"]);
    }
    c.args(extra).stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

/// Runs `command` expecting exit code 1; its stderr.
fn fails(mut command: Command) -> String {
    let out = command.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    stderr
}

fn modified(path: &Path) -> std::time::SystemTime {
    std::fs::metadata(path).unwrap().modified().unwrap()
}

#[test]
fn a_second_render_to_the_same_path_overwrites_it() {
    let dir = common::scratch("outputs_overwrite");
    let exr = dir.join("out.exr");
    common::succeeds(render(&exr, &["--seed", "1"]));
    let first = std::fs::read(&exr).unwrap();
    common::succeeds(render(&exr, &["--seed", "2"]));
    assert_ne!(std::fs::read(&exr).unwrap(), first, "the output was kept");
    // `--force` is still accepted (old scripts), and changes nothing.
    common::succeeds(render(&exr, &["--seed", "2", "--force"]));
}

#[test]
fn skip_existing_keeps_a_complete_output_and_renders_a_missing_one() {
    let dir = common::scratch("outputs_skip");
    let exr = dir.join("out.exr");
    let out = common::succeeds(render(&exr, &["--skip-existing"]));
    assert!(exr.exists(), "{}", String::from_utf8_lossy(&out.stderr));
    let (bytes, time) = (std::fs::read(&exr).unwrap(), modified(&exr));
    std::thread::sleep(Duration::from_millis(20));
    let out = common::succeeds(render(&exr, &["--skip-existing", "--seed", "5"]));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    assert!(stdout.contains("out.exr is complete"), "{stdout}");
    assert_eq!(modified(&exr), time, "--skip-existing touched the output");
    assert_eq!(std::fs::read(&exr).unwrap(), bytes);
    // A checkpoint beside it: the render is unfinished, so it runs again.
    std::fs::write(dir.join("out.checkpoint"), b"stale").unwrap();
    common::succeeds(render(&exr, &["--skip-existing", "--seed", "5"]));
    assert_ne!(std::fs::read(&exr).unwrap(), bytes);
    assert!(!dir.join("out.checkpoint").exists());
}

#[test]
fn missing_output_folders_are_created() {
    let dir = common::scratch("outputs_folders");
    let exr = dir.join("shots/sh010/beauty.exr");
    common::succeeds(render(&exr, &[]));
    assert!(exr.exists() && exr.with_extension("png").exists());
}

/// An output that is a folder, or whose folder cannot be made (a path
/// component is a file: root fails too), fails at once, naming it, before
/// the scene is even loaded.
#[test]
fn an_unwritable_output_fails_before_rendering() {
    let dir = common::scratch("outputs_unwritable");
    let stderr = fails(render(&dir, &[]));
    assert!(
        stderr.contains(&format!("{} is a folder", dir.display())),
        "{stderr}"
    );
    let file = dir.join("a_file");
    std::fs::write(&file, b"").unwrap();
    let stderr = fails(render(&file.join("sub/out.exr"), &[]));
    assert!(
        stderr.contains(&format!(
            "cannot create the folder {}",
            file.join("sub").display()
        )),
        "{stderr}"
    );
    assert!(!stderr.contains("ready in"), "it rendered first: {stderr}");
}

/// The output folder is replaced by a file mid-render, so the finished
/// image cannot be written (as root too): the film state is saved in the
/// cache, the exit code is 1, and the printed command, once the folder is
/// back, writes an image bit-identical to an uninterrupted render's.
#[test]
fn a_failed_write_leaves_a_film_state_and_the_command_to_finish() {
    let dir = common::scratch("outputs_rescue");
    let whole = dir.join("whole.exr");
    let flags = ["--spp", "256", "--checkpoint-every", "0.05"];
    common::succeeds(render(&whole, &flags));

    let shot = dir.join("shot");
    let exr = shot.join("out.exr");
    let cache = dir.join("cache");
    let child = render(&exr, &flags)
        .env("XDG_CACHE_HOME", &cache)
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !shot.join("out.checkpoint").exists() {
        assert!(start.elapsed() < Duration::from_secs(60), "no checkpoint");
        std::thread::sleep(Duration::from_millis(2));
    }
    // Renamed, not removed: a checkpoint may be being written into it.
    std::fs::rename(&shot, dir.join("shot.gone")).unwrap();
    std::fs::write(&shot, b"not a folder").unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("the render is not lost"), "{stderr}");
    let command = stderr
        .lines()
        .find_map(|l| l.trim().strip_prefix("cirrus merge "))
        .unwrap_or_else(|| panic!("no command in: {stderr}"));
    let args: Vec<&str> = command.split_whitespace().collect();
    assert!(
        Path::new(args[0]).starts_with(cache.join("cirrus/rescued")),
        "{stderr}"
    );

    std::fs::remove_file(&shot).unwrap();
    let mut merge = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    merge.arg("merge").args(&args);
    common::succeeds(merge);
    let (a, b) = (common::channel_bits(&whole), common::channel_bits(&exr));
    assert_eq!(a.len(), b.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "channel {name} differs from the uninterrupted render"
        );
    }
}

/// A stage with two cameras: `--camera` renders each (the first is the
/// default), and a path that is not a camera fails listing the cameras.
#[test]
fn camera_selects_any_camera_of_the_stage() {
    let dir = common::scratch("outputs_camera");
    let usda = dir.join("two_cameras.usda");
    std::fs::write(
        &usda,
        r#"#usda 1.0
(
    upAxis = "Y"
)
def Sphere "ball"
{
    double radius = 1
}
def DistantLight "sun"
{
    float inputs:intensity = 3
}
def Xform "cams"
{
    def Camera "front"
    {
        double3 xformOp:translate = (0, 0, 6)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Camera "side"
    {
        double3 xformOp:translate = (1.5, 0.5, 6)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"#,
    )
    .unwrap();
    let run = |name: &str, camera: Option<&str>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
        c.arg("render").arg(&usda).arg("-o").arg(dir.join(name));
        c.args(["--res", "16x12", "--spp", "4", "--aovs", "beauty"]);
        c.args(camera.map(|cam| ["--camera", cam]).iter().flatten());
        c.env("XDG_CACHE_HOME", dir.join("cache"));
        c
    };
    common::succeeds(run("front.exr", Some("/cams/front")));
    common::succeeds(run("side.exr", Some("/cams/side")));
    common::succeeds(run("default.exr", None));
    let bits = |name: &str| common::channel_bits(&dir.join(name));
    assert_ne!(
        bits("front.exr"),
        bits("side.exr"),
        "--camera changed nothing"
    );
    assert_eq!(bits("front.exr"), bits("default.exr"));
    for bad in ["/ball", "/nope"] {
        let stderr = fails(run("bad.exr", Some(bad)));
        assert!(
            stderr.contains(&format!("--camera {bad} is not a"))
                && stderr.contains("its cameras: /cams/front, /cams/side"),
            "{stderr}"
        );
    }
}

/// `--frames 1-3`: one EXR per frame of an animated stage, named by the `#`
/// run of -o, each rendering its own frame (the same image as `--frame N`);
/// `--skip-existing` leaves the complete frames alone; an empty or reversed
/// range and a sequence without `#` in -o are refused before rendering.
#[test]
fn frames_render_a_sequence() {
    let dir = common::scratch("outputs_frames");
    let usda = dir.join("moving_ball.usda");
    std::fs::write(
        &usda,
        r#"#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 1
    endTimeCode = 3
)
def Sphere "ball"
{
    double3 xformOp:translate.timeSamples = { 1: (-1, 0, 0), 3: (1, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def DistantLight "sun"
{
    float inputs:intensity = 3
}
def Camera "cam"
{
    double3 xformOp:translate = (0, 0, 6)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"#,
    )
    .unwrap();
    let run = |out: &str, extra: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
        c.arg("render").arg(&usda).arg("-o").arg(dir.join(out));
        c.args(["--res", "16x12", "--spp", "2", "--aovs", "beauty"]);
        c.args(extra).env("XDG_CACHE_HOME", dir.join("cache"));
        c.stdout(Stdio::piped()).stderr(Stdio::piped());
        c
    };
    common::succeeds(run("seq/shot.####.exr", &["--frames", "1-3"]));
    common::succeeds(run("two.exr", &["--frame", "2"]));
    let bits = |name: &str| common::channel_bits(&dir.join(name));
    let frames: Vec<_> = (1..=3)
        .map(|f| bits(&format!("seq/shot.{f:04}.exr")))
        .collect();
    assert!(
        frames[0] != frames[1] && frames[1] != frames[2],
        "the frames are alike"
    );
    assert_eq!(
        frames[1],
        bits("two.exr"),
        "frame 2 of the sequence is not --frame 2"
    );

    let first = modified(&dir.join("seq/shot.0001.exr"));
    std::fs::remove_file(dir.join("seq/shot.0003.exr")).unwrap();
    common::succeeds(run(
        "seq/shot.####.exr",
        &["--frames", "1-3x2", "--skip-existing"],
    ));
    assert_eq!(
        modified(&dir.join("seq/shot.0001.exr")),
        first,
        "a complete frame was rendered again"
    );
    assert_eq!(bits("seq/shot.0003.exr"), frames[2]);

    for (frames, out, why) in [
        ("3-1", "r.####.exr", "expected frames A-B[xSTEP]"),
        ("1-3x0", "r.####.exr", "expected frames A-B[xSTEP]"),
        ("1-3", "r.exr", "has no frame token for the frame number"),
    ] {
        let mut c = run(out, &["--frames", frames]);
        let out = c.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && stderr.contains(why),
            "--frames {frames}: {stderr}"
        );
    }
}
