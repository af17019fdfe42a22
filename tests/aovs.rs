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
//! Half-precision tolerance: a half stores a normal value with a relative
//! rounding error of at most 2^-11 (11-bit significand), and a value below
//! 2^-14 (a subnormal) with an absolute error of at most 2^-25.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use cirrus::film::{layer_key, name_to_id};
use exr::meta::attribute::AttributeValue;
use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};
use glam::{Mat3, Vec3};
use serde_json::Value;

/// Relative rounding error of a normal half value.
const HALF_EPS: f64 = 1.0 / 2048.0;

/// Absolute rounding error of a subnormal half value (below 2^-14).
const HALF_SUBNORMAL_ERROR: f64 = 1.0 / 33_554_432.0;

/// The light-path AOVs, which partition the beauty by the first scattering
/// event after the camera.
const LIGHT_PATHS: [&str; 8] = [
    "emission",
    "diffuse_direct",
    "diffuse_indirect",
    "specular_direct",
    "specular_indirect",
    "transmission",
    "volume_direct",
    "volume_indirect",
];

/// `--aovs default`, in the order the contract lists them.
const DEFAULT: [&str; 13] = [
    "emission",
    "diffuse_direct",
    "diffuse_indirect",
    "specular_direct",
    "specular_indirect",
    "transmission",
    "volume_direct",
    "volume_indirect",
    "albedo",
    "N",
    "Z",
    "CryptoObject",
    "CryptoMaterial",
];

/// `--aovs all` adds these to [`DEFAULT`].
const ALL_EXTRA: [&str; 3] = ["P", "sample_count", "variance"];

/// How a channel is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Half,
    Float,
}

impl Format {
    /// The name `tests/python/read_exr.py` gives the format.
    fn python_name(self) -> &'static str {
        match self {
            Format::Half => "half",
            Format::Float => "float",
        }
    }
}

/// The channels (name, storage) the contract gives the AOV `aov`.
fn aov_channels(aov: &str) -> Vec<(String, Format)> {
    let with = |suffixes: &[&str], format| {
        suffixes
            .iter()
            .map(|s| (format!("{aov}.{s}"), format))
            .collect::<Vec<_>>()
    };
    match aov {
        "albedo" => with(&["R", "G", "B"], Format::Half),
        _ if LIGHT_PATHS.contains(&aov) => with(&["R", "G", "B"], Format::Half),
        "N" | "P" => with(&["X", "Y", "Z"], Format::Float),
        "Z" | "sample_count" => vec![(aov.to_string(), Format::Float)],
        "variance" => with(&["R", "G", "B"], Format::Float),
        "CryptoObject" | "CryptoMaterial" => (0..3)
            .flat_map(|rank| {
                ["R", "G", "B", "A"].map(|c| (format!("{aov}{rank:02}.{c}"), Format::Float))
            })
            .collect(),
        _ => panic!("no AOV {aov} in the contract"),
    }
}

/// The base layer: float R, G, B and A.
fn beauty_channels() -> Vec<(String, Format)> {
    ["R", "G", "B", "A"]
        .iter()
        .map(|c| (c.to_string(), Format::Float))
        .collect()
}

/// Every channel of a file holding the beauty and `aovs`, sorted by name.
fn expected_channels(aovs: &[&str]) -> BTreeMap<String, Format> {
    beauty_channels()
        .into_iter()
        .chain(aovs.iter().flat_map(|aov| aov_channels(aov)))
        .collect()
}

/// `scenes/tests/NAME.usda` exported once per test process (see
/// [`common::exported_test_scene`]).
fn exported(name: &str) -> PathBuf {
    common::exported_test_scene(name, "aovs_scenes")
}

