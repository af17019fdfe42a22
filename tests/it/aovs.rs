//! End to end: `cirrus render --aovs ...` on the scenes `scenes/tests/aovs_*`
//! (exported by the real usd-core exporter), its EXRs read back by two
//! independent readers (the `exr` crate; the Python `OpenEXR` package through
//! the project's venv), and every AOV compared with what its definition and
//! the scene say: channel names, storage and metadata; light-path AOVs that
//! sum to the beauty and land in the right category; albedo, depth, normal,
//! position, variance and coverage against closed forms; Cryptomatte decoded
//! with the specification's reference algorithm.
//!
//! Renders are small, use fixed seeds, one worker thread each (the harness
//! runs tests in parallel) and the box filter unless a test says otherwise,
//! so that a pixel's value is the plain mean of its own samples.
//!
//! Half-precision tolerances: `tests/common/aovs.rs`. The depth card and
//! Cryptomatte checks are in `tests/aovs_card.rs`.

use crate::common;
use std::collections::BTreeSet;

use crate::common::aovs::*;
use cirrus::film::layer_key;
use serde_json::Value;

/// `--aovs all` writes exactly the contract's channels with their storage,
/// the Cryptomatte, camera-matrix, `software` and `cirrus/*` metadata;
/// sample_count is the spp.
#[test]
fn all_aovs_have_the_documented_channels_types_and_metadata() {
    let (_, exr) = render_and_read(
        "aovs_all",
        "aovs_cryptomatte",
        "20x20",
        8,
        &["--aovs", "all"],
    );
    let all: Vec<&str> = DEFAULT.iter().chain(&ALL_EXTRA).copied().collect();
    assert_eq!(exr.formats(), expected_channels(&all));
    assert_eq!((exr.width, exr.height), (20, 20));

    let software = exr.strings.get("software").expect("software attribute");
    assert!(software.starts_with("Cirrus "), "software = {software:?}");
    assert_eq!(exr.strings.get("cirrus/spp").map(String::as_str), Some("8"));
    assert_eq!(
        exr.strings.get("cirrus/seed").map(String::as_str),
        Some("7")
    );
    for layer in ["CryptoObject", "CryptoMaterial", "CryptoAsset"] {
        for field in ["name", "hash", "conversion", "manifest"] {
            let key = format!("cryptomatte/{}/{field}", layer_key(layer));
            assert!(exr.strings.contains_key(&key), "missing {key}");
        }
    }
    for (name, m) in [
        ("worldToCamera", exr.world_to_camera),
        ("worldToNDC", exr.world_to_ndc),
    ] {
        let m = m.unwrap_or_else(|| panic!("missing {name}"));
        assert!(
            m.iter().all(|v| v.is_finite()) && m.iter().any(|&v| v != 0.0),
            "{name} = {m:?}"
        );
    }
    assert!(exr.plane("sample_count").iter().all(|&n| n == 8.0));
    for (name, (_, values)) in &exr.channels {
        assert!(
            values.iter().all(|v| v.is_finite()),
            "{name} has a non-finite value"
        );
    }
}

/// The same `--aovs all` file through the Python `OpenEXR` package: the same
/// channel names, storage and values as the `exr` crate reads, the same text
/// attributes, and both camera matrices.
#[test]
fn python_openexr_reads_the_same_channels_and_metadata() {
    let (path, exr) = render_and_read(
        "aovs_python",
        "aovs_cryptomatte",
        "12x12",
        4,
        &["--aovs", "all"],
    );
    let json = common::run_python(
        &common::venv_python(),
        &common::python_script("read_exr.py"),
        &[path.to_str().unwrap()],
    );
    let got: Value = serde_json::from_str(&json).unwrap();
    let channels = got["channels"].as_object().unwrap();
    let names: BTreeSet<&str> = channels.keys().map(String::as_str).collect();
    let all: Vec<&str> = DEFAULT.iter().chain(&ALL_EXTRA).copied().collect();
    let wanted = expected_channels(&all);
    assert_eq!(names, wanted.keys().map(String::as_str).collect());
    for (name, format) in &wanted {
        let entry = &channels[name];
        assert_eq!(entry["type"], format.python_name(), "{name}");
        // Every stored value is an f32 (or a half, exact in f32); the JSON's
        // decimal doubles round back to it exactly.
        let values: Vec<f32> = entry["values"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap() as f32)
            .collect();
        assert_eq!(values, exr.plane(name), "{name}: the two readers disagree");
    }
    let strings = got["strings"].as_object().unwrap();
    for (key, value) in &exr.strings {
        assert_eq!(
            strings.get(key).and_then(Value::as_str),
            Some(value.as_str()),
            "{key}"
        );
    }
    assert!(strings["software"].as_str().unwrap().starts_with("Cirrus "));
    for layer in ["CryptoObject", "CryptoMaterial", "CryptoAsset"] {
        let key = format!("cryptomatte/{}/name", layer_key(layer));
        assert_eq!(strings[&key], layer);
    }
    for (name, ours) in [
        ("worldToCamera", exr.world_to_camera.unwrap()),
        ("worldToNDC", exr.world_to_ndc.unwrap()),
    ] {
        let m: Vec<f64> = got["matrices"][name]
            .as_array()
            .unwrap_or_else(|| panic!("Python sees no {name}"))
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let m: Vec<f32> = m.iter().map(|&v| v as f32).collect();
        assert_eq!(m, ours, "{name}");
    }
}

