//! Splitting a frame: parts rendered with `--tile`, `--crop` or
//! `--sample-range` into film states and joined by `cirrus merge` give the
//! frame rendered whole: bit for bit when split by pixels, within the
//! rounding of adding partial sums when split by samples; sets of parts that
//! cannot make one frame are refused with every problem listed.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use exr::prelude::*;

/// Surfaces, a volume and every AOV, so each accumulator is merged.
fn scene() -> PathBuf {
    common::exported_test_scene("aovs_mixed", "farm")
}

/// Runs `cirrus ARGS...`.
fn cirrus(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(args)
        .output()
        .unwrap()
}

/// `cirrus render` of the test scene to `out` (96x70, 24 spp, all AOVs,
/// seed 5) with `extra` flags; panics unless it succeeds.
fn render(out: &Path, extra: &[&str]) {
    let scene = scene();
    let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), scene.as_os_str()];
    args.extend(["-o".as_ref(), out.as_os_str()]);
    for (flag, value) in [
        ("--res", "96x70"),
        ("--spp", "24"),
        ("--aovs", "all"),
        ("--seed", "5"),
    ] {
        if !extra.contains(&flag) {
            args.extend([flag, value].map(std::ffi::OsStr::new));
        }
    }
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    let out = cirrus(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `cirrus merge PARTS -o OUT`.
fn merge(parts: &[PathBuf], out: &Path) -> Output {
    let mut args: Vec<&std::ffi::OsStr> = vec!["merge".as_ref()];
    args.extend(parts.iter().map(|p| p.as_os_str()));
    args.extend(["-o".as_ref(), out.as_os_str()]);
    cirrus(&args)
}

/// A channel's name, whether it is stored as half, and its values.
type ChannelValues = (String, bool, Vec<f32>);

/// Every channel of an EXR as f32 values, by name.
fn channels(path: &Path) -> Vec<ChannelValues> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let mut out: Vec<ChannelValues> = image
        .layer_data
        .iter()
        .flat_map(|l| &l.channel_data.list)
        .map(|c| {
            let values = match &c.sample_data {
                FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                FlatSamples::F32(v) => v.clone(),
                FlatSamples::U32(v) => v.iter().map(|&u| f32::from_bits(u)).collect(),
            };
            let half = matches!(c.sample_data, FlatSamples::F16(_));
            (c.name.to_string(), half, values)
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The whole frame, rendered once per test binary.
fn whole(dir: &Path) -> Vec<ChannelValues> {
    let exr = dir.join("whole.exr");
    render(&exr, &["--threads", "2"]);
    channels(&exr)
}

#[test]
fn frames_split_by_pixels_merge_bit_identical_and_by_samples_within_rounding() {
    let dir = common::scratch("farm_split");
    let whole = whole(&dir);
    let bits = |c: &[ChannelValues]| -> Vec<(String, Vec<u32>)> {
        c.iter()
            .map(|(n, _, v)| (n.clone(), v.iter().map(|x| x.to_bits()).collect()))
            .collect()
    };
    let bands: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("band{i}.film"))).collect();
    for (i, band) in bands.iter().enumerate() {
        render(band, &["--tile", &format!("{i}/3"), "--threads", "1"]);
    }
    // Parts named NAME0.film, NAME1.film.. rendered with `flag` = each value.
    let parts = |name: &str, flag: &str, values: &[&str]| -> Vec<PathBuf> {
        let part = |(i, value): (usize, &&str)| {
            let path = dir.join(format!("{name}{i}.film"));
            render(&path, &[flag, value]);
            path
        };
        values.iter().enumerate().map(part).collect()
    };
    // Crops that do not align with the 16-pixel tiles.
    let crops = parts(
        "crop",
        "--crop",
        &["0,0,37,70", "37,0,96,29", "37,29,96,70"],
    );
    for (what, parts) in [("bands", &bands), ("crops", &crops)] {
        let exr = dir.join(format!("{what}.exr"));
        let out = merge(parts, &exr);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let merged = channels(&exr);
        assert_eq!(merged.len(), whole.len());
        for ((name, a), (_, b)) in bits(&whole).iter().zip(bits(&merged)) {
            assert!(
                *a == b,
                "{what}: channel {name} differs from the whole frame"
            );
        }
    }

    let ranges = parts("samples", "--sample-range", &["0..8", "8..9", "9..24"]);
    let exr = dir.join("samples.exr");
    let out = merge(&ranges, &exr);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for ((name, half, a), (_, _, b)) in whole.iter().zip(channels(&exr)) {
        // Beauty sums are f64 (one f32 rounding of the mean); the averaged
        // AOVs sum in f32 (a few roundings over 24 samples); half channels
        // may round to the neighbouring half (2^-10 relative).
        let tolerance = match (*half, name.len()) {
            (true, _) => 1.0 / 1024.0,
            (false, 1) => 1e-6,
            (false, _) => 1e-5,
        };
        for (x, y) in a.iter().zip(&b) {
            let scale = x.abs().max(1.0);
            assert!(
                (x - y).abs() <= tolerance * scale || (x.is_infinite() && x == y),
                "{name}: {x} whole vs {y} merged"
            );
        }
    }
}

/// Missing, duplicate, overlapping, unfinished and foreign parts are refused
/// naming the files and what is wrong; the output is not written.
#[test]
fn parts_that_do_not_make_one_frame_are_refused() {
    let dir = common::scratch("farm_refuse");
    let part = |name: &str, extra: &[&str]| {
        let path = dir.join(format!("{name}.film"));
        render(&path, extra);
        path
    };
    let a = part("a", &["--tile", "0/2"]);
    let b = part("b", &["--tile", "1/2"]);
    let other_seed = part("other_seed", &["--tile", "1/2", "--seed", "6"]);
    let half_samples = part("half", &["--tile", "1/2", "--sample-range", "0..12"]);
    let exr = dir.join("out.exr");
    for (parts, wanted) in [
        (vec![a.clone()], "pixels lack samples"),
        (
            vec![a.clone(), half_samples],
            "has 12 of 24: a part is missing",
        ),
        (vec![a.clone(), b.clone(), b.clone()], "overlap"),
        (vec![a.clone(), other_seed], "other_seed.film 6"),
    ] {
        let out = merge(&parts, &exr);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{parts:?}: {stderr}");
        assert!(stderr.contains(wanted), "{parts:?}: {stderr}");
        assert!(!exr.exists(), "{parts:?}: wrote the output");
    }
    let garbage = dir.join("garbage.film");
    std::fs::write(&garbage, b"CIRRUSFS and then nothing").unwrap();
    let stderr = String::from_utf8_lossy(&merge(&[a.clone(), garbage], &exr).stderr).into_owned();
    assert!(
        stderr.contains("garbage.film") && stderr.contains("not a valid"),
        "{stderr}"
    );
    assert!(merge(&[a, b], &exr).status.success());
}

/// Part flags need a film-state output and a sample budget, and must fit
/// the frame.
#[test]
fn part_flags_are_checked() {
    let dir = common::scratch("farm_cli");
    let scene = scene();
    let exr = dir.join("out.exr");
    let film = dir.join("out.film");
    let run = |out: &Path, extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), scene.as_os_str()];
        args.extend([
            "-o".as_ref(),
            out.as_os_str(),
            "--res".as_ref(),
            "32x16".as_ref(),
        ]);
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        let out = cirrus(&args);
        assert!(!out.status.success(), "{extra:?} succeeded");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    for (out, extra, wanted) in [
        (&exr, &["--tile", "0/2"][..], "-o PART.film"),
        (&film, &["--time", "1"][..], "needs --spp"),
        (
            &film,
            &["--spp", "8", "--sample-range", "4..9"][..],
            "the frame has 8 samples",
        ),
        (&film, &["--tile", "2/2"][..], "0 <= I < N"),
        (
            &film,
            &["--crop", "0,0,40,8"][..],
            "outside the 32x16 image",
        ),
        (
            &film,
            &["--tile", "0/2", "--crop", "0,0,4,4"][..],
            "cannot be used with",
        ),
    ] {
        let stderr = run(out, extra);
        assert!(stderr.contains(wanted), "{extra:?}: {stderr}");
        assert!(!out.exists(), "{extra:?}: wrote {}", out.display());
    }
}

