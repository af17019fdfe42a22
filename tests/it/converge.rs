//! `cirrus converge` end to end on the half-sky scene of tests/adaptive.rs
//! (scenes/tests/adaptive_half_sky.usda: a Lambert plane lit by a rect light,
//! sampled by area, and a constant dome beside the dome itself; a plane
//! under a constant dome alone has no noise to converge, since cosine-weighted
//! BSDF sampling finds the dome exactly): the CSVs hold one row per method,
//! budget and seed with the promised columns, each unbiased method's median
//! relMSE falls by a clear factor per doubling of spp, the default method's
//! bias interval holds 0 and is narrow enough to show a 0.5% bias, and each
//! chart has one curve per method.

use crate::common;
use std::collections::HashMap;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// Methods run (both unbiased), budgets (`--spp-max 16`) and seeds.
const METHODS: [&str; 2] = ["default", "sampler-independent"];
const BUDGETS: [u32; 5] = [1, 2, 4, 8, 16];
const SEEDS: u32 = 3;

/// Least factor by which each doubling of spp must divide an unbiased
/// method's median relMSE. Independent samples give 2 (MSE ~ 1/spp),
/// Owen-scrambled Sobol more; the 256-spp reference's own noise adds a floor
/// of about relMSE(1 spp) / 256, which lowers the 8 -> 16 factor to
/// (1/8 + 1/256) / (1/16 + 1/256) = 1.94 at worst. Over 10 disjoint groups
/// of 3 seeds (30 seeds, 64x64, `cirrus converge` on [`SCENE`] with these
/// methods and budgets, 2026-12-02) the smallest factor seen was 1.82
/// (independent) and 2.17 (Sobol), so 1.5 has margin, yet fails
/// an error that stalls (repeated samples) or falls only as 1/sqrt(spp)
/// (factor 1.41).
const MIN_FACTOR_PER_DOUBLING: f64 = 1.5;

/// The scene converged.
const SCENE: &str = "adaptive_half_sky";

/// The mean over pixels and channels of our reference in `out`, which
/// `converge` names SCENE-HASH-`suffix`.exr (the peers' own add their name).
fn reference_mean(out: &Path, suffix: &str) -> f64 {
    let ours = |p: &Path| {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        name.ends_with(&format!("-{suffix}.exr")) && name.split('-').count() == 4
    };
    let reference = std::fs::read_dir(out)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .find(|p| ours(p))
        .expect("no reference EXR");
    let exr = common::aovs::Exr::read(&reference);
    let channels = ["R", "G", "B"].map(|c| exr.plane(c));
    let sum: f64 = channels
        .iter()
        .flat_map(|p| p.iter())
        .map(|&v| f64::from(v))
        .sum();
    sum / (3 * channels[0].len()) as f64
}

/// Each row's (method, spp, seed), in file order.
fn row_keys(rows: &[HashMap<String, String>]) -> Vec<(String, u32, u32)> {
    rows.iter()
        .map(|r| {
            (
                r["method"].clone(),
                r["spp"].parse().unwrap(),
                r["seed"].parse().unwrap(),
            )
        })
        .collect()
}

/// A CSV as a header and rows of named fields.
fn read_csv(path: &Path) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|line| {
            header
                .iter()
                .cloned()
                .zip(line.split(',').map(str::to_owned))
                .collect()
        })
        .collect();
    (header, rows)
}

fn number(row: &HashMap<String, String>, column: &str) -> f64 {
    row[column].parse().unwrap()
}

/// Curves in a chart: only they are drawn with stroke width 2.
fn curves(svg: &str) -> usize {
    svg.lines()
        .filter(|l| l.contains("<polyline") && l.contains("stroke-width=\"2\""))
        .count()
}