/// `--aovs beauty` writes R, G, B, A only and no Cryptomatte metadata, with
/// the same beauty as a render with every AOV (AOVs do not perturb the
/// samples); a list writes just the listed AOVs; `default` the default set;
/// an unknown name is an error that names it.
#[test]
fn beauty_default_and_lists_write_just_those_channels() {
    let dir = common::scratch("aovs_lists");
    let run = |file: &str, aovs: &str| {
        let path = dir.join(file);
        render("aovs_cryptomatte", &path, "10x10", 4, &["--aovs", aovs]);
        Exr::read(&path)
    };
    let beauty = run("beauty.exr", "beauty");
    assert_eq!(beauty.formats(), expected_channels(&[]));
    assert!(
        !beauty.strings.keys().any(|k| k.starts_with("cryptomatte/")),
        "{:?}",
        beauty.strings.keys()
    );

    let list = run("list.exr", "Z,albedo,CryptoMaterial,variance");
    assert_eq!(
        list.formats(),
        expected_channels(&["Z", "albedo", "CryptoMaterial", "variance"])
    );
    let material_key = format!("cryptomatte/{}/name", layer_key("CryptoMaterial"));
    let object_key = format!("cryptomatte/{}/name", layer_key("CryptoObject"));
    assert!(list.strings.contains_key(&material_key));
    assert!(!list.strings.contains_key(&object_key));

    let default = run("default.exr", "default");
    assert_eq!(default.formats(), expected_channels(&DEFAULT));
    let all = run("all.exr", "all");
    for c in ["R", "G", "B", "A"] {
        assert_eq!(
            beauty.plane(c),
            all.plane(c),
            "{c}: beauty-only and all-AOV renders differ"
        );
        assert_eq!(beauty.plane(c), default.plane(c), "{c}");
    }

    let args = render_args(
        "aovs_cryptomatte",
        &dir.join("bad.exr"),
        "10x10",
        4,
        &["--aovs", "albedo,glossy"],
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(&args)
        .output()
        .unwrap();
    assert!(!out.status.success(), "an unknown AOV was accepted");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("glossy"), "{stderr}");
    assert!(!dir.join("bad.exr").exists());
}