/// The arguments of `cirrus render SCENE -o OUT` at `res` (e.g. "20x20")
/// and `spp`, seed 7, one thread, the box filter unless `extra` names
/// another, then `extra`.
fn render_args(scene: &str, out: &Path, res: &str, spp: u32, extra: &[&str]) -> Vec<String> {
    let scene = exported(scene);
    let spp = spp.to_string();
    [
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--res",
        res,
        "--spp",
        &spp,
        "--seed",
        "7",
        "--threads",
        "1",
    ]
    .iter()
    .chain(if extra.contains(&"--filter") {
        &[][..]
    } else {
        &["--filter", "box"][..]
    })
    .chain(extra)
    .map(|s| s.to_string())
    .collect()
}

/// Runs `cirrus render` (see [`render_args`]) and panics with its stderr if
/// it fails.
fn render(scene: &str, out: &Path, res: &str, spp: u32, extra: &[&str]) {
    let args = render_args(scene, out, res, spp, extra);
    let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
    common::cirrus_ok(&args);
}

/// An EXR as the `exr` crate reads it: every channel as f32 (halves widened
/// exactly) with its storage, and the header attributes the tests look at.
struct Exr {
    width: usize,
    height: usize,
    channels: BTreeMap<String, (Format, Vec<f32>)>,
    /// Text attributes of the header, custom and standard (`software`).
    strings: BTreeMap<String, String>,
    world_to_camera: Option<[f32; 16]>,
    world_to_ndc: Option<[f32; 16]>,
}