/// Runs `cirrus converge` on [`SCENE`] with `flags`, two threads, into the
/// scratch folder `scratch`, which it returns.
fn converge(scratch: &str, flags: &[&str]) -> PathBuf {
    let scene = common::exported_test_scene(SCENE, "converge_scenes");
    let out = common::scratch(scratch);
    let mut args: Vec<&OsStr> = vec![OsStr::new("converge"), scene.as_os_str()];
    args.extend(flags.iter().map(OsStr::new));
    args.extend(["--threads", "2", "--out"].map(OsStr::new));
    args.push(out.as_os_str());
    common::cirrus_ok(&args);
    out
}

#[test]
fn converge_writes_rows_and_unbiased_error_falls_with_spp() {
    let methods = METHODS.join(",");
    let seeds = SEEDS.to_string();
    let out = converge(
        "converge",
        &[
            "--methods",
            &methods,
            "--spp-max",
            "16",
            "--seeds",
            &seeds,
            "--res",
            "64x64",
            "--reference-spp",
            "256",
        ],
    );

    // One row per method, budget and seed, in that order, with finite values.
    let (header, rows) = read_csv(&out.join("converge.csv"));
    for column in [
        "scene", "method", "spp", "seed", "seconds", "relmse", "rmse", "bias",
    ] {
        assert!(header.iter().any(|h| h == column), "no column {column}");
    }
    let expected: Vec<(String, u32, u32)> = METHODS
        .iter()
        .flat_map(|m| BUDGETS.iter().map(move |&spp| (m, spp)))
        .flat_map(|(m, spp)| (0..SEEDS).map(move |seed| (m.to_string(), spp, seed)))
        .collect();
    assert_eq!(row_keys(&rows), expected);
    for r in &rows {
        assert_eq!(r["scene"], SCENE);
        assert!(number(r, "seconds") > 0.0);
        assert!(number(r, "relmse") > 0.0 && number(r, "rmse") > 0.0);
        assert!(number(r, "bias").is_finite());
    }

    // Per method, median relMSE falls by the factor per doubling.
    let (_, summary) = read_csv(&out.join("summary.csv"));
    assert_eq!(summary.len(), METHODS.len() * BUDGETS.len());
    for method in METHODS {
        let relmse: Vec<f64> = summary
            .iter()
            .filter(|r| r["method"] == method)
            .map(|r| number(r, "median_relmse"))
            .collect();
        for (i, pair) in relmse.windows(2).enumerate() {
            let factor = pair[0] / pair[1];
            assert!(
                factor >= MIN_FACTOR_PER_DOUBLING,
                "{method}: relMSE {} at {} spp -> {} at {} spp (factor {factor:.2})",
                pair[0],
                BUDGETS[i],
                pair[1],
                BUDGETS[i + 1]
            );
        }
    }

    // The default method at the largest budget: the 95% bias interval holds
    // 0 and is narrow (under 0.5% of the mean radiance), so a bias of that
    // size would show. One budget only: five 95% intervals would miss 0 by
    // chance about a quarter of the time.
    let last = summary
        .iter()
        .find(|r| r["method"] == "default" && r["spp"] == "16")
        .unwrap();
    let (low, high) = (
        number(last, "bias_ci95_low"),
        number(last, "bias_ci95_high"),
    );
    assert!(low <= 0.0 && 0.0 <= high, "bias interval [{low}, {high}]");
    assert!(
        high - low < 2.0 * 0.005 * reference_mean(&out, "64x64-ref256"),
        "bias interval [{low}, {high}] too wide to show a 0.5% bias"
    );

    // Two charts, one curve per method each.
    for chart in ["relmse-time", "relmse-spp"] {
        let svg = std::fs::read_to_string(out.join(format!("{SCENE}-{chart}.svg"))).unwrap();
        assert_eq!(curves(&svg), METHODS.len(), "{chart}");
    }
}