/// `--aov-files separate`: OUT.exr holds the beauty, each AOV its own
/// OUT.<aov>.exr with the same channel names, storage and values as the
/// single multi-channel file, Cryptomatte metadata beside its layer.
#[test]
fn separate_files_hold_each_aov_with_the_same_channels_and_values() {
    let dir = common::scratch("aovs_separate");
    let single_path = dir.join("single.exr");
    render(
        "aovs_cryptomatte",
        &single_path,
        "10x10",
        4,
        &["--aovs", "default"],
    );
    let single = Exr::read(&single_path);
    let separate_dir = dir.join("separate");
    std::fs::create_dir(&separate_dir).unwrap();
    let out = separate_dir.join("out.exr");
    render(
        "aovs_cryptomatte",
        &out,
        "10x10",
        4,
        &["--aovs", "default", "--aov-files", "separate"],
    );

    let exrs: BTreeSet<String> = std::fs::read_dir(&separate_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".exr"))
        .collect();
    let wanted: BTreeSet<String> = std::iter::once("out.exr".to_string())
        .chain(DEFAULT.iter().map(|aov| format!("out.{aov}.exr")))
        .collect();
    assert_eq!(exrs, wanted);

    let files = std::iter::once(("out.exr".to_string(), beauty_channels())).chain(
        DEFAULT
            .iter()
            .map(|aov| (format!("out.{aov}.exr"), aov_channels(aov))),
    );
    for (file, channels) in files {
        let exr = Exr::read(&separate_dir.join(&file));
        assert_eq!(exr.formats(), channels.iter().cloned().collect(), "{file}");
        for (name, _) in &channels {
            assert_eq!(exr.plane(name), single.plane(name), "{file}: {name}");
        }
        assert!(
            exr.strings
                .get("software")
                .is_some_and(|s| s.starts_with("Cirrus ")),
            "{file}"
        );
        for layer in ["CryptoObject", "CryptoMaterial", "CryptoAsset"] {
            let key = format!("cryptomatte/{}/manifest", layer_key(layer));
            let is_layer = file == format!("out.{layer}.exr");
            if is_layer {
                assert_eq!(
                    exr.strings.get(&key),
                    single.strings.get(&key),
                    "{file}: {key}"
                );
            }
            if file == "out.exr" {
                assert!(!exr.strings.contains_key(&key), "{file} has {key}");
            }
        }
    }
}

/// The pixel's light-path AOVs add up to its beauty: |sum - beauty| <= 1e-3
/// beauty + 1e-6 per channel. Each of the eight half values carries a
/// relative rounding error of at most 2^-11 (< 5e-4, so the sum is within
/// 5e-4 of the beauty when all are non-negative), or, below 2^-14, an
/// absolute one of 2^-25 (eight of them: < 2.4e-7, hence the 1e-6 floor).
fn assert_light_paths_sum_to_beauty(exr: &Exr, what: &str) {
    let mut worst: f64 = 0.0;
    for (x, y) in exr.pixels() {
        for c in ["R", "G", "B"] {
            let beauty = exr.at(c, x, y);
            let sum: f64 = LIGHT_PATHS
                .iter()
                .map(|aov| exr.at(&format!("{aov}.{c}"), x, y))
                .sum();
            assert!(
                beauty.is_finite() && sum.is_finite(),
                "{what} ({x}, {y}) {c}"
            );
            let error = (sum - beauty).abs();
            worst = worst.max(error / (beauty + 1e-3));
            assert!(
                error <= 1e-3 * beauty + 1e-6,
                "{what} ({x}, {y}) {c}: light paths sum to {sum}, beauty {beauty}"
            );
        }
    }
    eprintln!("{what}: worst |sum - beauty| / (beauty + 1e-3) = {worst:.2e}");
}

/// The mixed scene (every category: Lambert floor, metal and glass balls,
/// emissive panel, scattering fog, sun and dome): the light-path AOVs sum to
/// the beauty with the box and with the default filter; each category is
/// non-zero (at least 1e-3 of the image's beauty; the smallest, volume_direct,
/// is 0.017); and each lands only where
/// its first event can happen: transmission only where the glass is seen
/// first, specular only on the balls, diffuse only on the floor, emission
/// only on the lamp or where a camera ray escapes to the dome (A < 1).
#[test]
fn light_path_aovs_sum_to_the_beauty_and_each_is_where_it_belongs() {
    let (_, exr) = render_and_read(
        "aovs_mixed_box",
        "aovs_mixed",
        "40x30",
        16,
        &["--aovs", "default"],
    );
    assert_light_paths_sum_to_beauty(&exr, "box filter");
    let (_, smooth) = render_and_read(
        "aovs_mixed_blackman_harris",
        "aovs_mixed",
        "40x30",
        8,
        &["--aovs", "default", "--filter", "blackman-harris"],
    );
    assert_light_paths_sum_to_beauty(&smooth, "Blackman-Harris filter");

    let total = |prefix: &str| -> f64 {
        ["R", "G", "B"]
            .iter()
            .map(|c| {
                let name = if prefix.is_empty() {
                    c.to_string()
                } else {
                    format!("{prefix}.{c}")
                };
                exr.plane(&name).iter().map(|&v| f64::from(v)).sum::<f64>()
            })
            .sum()
    };
    let beauty = total("");
    for aov in LIGHT_PATHS {
        let share = total(aov) / beauty;
        eprintln!("{aov}: {:.4} of the beauty", share);
        assert!(
            share >= 1e-3,
            "{aov} is (almost) never written: {share:.2e} of the beauty"
        );
    }

    let objects = decode_cryptomatte(&exr, "CryptoObject");
    let names: Vec<&str> = objects.manifest.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "/World/Floor",
            "/World/Glass",
            "/World/Glossy",
            "/World/Lamp"
        ]
    );
    let seen = |object: &str, p: usize| objects.coverage[object][p] > 0.0;
    let nonzero = |aov: &str, p: usize| {
        ["R", "G", "B"]
            .iter()
            .any(|c| exr.plane(&format!("{aov}.{c}"))[p] != 0.0)
    };
    for (x, y) in exr.pixels() {
        let p = y * exr.width + x;
        let rule = [
            ("transmission", seen("/World/Glass", p)),
            (
                "specular_direct",
                seen("/World/Glass", p) || seen("/World/Glossy", p),
            ),
            (
                "specular_indirect",
                seen("/World/Glass", p) || seen("/World/Glossy", p),
            ),
            ("diffuse_direct", seen("/World/Floor", p)),
            ("diffuse_indirect", seen("/World/Floor", p)),
            (
                "emission",
                seen("/World/Lamp", p) || exr.at("A", x, y) < 1.0,
            ),
        ];
        for (aov, allowed) in rule {
            assert!(
                allowed || !nonzero(aov, p),
                "{aov} at ({x}, {y}), where its first event cannot be"
            );
        }
    }
}

