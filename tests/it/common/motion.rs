//! Motion-blur checks shared by the motion tests (motion, motion_curves,
//! motion_lights, volume_motion): a blurred render against the average of
//! still frames, velocities against their time-sampled equivalent, a closed
//! shutter against the still export, on `scenes/tests` stages seen by an
//! orthographic camera at 8 pixels per scene unit.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Image size of the statistical renders: 8 pixels per scene unit.
pub const RES: &str = "64x32";
pub const WIDTH: usize = 64;
pub const HEIGHT: usize = 32;
/// Still frames averaged, at the midpoints of K equal parts of the shutter.
pub const K: usize = 16;
/// Samples per pixel of the blurred render and of each still frame.
pub const BLURRED_SPP: &str = "64";
pub const STILL_SPP: &str = "16";
/// Columns per band compared.
pub const BAND: usize = 4;

/// A render's G channel and its variance, per pixel.
pub type Plane = (Vec<f64>, Vec<f64>);

/// `scenes/tests/NAME.usda` exported once per test process, as its camera
/// sees it (shutter open, with motion).
pub fn exported(name: &str) -> PathBuf {
    super::exported_test_scene(name, "motion")
}

/// `scenes/tests/NAME.usda`.
pub fn stage(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/tests/{name}.usda"))
}

/// Renders `scene` to `out` (box filter, beauty and variance, one thread)
/// with `extra` flags; the G channel and its variance, per pixel.
pub fn render(scene: &Path, out: &Path, extra: &[&str]) -> Plane {
    render_with_bits(scene, out, extra).0
}

/// [`render`], and every channel's bits.
pub fn render_with_bits(
    scene: &Path,
    out: &Path,
    extra: &[&str],
) -> (Plane, Vec<(String, Vec<u32>)>) {
    super::succeeds(render_command(scene, out, extra));
    let channels = super::channel_bits(out);
    let plane = |name: &str| -> Vec<f64> {
        let (_, bits) = channels
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{}: no channel {name}", out.display()));
        bits.iter().map(|&b| f64::from(f32::from_bits(b))).collect()
    };
    ((plane("G"), plane("variance.G")), channels)
}

/// The frames a blur is compared with: the midpoints of the shutter's
/// [`K`] equal parts, then frame 0.
pub fn still_frames() -> Vec<String> {
    (0..K)
        .map(|k| format!("{}", (k as f64 + 0.5) / K as f64))
        .chain(["0".into()])
        .collect()
}

/// Exports `usda` at each of `frames` to `out/frameI` (I its position in
/// `frames`) with the shutter `shutter` ("0,0": closed), by
/// `export_frames.py`.
pub fn export_frames(usda: &Path, out: &Path, shutter: &str, frames: &[String]) {
    let mut args = vec![usda.to_str().unwrap(), out.to_str().unwrap(), shutter];
    args.extend(frames.iter().map(String::as_str));
    let script = super::python_script("export_frames.py");
    super::run_python(&super::venv_python(), &script, &args);
}

/// `blurred` agrees with the average of `stills` in every band of columns
/// within 4 sigma, and the blur is visible: some band differs from
/// `frame_0` by far more (20 sigma).
pub fn assert_blur_is_average(what: &str, blurred: &Plane, stills: &[Plane], frame_0: &Plane) {
    let bands = |images: &[Plane]| super::column_bands(images, (WIDTH, HEIGHT), BAND);
    let (blurred, stills, frame_0) = (
        bands(std::slice::from_ref(blurred)),
        bands(stills),
        bands(std::slice::from_ref(frame_0)),
    );
    super::assert_bands_agree(&format!("{what}: blurred vs stills"), &blurred, &stills);
    assert!(
        super::widest_gap(&blurred, &frame_0) > 20.0,
        "{what}: the blurred render looks like frame 0"
    );
}

/// The `cirrus render` command of [`render`].
pub fn render_command(scene: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    c.arg("render")
        .arg(scene)
        .arg("-o")
        .arg(out)
        .args(["--res", RES]);
    c.args(["--filter", "box", "--aovs", "variance", "--threads", "1"]);
    c.args(extra);
    c
}

/// The blurred render of `name` (its camera's shutter 0..1) against the
/// average of [`K`] still renders at the midpoints of the shutter's K
/// parts, each a fresh export of the stage at that frame with the shutter
/// closed: every band of columns agrees within 4 sigma, and the blur is
/// visible (some band differs from frame 0 by far more).
pub fn blurred_equals_average_of_stills(name: &str) {
    let dir = super::scratch(&format!("motion_{name}"));
    export_frames(&stage(name), &dir.join("stills"), "0,0", &still_frames());
    let blurred = render(
        &exported(name),
        &dir.join("blurred.exr"),
        &["--spp", BLURRED_SPP, "--seed", "1"],
    );
    let stills: Vec<_> = (0..K)
        .map(|k| {
            let scene = dir.join(format!("stills/frame{k}"));
            let seed = (100 + k).to_string();
            let out = dir.join(format!("still{k}.exr"));
            render(&scene, &out, &["--spp", STILL_SPP, "--seed", &seed])
        })
        .collect();
    let frame_0 = render(
        &dir.join(format!("stills/frame{K}")),
        &dir.join("frame0.exr"),
        &["--spp", STILL_SPP, "--seed", "7"],
    );
    assert_blur_is_average(name, &blurred, &stills, &frame_0);
}

/// `sampled` (time-sampled points) and `driven` (the same motion by
/// `velocities`), both blurred over their shutter 0..1: every band of
/// columns within 4 sigma (independent seeds); the bands of `driven`.
pub fn velocities_blur_as_their_time_sampled_equivalent(
    sampled: &str,
    driven: &str,
) -> Vec<(f64, f64)> {
    let dir = super::scratch(driven);
    let flags = |seed| ["--spp", BLURRED_SPP, "--seed", seed];
    let sampled = render(&exported(sampled), &dir.join("sampled.exr"), &flags("11"));
    let driven = render(&exported(driven), &dir.join("driven.exr"), &flags("12"));
    let [sampled, driven] = [sampled, driven]
        .map(|image| super::column_bands(std::slice::from_ref(&image), (WIDTH, HEIGHT), BAND));
    super::assert_bands_agree("time-sampled vs velocities", &sampled, &driven);
    driven
}

/// `--shutter 0,0` on `scenes/tests/NAME.usda` exported with motion renders
/// exactly what the same stage exported without motion (shutter closed)
/// renders: every channel, bit for bit.
pub fn closed_shutter_renders_the_still_frame(name: &str) {
    let dir = super::scratch(&format!("motion_closed_{name}"));
    let still = dir.join("still");
    export_frames(&stage(name), &still, "0,0", &["0".into()]);
    let (a, b) = (dir.join("closed.exr"), dir.join("still.exr"));
    let flags = ["--spp", "8", "--seed", "3"];
    render(
        &exported(name),
        &a,
        &[&flags[..], &["--shutter", "0,0"]].concat(),
    );
    render(&still.join("frame0"), &b, &flags);
    assert!(
        super::channel_bits(&a) == super::channel_bits(&b),
        "{name}: --shutter 0,0 differs from the still export"
    );
}
