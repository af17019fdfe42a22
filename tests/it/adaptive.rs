//! Adaptive sampling (`--noise-threshold`): on a stage that is half
//! noise-free sky and half noisy lit plane, the sky gets fewer samples and
//! the image's mean stays that of a uniform render; the image does not
//! depend on the thread count, and a render stopped by SIGTERM and resumed
//! is bit-identical to an uninterrupted one; bad thresholds are refused.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common::aovs::{render_args, Exr};

/// The half-sky stage: the plane fills image columns x < 16 of 32.
const SCENE: &str = "adaptive_half_sky";
const RES: &str = "32x32";

/// `cirrus render` of the half-sky stage to `out` at 32x32, seed 7, one
/// thread, box filter, sample counts and variance, with each flag of `set`
/// replacing the default or added, then `extra`.
fn command(out: &Path, spp: u32, set: &[(&str, &str)], extra: &[&str]) -> Command {
    let mut args = render_args(SCENE, out, RES, spp, &["--aovs", "sample_count,variance"]);
    for (flag, value) in set {
        match args.iter().position(|a| a == flag) {
            Some(at) => args[at + 1] = value.to_string(),
            None => args.extend([flag.to_string(), value.to_string()]),
        }
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    c.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

fn scratch(test: &str) -> PathBuf {
    common::scratch(&format!("adaptive_{test}"))
}

/// Mean of `channel` over the pixels with `x` in `columns`.
fn mean(exr: &Exr, channel: &str, columns: std::ops::Range<usize>) -> f64 {
    let values: Vec<f64> = exr
        .pixels()
        .filter(|(x, _)| columns.contains(x))
        .map(|(x, y)| exr.at(channel, x, y))
        .collect();
    values.iter().sum::<f64>() / values.len() as f64
}

/// The sky (noise-free) stops at the first check after the automatic
/// minimum while the plane samples on; the plane's mean radiance agrees with
/// a uniform render of another seed within 4 sigma (from both renders'
/// variance AOVs), channel by channel.
#[test]
fn the_sky_gets_fewer_samples_and_the_mean_is_kept() {
    let dir = scratch("mean");
    let (adaptive, uniform) = (dir.join("adaptive.exr"), dir.join("uniform.exr"));
    let spp = 512;
    common::succeeds(command(
        &adaptive,
        spp,
        &[("--noise-threshold", "0.02")],
        &[],
    ));
    common::succeeds(command(&uniform, spp, &[("--seed", "2")], &[]));
    let (a, u) = (Exr::read(&adaptive), Exr::read(&uniform));
    // Threshold 0.02: automatic minimum ceil(16 / 0.02^0.3) = 53, first
    // checked at the pass boundary 64; the sky's error is exactly 0.
    let (sky, plane) = (
        mean(&a, "sample_count", 17..32),
        mean(&a, "sample_count", 0..15),
    );
    eprintln!("samples per pixel: sky {sky}, plane {plane}");
    assert_eq!(sky, 64.0, "every sky pixel stops at 64 samples");
    assert!(plane > 2.0 * sky, "the plane sampled on: {plane} spp");
    assert!(
        plane < f64::from(spp),
        "the plane converged too: {plane} spp"
    );
    assert_eq!(mean(&u, "sample_count", 0..32), f64::from(spp));
    let pixels = (a.width * a.height) as f64;
    for c in ["R", "G", "B"] {
        let variance = |exr: &Exr| mean(exr, &format!("variance.{c}"), 0..32) / pixels;
        let sigma = (variance(&a) + variance(&u)).sqrt();
        let (ma, mu) = (mean(&a, c, 0..32), mean(&u, c, 0..32));
        eprintln!("{c}: adaptive {ma:.5}, uniform {mu:.5}, sigma {sigma:.2e}");
        assert!(sigma > 0.0 && (ma - mu).abs() <= 4.0 * sigma, "{c}: biased");
    }
}

/// One thread or two: the same adaptive image, bit for bit.
#[test]
fn adaptive_renders_do_not_depend_on_the_thread_count() {
    let dir = scratch("threads");
    let (one, two) = (dir.join("one.exr"), dir.join("two.exr"));
    let t = ("--noise-threshold", "0.05");
    common::succeeds(command(&one, 128, &[t], &[]));
    common::succeeds(command(&two, 128, &[t, ("--threads", "2")], &[]));
    assert!(
        common::channel_bits(&one) == common::channel_bits(&two),
        "1 and 2 threads differ"
    );
}

/// Stopped by SIGTERM after a checkpoint, then resumed: every channel
/// (beauty, sample counts, variance) equals the uninterrupted adaptive
/// render's.
#[test]
fn a_resumed_adaptive_render_is_bit_identical() {
    let dir = scratch("resume");
    let spp = 2048;
    let flags = [("--noise-threshold", "0.01")];
    let whole = dir.join("whole.exr");
    common::succeeds(command(&whole, spp, &flags, &[]));
    let exr = dir.join("resumed.exr");
    let checkpoint = dir.join("resumed.checkpoint");
    let render = command(&exr, spp, &flags, &["--checkpoint-every", "0.2"]);
    common::interrupted_after_checkpoint(render, &checkpoint, "TERM");
    common::succeeds(command(&exr, spp, &flags, &["--resume"]));
    assert!(
        common::channel_bits(&exr) == common::channel_bits(&whole),
        "the resumed adaptive render differs"
    );
}

/// `cirrus render` with `extra` fails with exit code 2 (a flag error) or 1;
/// its stderr.
fn refused(extra: &[&str]) -> String {
    let dir = scratch(&common::test_name());
    let out = command(&dir.join("out.exr"), 16, &[], extra)
        .output()
        .unwrap();
    assert!(!out.status.success(), "{extra:?} was accepted");
    assert!(!dir.join("out.exr").exists());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_zero_noise_threshold_is_refused() {
    let err = refused(&["--noise-threshold", "0"]);
    assert!(
        err.contains("--noise-threshold") && err.contains("positive"),
        "{err}"
    );
}

#[test]
fn a_negative_noise_threshold_is_refused() {
    let err = refused(&["--noise-threshold", "-0.1"]);
    assert!(
        err.contains("--noise-threshold") && err.contains("positive"),
        "{err}"
    );
}

#[test]
fn a_nan_noise_threshold_is_refused() {
    let err = refused(&["--noise-threshold", "NaN"]);
    assert!(
        err.contains("--noise-threshold") && err.contains("positive"),
        "{err}"
    );
}

#[test]
fn adaptive_sampling_is_not_split_by_sample_range() {
    let dir = scratch("range");
    let film = dir.join("part.film");
    let mut args = render_args(SCENE, &film, RES, 16, &["--noise-threshold", "0.05"]);
    args.extend(["--sample-range", "0..8"].map(String::from));
    let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--sample-range") && err.contains("--tile"),
        "{err}"
    );
}