/// scenes/tests/aovs_lambert_sun.usda: a coloured Lambert plane lit only by
/// the sun. Every pixel is (0.25, 0.5, 0.75) (1e-5 relative: f32
/// arithmetic), all of it diffuse_direct (half precision); every other
/// light-path AOV is exactly 0; albedo is the diffuse colour (exact in half);
/// A = 1; N = +Y; Z is the camera's height 2; the pixel variance is 0 (up to
/// f32 cancellation, 1e-6).
#[test]
fn a_lambert_plane_under_the_sun_is_all_diffuse_direct() {
    let (_, exr) = render_and_read(
        "aovs_lambert_sun",
        "aovs_lambert_sun",
        "16x16",
        8,
        &["--aovs", "all"],
    );
    let colour = [0.25, 0.5, 0.75];
    for (x, y) in exr.pixels() {
        for (c, want) in ["R", "G", "B"].into_iter().zip(colour) {
            let beauty = exr.at(c, x, y);
            assert!(
                (beauty - want).abs() <= 1e-5 * want,
                "({x}, {y}) {c} = {beauty}"
            );
            let direct = exr.at(&format!("diffuse_direct.{c}"), x, y);
            assert!(
                (direct - beauty).abs() <= HALF_EPS * beauty,
                "({x}, {y}) diffuse_direct.{c} = {direct}, beauty {beauty}"
            );
            for aov in LIGHT_PATHS.iter().filter(|&&a| a != "diffuse_direct") {
                assert_eq!(
                    exr.at(&format!("{aov}.{c}"), x, y),
                    0.0,
                    "({x}, {y}) {aov}.{c}"
                );
            }
            let albedo = exr.at(&format!("albedo.{c}"), x, y);
            assert!(
                (albedo - want).abs() <= HALF_EPS * want,
                "({x}, {y}) albedo.{c} = {albedo}"
            );
            let variance = exr.at(&format!("variance.{c}"), x, y);
            assert!(
                (0.0..=1e-6).contains(&variance),
                "({x}, {y}) variance.{c} = {variance}"
            );
        }
        assert_eq!(exr.at("A", x, y), 1.0, "({x}, {y}) A");
        let n = [
            exr.at("N.X", x, y),
            exr.at("N.Y", x, y),
            exr.at("N.Z", x, y),
        ];
        assert!(
            (n[0].abs() + (n[1] - 1.0).abs() + n[2].abs()) <= 1e-6,
            "({x}, {y}) N = {n:?}"
        );
        let z = exr.at("Z", x, y);
        assert!((z - 2.0).abs() <= 2e-5, "({x}, {y}) Z = {z}");
        let py = exr.at("P.Y", x, y);
        assert!(py.abs() <= 1e-5, "({x}, {y}) P.Y = {py}");
    }
}