impl Exr {
    /// Reads `path` with the `exr` crate; it must hold one layer.
    fn read(path: &Path) -> Exr {
        let image = read_all_flat_layers_from_file(path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(image.layer_data.len(), 1, "{}", path.display());
        let layer = &image.layer_data[0];
        let channels = layer
            .channel_data
            .list
            .iter()
            .map(|c| {
                let plane = match &c.sample_data {
                    FlatSamples::F16(v) => (Format::Half, v.iter().map(|h| h.to_f32()).collect()),
                    FlatSamples::F32(v) => (Format::Float, v.clone()),
                    FlatSamples::U32(_) => panic!("{}: {} is uint", path.display(), c.name),
                };
                (c.name.to_string(), plane)
            })
            .collect();
        let mut strings: BTreeMap<String, String> = image
            .attributes
            .other
            .iter()
            .chain(&layer.attributes.other)
            .filter_map(|(k, v)| match v {
                AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
                _ => None,
            })
            .collect();
        if let Some(software) = &layer.attributes.software_name {
            strings.insert("software".into(), software.to_string());
        }
        Exr {
            width: layer.size.0,
            height: layer.size.1,
            channels,
            strings,
            world_to_camera: layer.attributes.world_to_camera,
            world_to_ndc: layer.attributes.world_to_normalized_device,
        }
    }

    /// Channel names and storage, sorted by name.
    fn formats(&self) -> BTreeMap<String, Format> {
        self.channels
            .iter()
            .map(|(name, (format, _))| (name.clone(), *format))
            .collect()
    }

    /// The values of channel `name`, row 0 at the top.
    fn plane(&self, name: &str) -> &[f32] {
        &self
            .channels
            .get(name)
            .unwrap_or_else(|| panic!("no channel {name} in {:?}", self.formats()))
            .1
    }

    /// Channel `name` at pixel (x, y).
    fn at(&self, name: &str, x: usize, y: usize) -> f64 {
        f64::from(self.plane(name)[y * self.width + x])
    }

    /// Every pixel (x, y), row by row.
    fn pixels(&self) -> impl Iterator<Item = (usize, usize)> {
        let (w, h) = (self.width, self.height);
        (0..h).flat_map(move |y| (0..w).map(move |x| (x, y)))
    }
}

/// Renders `scene` and reads the result back.
fn render_and_read(test: &str, scene: &str, res: &str, spp: u32, extra: &[&str]) -> (PathBuf, Exr) {
    let path = common::scratch(test).join("out.exr");
    render(scene, &path, res, spp, extra);
    let exr = Exr::read(&path);
    (path, exr)
}

/// One Cryptomatte layer decoded: manifest (name -> id) and, per name, its
/// coverage of every pixel.
struct Matte {
    manifest: BTreeMap<String, f32>,
    coverage: BTreeMap<String, Vec<f64>>,
}

/// Decodes the Cryptomatte layer `layer` (e.g. "CryptoObject") of `exr` as
/// the specification's reference decoder does: find the layer's metadata
/// key, read the manifest, and for each manifest id sum the coverage of the
/// ranks whose id equals it. Also checks the metadata, that every rank's id
/// with coverage is in the manifest, that empty ranks hold (0, 0), and that
/// ranks are sorted by decreasing coverage.
fn decode_cryptomatte(exr: &Exr, layer: &str) -> Matte {
    let key = layer_key(layer);
    let attr = |field: &str| -> &str {
        exr.strings
            .get(&format!("cryptomatte/{key}/{field}"))
            .unwrap_or_else(|| {
                panic!(
                    "{layer}: no cryptomatte/{key}/{field} in {:?}",
                    exr.strings.keys()
                )
            })
    };
    assert_eq!(attr("name"), layer);
    assert_eq!(attr("hash"), "MurmurHash3_32");
    assert_eq!(attr("conversion"), "uint32_to_float32");
    let manifest: BTreeMap<String, Value> =
        serde_json::from_str(attr("manifest")).expect("manifest is a JSON object");
    let manifest: BTreeMap<String, f32> = manifest
        .into_iter()
        .map(|(name, hex)| {
            let hex = hex.as_str().expect("manifest ids are strings");
            assert_eq!(hex.len(), 8, "{name}: id {hex} is not 8 hex digits");
            let id = f32::from_bits(u32::from_str_radix(hex, 16).unwrap());
            assert_eq!(
                id.to_bits(),
                name_to_id(&name).to_bits(),
                "{name}: manifest id {hex}"
            );
            (name, id)
        })
        .collect();

    let ranks: Vec<(&[f32], &[f32])> = (0..6)
        .map(|rank| {
            let prefix = format!("{layer}{:02}", rank / 2);
            let (id, cov) = if rank % 2 == 0 {
                ("R", "G")
            } else {
                ("B", "A")
            };
            (
                exr.plane(&format!("{prefix}.{id}")),
                exr.plane(&format!("{prefix}.{cov}")),
            )
        })
        .collect();
    let known: BTreeSet<u32> = manifest.values().map(|id| id.to_bits()).collect();
    for p in 0..exr.width * exr.height {
        for (rank, (ids, covs)) in ranks.iter().enumerate() {
            if covs[p] == 0.0 {
                assert_eq!(
                    ids[p], 0.0,
                    "{layer} pixel {p} rank {rank}: id without coverage"
                );
            } else {
                assert!(
                    known.contains(&ids[p].to_bits()),
                    "{layer} pixel {p} rank {rank}: id {:08x} not in the manifest",
                    ids[p].to_bits()
                );
            }
            if rank > 0 {
                assert!(
                    ranks[rank - 1].1[p] >= covs[p],
                    "{layer} pixel {p}: rank {rank} has more coverage than rank {}",
                    rank - 1
                );
            }
        }
    }
    let coverage = manifest
        .iter()
        .map(|(name, id)| {
            let map = (0..exr.width * exr.height)
                .map(|p| {
                    ranks
                        .iter()
                        .filter(|(ids, _)| ids[p].to_bits() == id.to_bits())
                        .map(|(_, covs)| f64::from(covs[p]))
                        .sum()
                })
                .collect();
            (name.clone(), map)
        })
        .collect();
    Matte { manifest, coverage }
}

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
    for layer in ["CryptoObject", "CryptoMaterial"] {
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
    for layer in ["CryptoObject", "CryptoMaterial"] {
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
        for layer in ["CryptoObject", "CryptoMaterial"] {
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

/// scenes/tests/aovs_depth_card.usda, 32 x 32 at 16 spp with every AOV,
/// rendered once per test process.
fn card() -> &'static Exr {
    static CARD: OnceLock<Exr> = OnceLock::new();
    CARD.get_or_init(|| {
        render_and_read(
            "aovs_card",
            "aovs_depth_card",
            "32x32",
            16,
            &["--aovs", "all"],
        )
        .1
    })
}

/// Where pixel (x, y) lies relative to the card (columns 5.6 to 24.8, rows
/// 4.4 to 23.2, see the scene's doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CardPixel {
    Inside,
    Edge,
    Outside,
}

fn card_pixel(x: usize, y: usize) -> CardPixel {
    let inside = |i: usize, lo: f64, hi: f64| (i as f64) >= lo && (i + 1) as f64 <= hi;
    let outside = |i: usize, lo: f64, hi: f64| (i + 1) as f64 <= lo || (i as f64) >= hi;
    if outside(x, 5.6, 24.8) || outside(y, 4.4, 23.2) {
        CardPixel::Outside
    } else if inside(x, 5.6, 24.8) && inside(y, 4.4, 23.2) {
        CardPixel::Inside
    } else {
        CardPixel::Edge
    }
}

/// The rig's rotation rotY(30) rotX(-20): camera to world directions.
fn card_rotation() -> Mat3 {
    Mat3::from_rotation_y(30f32.to_radians()) * Mat3::from_rotation_x((-20f32).to_radians())
}

/// `v` (a point, w = 1) times the 4x4 matrix `m` in OpenEXR's (Imath's)
/// row-vector layout, translation in m[12..15]; returns (x, y, z, w).
fn transform_row_vector(v: Vec3, m: &[f32; 16]) -> [f64; 4] {
    let v = [f64::from(v.x), f64::from(v.y), f64::from(v.z), 1.0];
    std::array::from_fn(|j| (0..4).map(|i| v[i] * f64::from(m[i * 4 + j])).sum())
}

/// Z on a card perpendicular to the view axis at distance 4 of a perspective
/// camera: exactly 4 (1e-5 relative) in every pixel whose samples hit it at
/// all (A > 0), although the ray lengths differ by up to 22%; +inf in every
/// pixel none of whose samples hits it (A = 0), which includes every pixel
/// outside the card.
#[test]
fn depth_is_the_view_axis_distance_on_a_perpendicular_card() {
    let exr = card();
    let mut hit = 0;
    for (x, y) in exr.pixels() {
        let (z, a) = (exr.at("Z", x, y), exr.at("A", x, y));
        match card_pixel(x, y) {
            CardPixel::Inside => assert_eq!(a, 1.0, "({x}, {y}) A"),
            CardPixel::Outside => assert_eq!(a, 0.0, "({x}, {y}) A"),
            CardPixel::Edge => assert!(a > 0.0 && a < 1.0, "({x}, {y}) A = {a}"),
        }
        if a > 0.0 {
            hit += 1;
            assert!((z - 4.0).abs() <= 4e-5, "({x}, {y}) Z = {z}");
        } else {
            assert_eq!(z, f64::INFINITY, "({x}, {y}) Z where nothing is hit");
        }
    }
    assert!(hit > 18 * 18, "{hit} pixels see the card");
}

/// Albedo of the constant-colour card: its diffuseColor (0.25, 0.5, 0.75)
/// (exact in half) where every sample sees it, 0 where none does, and at the
/// edges colour x coverage A (escaped samples add 0), within half precision.
#[test]
fn albedo_is_the_diffuse_colour_where_the_plane_is_seen() {
    let exr = card();
    for (x, y) in exr.pixels() {
        let a = exr.at("A", x, y);
        for (c, colour) in ["R", "G", "B"].into_iter().zip([0.25, 0.5, 0.75]) {
            let albedo = exr.at(&format!("albedo.{c}"), x, y);
            let want = colour * a;
            assert!(
                (albedo - want).abs() <= HALF_EPS * want + HALF_SUBNORMAL_ERROR,
                "({x}, {y}) albedo.{c} = {albedo}, want {want} ({:?}, A = {a})",
                card_pixel(x, y)
            );
        }
    }
}

/// The other geometric AOVs and the header matrices on the card: N is the
/// card's world normal R (0, 0, 1) inside and 0 outside; P lies on the card
/// plane at view depth 4 inside; sample_count is the spp; the variance is 0
/// inside and outside (the card's radiance is noise-free: its bounces
/// escape) and at an edge pixel is that of n samples of which a fraction A
/// see radiance L and the rest 0: A (1 - A) L^2 / (n - 1) for the unbiased
/// sample variance (or / n for the biased one), 1e-3 relative. worldToCamera
/// (row vectors, as Imath) takes the camera's position to the origin and P
/// to depth |z| = Z; worldToNDC, after the perspective divide, takes P to a
/// point affine in the pixel centre (within 0.1 pixel: P is the mean of the
/// pixel's sample positions).
#[test]
fn geometry_variance_and_camera_matrices_agree_on_the_card() {
    let exr = card();
    let r = card_rotation();
    let normal = r * Vec3::Z;
    let forward = r * Vec3::NEG_Z;
    let eye = Vec3::new(1.0, 2.0, 3.0);
    let (cx, cy) = (15, 15);
    let radiance: Vec<f64> = ["R", "G", "B"].iter().map(|c| exr.at(c, cx, cy)).collect();
    assert!(
        radiance.iter().all(|&l| l > 0.0),
        "the card is lit: {radiance:?}"
    );
    let spp = 16.0;

    let to_camera = exr.world_to_camera.expect("worldToCamera");
    let origin = transform_row_vector(eye, &to_camera);
    assert!(
        origin[..3].iter().all(|v| v.abs() <= 1e-5) && (origin[3] - 1.0).abs() <= 1e-6,
        "eye -> {origin:?}"
    );
    let to_ndc = exr.world_to_ndc.expect("worldToNDC");
    let ndc = |x: usize, y: usize| -> [f64; 2] {
        let p = Vec3::new(
            exr.at("P.X", x, y) as f32,
            exr.at("P.Y", x, y) as f32,
            exr.at("P.Z", x, y) as f32,
        );
        let h = transform_row_vector(p, &to_ndc);
        [h[0] / h[3], h[1] / h[3]]
    };
    // The affine map pixel centre -> NDC through three interior pixels.
    let (o, ex, ey) = (ndc(6, 5), ndc(23, 5), ndc(6, 22));
    let du = [(ex[0] - o[0]) / 17.0, (ex[1] - o[1]) / 17.0];
    let dv = [(ey[0] - o[0]) / 17.0, (ey[1] - o[1]) / 17.0];
    let pixel_size = du[0].hypot(du[1]).min(dv[0].hypot(dv[1]));
    assert!(
        pixel_size > 0.0 && (du[0] * dv[1] - du[1] * dv[0]).abs() > 0.5 * pixel_size * pixel_size,
        "degenerate worldToNDC: {to_ndc:?}"
    );

    for (x, y) in exr.pixels() {
        let where_ = card_pixel(x, y);
        assert_eq!(exr.at("sample_count", x, y), spp, "({x}, {y}) sample_count");
        let n = Vec3::new(
            exr.at("N.X", x, y) as f32,
            exr.at("N.Y", x, y) as f32,
            exr.at("N.Z", x, y) as f32,
        );
        match where_ {
            CardPixel::Inside => assert!(
                (n - normal).abs().max_element() <= 1e-5,
                "({x}, {y}) N = {n}, want {normal}"
            ),
            CardPixel::Outside => assert_eq!(n, Vec3::ZERO, "({x}, {y}) N"),
            CardPixel::Edge => {}
        }
        if where_ == CardPixel::Inside {
            let p = Vec3::new(
                exr.at("P.X", x, y) as f32,
                exr.at("P.Y", x, y) as f32,
                exr.at("P.Z", x, y) as f32,
            );
            let depth = (p - eye).dot(forward);
            assert!(
                (depth - 4.0).abs() <= 1e-4,
                "({x}, {y}) P = {p} at view depth {depth}"
            );
            let camera = transform_row_vector(p, &to_camera);
            assert!(
                (camera[2].abs() - exr.at("Z", x, y)).abs() <= 1e-4,
                "({x}, {y}) worldToCamera takes P to {camera:?}"
            );
            let (u, v) = (x as f64 - 6.0, y as f64 - 5.0);
            let want = [o[0] + u * du[0] + v * dv[0], o[1] + u * du[1] + v * dv[1]];
            let got = ndc(x, y);
            let off = (got[0] - want[0]).hypot(got[1] - want[1]) / pixel_size;
            assert!(
                off <= 0.1,
                "({x}, {y}) worldToNDC takes P {off:.3} pixels off the affine map"
            );
        }
        let a = exr.at("A", x, y);
        for (c, l) in ["R", "G", "B"].into_iter().zip(&radiance) {
            let variance = exr.at(&format!("variance.{c}"), x, y);
            let spread = a * (1.0 - a) * l * l;
            let (lo, hi) = (spread / spp, spread / (spp - 1.0));
            assert!(
                variance >= lo * (1.0 - 1e-3) - 1e-9 && variance <= hi * (1.0 + 1e-3) + 1e-9,
                "({x}, {y}) variance.{c} = {variance:.4e}, want {lo:.4e}..{hi:.4e} (A = {a})"
            );
        }
    }
}

/// The visible area of each object of scenes/tests/aovs_cryptomatte.usda in
/// pixel (x, y) of the 20 x 20 image, as a fraction of the pixel:
/// (backdrop, CardA, CardB); CardB hides CardA where they overlap.
fn analytic_coverage(x: usize, y: usize) -> [f64; 3] {
    // Pixel (x, y) spans world x in [-1 + 0.1 x, -1 + 0.1 (x + 1)], y in [1 - 0.1 (y + 1), 1 - 0.1 y].
    let pixel = [
        -1.0 + 0.1 * x as f64,
        -1.0 + 0.1 * (x + 1) as f64,
        1.0 - 0.1 * (y + 1) as f64,
        1.0 - 0.1 * y as f64,
    ];
    let card_a = [-0.83, -0.07, -0.52, 0.61];
    let card_b = [-0.35, 0.77, -0.74, 0.35];
    let overlap = |r: [f64; 4], s: [f64; 4]| {
        [
            r[0].max(s[0]),
            r[1].min(s[1]),
            r[2].max(s[2]),
            r[3].min(s[3]),
        ]
    };
    let area = |r: [f64; 4]| ((r[1] - r[0]).max(0.0) * (r[3] - r[2]).max(0.0)) / 0.01;
    let a = area(overlap(card_a, pixel));
    let b = area(overlap(card_b, pixel));
    let ab = area(overlap(overlap(card_a, card_b), pixel));
    [1.0 - a - b + ab, a - ab, b]
}

/// Cryptomatte, decoded with the manifest by the reference algorithm: the
/// manifests name exactly the three mesh and two material prim paths; the
/// object coverages sum to 1 (1e-3) in every pixel (the backdrop fills the
/// view); each object's coverage is exactly 1 where it alone is seen and 0
/// where it is not seen, and at an edge the visible area within 3/64: the
/// 64 box-filtered samples of a pixel are an Owen-scrambled Sobol (0, 6,
/// 2)-net, whose count in a strip along one side of the pixel is within 1
/// of 64 times its area (each of the 64 elementary slabs holds one sample),
/// and within a few in a corner rectangle (measured: 0.0144 at worst); each
/// material's coverage is the sum of its objects'.
#[test]
fn cryptomatte_decodes_to_each_objects_visible_area() {
    let (_, exr) = render_and_read(
        "aovs_cryptomatte",
        "aovs_cryptomatte",
        "20x20",
        64,
        &["--aovs", "CryptoObject,CryptoMaterial"],
    );
    let objects = decode_cryptomatte(&exr, "CryptoObject");
    let materials = decode_cryptomatte(&exr, "CryptoMaterial");
    let object_names = ["/World/Backdrop", "/World/CardA", "/World/CardB"];
    assert_eq!(
        objects
            .manifest
            .keys()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        object_names
    );
    assert_eq!(
        materials
            .manifest
            .keys()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        ["/World/Looks/Grey", "/World/Looks/Red"]
    );

    let (mut fractional, mut worst) = (0, 0.0f64);
    for (x, y) in exr.pixels() {
        let p = y * exr.width + x;
        let decoded: Vec<f64> = object_names
            .iter()
            .map(|n| objects.coverage[*n][p])
            .collect();
        let sum: f64 = decoded.iter().sum();
        assert!(
            (sum - 1.0).abs() <= 1e-3,
            "({x}, {y}) object coverages sum to {sum}: {decoded:?}"
        );
        for ((name, &got), want) in object_names
            .iter()
            .zip(&decoded)
            .zip(analytic_coverage(x, y))
        {
            if want > 1.0 - 1e-9 {
                assert!(
                    (got - 1.0).abs() <= 1e-6,
                    "({x}, {y}) {name} covers {got}, not 1"
                );
            } else if want < 1e-9 {
                assert_eq!(got, 0.0, "({x}, {y}) {name} covers {got}, not 0");
            } else {
                fractional += 1;
                worst = worst.max((got - want).abs());
                assert!(
                    (got - want).abs() <= 3.0 / 64.0,
                    "({x}, {y}) {name} covers {got}, visible area {want:.4}"
                );
            }
        }
        let grey = materials.coverage["/World/Looks/Grey"][p];
        let red = materials.coverage["/World/Looks/Red"][p];
        assert!(
            (grey - decoded[0]).abs() <= 1e-6,
            "({x}, {y}) Grey {grey} vs Backdrop {}",
            decoded[0]
        );
        assert!(
            (red - decoded[1] - decoded[2]).abs() <= 1e-6,
            "({x}, {y}) Red {red} vs the cards {decoded:?}"
        );
    }
    eprintln!("{fractional} fractional coverages, worst error {worst:.4}");
    assert!(fractional >= 40, "only {fractional} edge coverages");
}

/// The README's first command at its CI preset (`.ci/quickstart --preset ci`,
/// the whole script: set-up, explosion VDB, demo stage, render, contact
/// sheet) ends with the demo's EXR holding exactly the default AOV contract,
/// every value finite (Z: +inf on the sky), most pixels lit in the beauty, and the PNG and contact
/// sheet beside it.
#[test]
fn quickstart_ci_preset_renders_the_demo_with_the_default_aovs() {
    let out = common::scratch("quickstart_ci");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run = std::process::Command::new(root.join(".ci/quickstart"))
        .args(["--preset", "ci", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        ".ci/quickstart --preset ci failed:\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let exr = Exr::read(&out.join("canyon.exr"));
    assert_eq!(exr.formats(), expected_channels(&DEFAULT));
    assert_eq!((exr.width, exr.height), (256, 144));
    for (name, (_, values)) in &exr.channels {
        // Z is +inf where nothing is hit (the sky): the contract.
        let ok = |v: &f32| v.is_finite() || (name == "Z" && *v == f32::INFINITY);
        assert!(values.iter().all(ok), "{name}: NaN or -inf");
    }
    let lit = exr.plane("R").iter().filter(|&&v| v > 0.01).count();
    assert!(lit > exr.width * exr.height / 2, "{lit} lit pixels");
    for png in ["canyon.png", "canyon.aovs.png"] {
        let bytes = std::fs::metadata(out.join(png))
            .map(|m| m.len())
            .unwrap_or(0);
        assert!(bytes > 1000, "{png}: {bytes} bytes");
    }
}