/// `converge --peers mitsuba-scalar` on the same scene: after our rows (the
/// default method's budgets go on doubling until they take as long as the
/// peer's slowest render) come one row per budget and seed of the peer (rendered through
/// scenes/peers/render_peer.py) with its times and its error against our
/// reference and its own, the summary and `equal_time.md` have its lines, and
/// the own-reference chart has one curve per series. The peer's mean bias
/// against our reference stays within 2% of the mean radiance (it agrees).
/// Skipped with a message when Mitsuba is not installed, unless
/// `CIRRUS_REQUIRE_PEERS=1` (CI), where that fails.
#[test]
fn converge_adds_peer_rows() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let available = std::process::Command::new(root.join(".venv/bin/python"))
        .arg(root.join("scenes/peers/render_peer.py"))
        .args(["--available", "mitsuba-scalar"])
        .output()
        .is_ok_and(|out| out.status.success());
    if !available {
        assert!(
            std::env::var("CIRRUS_REQUIRE_PEERS").as_deref() != Ok("1"),
            "mitsuba is not installed and CIRRUS_REQUIRE_PEERS=1 (run scenes/peers/install)"
        );
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "converge_adds_peer_rows: skipped: mitsuba not installed (run scenes/peers/install)"
        );
        return;
    }
    let out = converge(
        "converge_peers",
        &[
            "--methods",
            "default",
            "--peers",
            "mitsuba-scalar",
            "--spp-max",
            "4",
            "--seeds",
            "2",
            "--res",
            "32x32",
            "--reference-spp",
            "64",
        ],
    );

    let (header, rows) = read_csv(&out.join("converge.csv"));
    for column in ["seconds", "relmse", "relmse_own", "total_seconds"] {
        assert!(header.iter().any(|h| h == column), "no column {column}");
    }
    // Our default method first, at 1, 2, 4 spp and on doubling past 4 until
    // it takes as long as the peer's slowest render; then the peer's rows.
    let keys = row_keys(&rows);
    let ours = keys.iter().take_while(|k| k.0 == "default").count();
    let ours_spp: Vec<u32> = keys[..ours].iter().step_by(2).map(|k| k.1).collect();
    assert!(ours_spp.len() >= 3, "{keys:?}");
    for (i, spp) in ours_spp.iter().enumerate() {
        assert_eq!(*spp, 1 << i, "{keys:?}");
    }
    let expected: Vec<(String, u32, u32)> = [1, 2, 4]
        .into_iter()
        .flat_map(|spp| [0, 1].map(move |seed| ("mitsuba-scalar".to_owned(), spp, seed)))
        .collect();
    assert_eq!(keys[ours..], expected[..], "{keys:?}");
    for r in rows.iter().filter(|r| r["method"] == "mitsuba-scalar") {
        let seconds = number(r, "seconds");
        assert!(
            seconds > 0.0 && number(r, "total_seconds") >= seconds,
            "{r:?}"
        );
        assert!(
            number(r, "relmse") > 0.0 && number(r, "relmse_own") > 0.0,
            "{r:?}"
        );
    }
    let (_, summary) = read_csv(&out.join("summary.csv"));
    let last = summary
        .iter()
        .find(|r| r["method"] == "mitsuba-scalar" && r["spp"] == "4")
        .expect("a summary line of the peer at 4 spp");
    let bias = number(last, "mean_bias");
    assert!(
        bias.abs() < 0.02 * reference_mean(&out, "32x32-ref64"),
        "mitsuba's mean bias against our reference {bias}"
    );
    let equal_time = std::fs::read_to_string(out.join("equal_time.md")).unwrap();
    // One equal-time row per budget (1, 2, 4 spp), then the peer's row in
    // the seconds-to-relMSE table, beside ours.
    let (budgets, time_to_error) = equal_time
        .split_once("## Seconds to reach relMSE")
        .expect("no time-to-error table");
    assert_eq!(
        budgets
            .matches(&format!("| {SCENE} | mitsuba-scalar |"))
            .count(),
        3,
        "{equal_time}"
    );
    for series in ["mitsuba-scalar", "default"] {
        let row = format!("| {SCENE} | {series} |");
        assert_eq!(time_to_error.matches(&row).count(), 1, "{equal_time}");
    }
    let svg = std::fs::read_to_string(out.join(format!("{SCENE}-relmse-own-time.svg"))).unwrap();
    assert_eq!(curves(&svg), 2);
}