/// Stops the single-host Slurm cluster of a folder when dropped.
struct SlurmCluster {
    dir: PathBuf,
    env: Vec<(String, String)>,
}

impl SlurmCluster {
    /// Starts (installing Slurm and munge if missing) the cluster of
    /// `.ci/slurm/start` with its state under `dir`.
    fn start(dir: &Path) -> Self {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci/slurm/start");
        let out = Command::new(script).arg(dir).output().unwrap();
        assert!(
            out.status.success(),
            "starting Slurm failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let env = String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| l.strip_prefix("export ")?.split_once('='))
            .map(|(k, v)| {
                let path = std::env::var("PATH").unwrap_or_default();
                (k.to_string(), v.replace("$PATH", &path))
            })
            .collect();
        Self {
            dir: dir.to_path_buf(),
            env,
        }
    }
}

impl Drop for SlurmCluster {
    fn drop(&mut self) {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci/slurm/stop");
        let _ = Command::new(script).arg(&self.dir).output();
    }
}

/// `cirrus farm submit` on a real single-host Slurm cluster (slurmctld,
/// slurmd and munged on loopback): a parts array and a dependent merge
/// array run, every task records exit code 0, and the merged frame equals a
/// single-process render bit for bit.
#[test]
fn a_frame_split_over_slurm_matches_a_single_process_render() {
    let dir = common::scratch("farm_slurm");
    let cluster = SlurmCluster::start(&dir.join("slurm"));
    let out = dir.join("frame.exr");
    let scene = scene();
    let mut submit = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    submit
        .arg("farm")
        .arg("submit")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(["--split", "3", "--spp", "24", "--res", "96x70"])
        .args(["--render-args", "--aovs all --seed 5"])
        .envs(cluster.env.iter().map(|(k, v)| (k, v)));
    let submitted = submit.output().unwrap();
    assert!(
        submitted.status.success(),
        "{}",
        String::from_utf8_lossy(&submitted.stderr)
    );
    let status = dir.join("farm-frame/status");
    let start = std::time::Instant::now();
    while !status.join("merge-0").exists() {
        assert!(
            start.elapsed().as_secs() < 300,
            "the merge job did not finish; logs in {}",
            dir.join("farm-frame/logs").display()
        );
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    for task in ["part-0", "part-1", "part-2", "merge-0"] {
        let code = std::fs::read_to_string(status.join(task)).unwrap();
        assert_eq!(code.trim(), "0", "{task} exited with {code}");
    }
    let whole = whole(&dir);
    let merged = channels(&out);
    assert_eq!(whole.len(), merged.len());
    for ((name, _, a), (_, _, b)) in whole.iter().zip(&merged) {
        let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{name} differs from the single-process render");
    }
}
