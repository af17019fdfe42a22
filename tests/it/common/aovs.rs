//! What the AOV tests share: the channel contract (names and storage of
//! every AOV), rendering a `scenes/tests/aovs_*` scene, reading its EXR with
//! the `exr` crate, and decoding a Cryptomatte layer as the specification's
//! reference decoder does.
//!
//! Half-precision tolerance: a half stores a normal value with a relative
//! rounding error of at most 2^-11 (11-bit significand), and a value below
//! 2^-14 (a subnormal) with an absolute error of at most 2^-25.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use cirrus::film::{layer_key, name_to_id};
use exr::meta::attribute::AttributeValue;
use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};

use serde_json::Value;

/// Relative rounding error of a normal half value.
pub const HALF_EPS: f64 = 1.0 / 2048.0;

/// Absolute rounding error of a subnormal half value (below 2^-14).
pub const HALF_SUBNORMAL_ERROR: f64 = 1.0 / 33_554_432.0;

/// The light-path AOVs, which partition the beauty by the first scattering
/// event after the camera.
pub const LIGHT_PATHS: [&str; 8] = [
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
pub const DEFAULT: [&str; 14] = [
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
    "CryptoAsset",
];

/// `--aovs all` adds these to [`DEFAULT`].
pub const ALL_EXTRA: [&str; 3] = ["P", "sample_count", "variance"];

/// How a channel is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Half,
    Float,
}

impl Format {
    /// The name `tests/python/read_exr.py` gives the format.
    pub fn python_name(self) -> &'static str {
        match self {
            Format::Half => "half",
            Format::Float => "float",
        }
    }
}

/// The channels (name, storage) the contract gives the AOV `aov`.
pub fn aov_channels(aov: &str) -> Vec<(String, Format)> {
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
        "CryptoObject" | "CryptoMaterial" | "CryptoAsset" => (0..3)
            .flat_map(|rank| {
                ["R", "G", "B", "A"].map(|c| (format!("{aov}{rank:02}.{c}"), Format::Float))
            })
            .collect(),
        _ => panic!("no AOV {aov} in the contract"),
    }
}

/// The base layer: float R, G, B and A.
pub fn beauty_channels() -> Vec<(String, Format)> {
    ["R", "G", "B", "A"]
        .iter()
        .map(|c| (c.to_string(), Format::Float))
        .collect()
}

/// Every channel of a file holding the beauty and `aovs`, sorted by name.
pub fn expected_channels(aovs: &[&str]) -> BTreeMap<String, Format> {
    beauty_channels()
        .into_iter()
        .chain(aovs.iter().flat_map(|aov| aov_channels(aov)))
        .collect()
}

/// `scenes/tests/NAME.usda` exported once per test process (see
/// [`super::exported_test_scene`]).
pub fn exported(name: &str) -> PathBuf {
    super::exported_test_scene(name, "aovs_scenes")
}

/// The arguments of `cirrus render SCENE -o OUT` at `res` (e.g. "20x20")
/// and `spp`, seed 7, one thread, the box filter unless `extra` names
/// another, then `extra`.
pub fn render_args(scene: &str, out: &Path, res: &str, spp: u32, extra: &[&str]) -> Vec<String> {
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
pub fn render(scene: &str, out: &Path, res: &str, spp: u32, extra: &[&str]) {
    let args = render_args(scene, out, res, spp, extra);
    let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
    super::cirrus_ok(&args);
}

/// An EXR as the `exr` crate reads it: every channel as f32 (halves widened
/// exactly) with its storage, and the header attributes the tests look at.
pub struct Exr {
    pub width: usize,
    pub height: usize,
    pub channels: BTreeMap<String, (Format, Vec<f32>)>,
    /// Text attributes of the header, custom and standard (`software`).
    pub strings: BTreeMap<String, String>,
    pub world_to_camera: Option<[f32; 16]>,
    pub world_to_ndc: Option<[f32; 16]>,
}

impl Exr {
    /// Reads `path` with the `exr` crate; it must hold one layer.
    pub fn read(path: &Path) -> Exr {
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
    pub fn formats(&self) -> BTreeMap<String, Format> {
        self.channels
            .iter()
            .map(|(name, (format, _))| (name.clone(), *format))
            .collect()
    }

    /// The values of channel `name`, row 0 at the top.
    pub fn plane(&self, name: &str) -> &[f32] {
        &self
            .channels
            .get(name)
            .unwrap_or_else(|| panic!("no channel {name} in {:?}", self.formats()))
            .1
    }

    /// Channel `name` at pixel (x, y).
    pub fn at(&self, name: &str, x: usize, y: usize) -> f64 {
        f64::from(self.plane(name)[y * self.width + x])
    }

    /// Every pixel (x, y), row by row.
    pub fn pixels(&self) -> impl Iterator<Item = (usize, usize)> {
        let (w, h) = (self.width, self.height);
        (0..h).flat_map(move |y| (0..w).map(move |x| (x, y)))
    }
}

/// Renders `scene` and reads the result back.
pub fn render_and_read(
    test: &str,
    scene: &str,
    res: &str,
    spp: u32,
    extra: &[&str],
) -> (PathBuf, Exr) {
    let path = super::scratch(test).join("out.exr");
    render(scene, &path, res, spp, extra);
    let exr = Exr::read(&path);
    (path, exr)
}

/// One Cryptomatte layer decoded: manifest (name -> id) and, per name, its
/// coverage of every pixel.
pub struct Matte {
    pub manifest: BTreeMap<String, f32>,
    pub coverage: BTreeMap<String, Vec<f64>>,
}

/// Decodes the Cryptomatte layer `layer` (e.g. "CryptoObject") of `exr` as
/// the specification's reference decoder does: find the layer's metadata
/// key, read the manifest, and for each manifest id sum the coverage of the
/// ranks whose id equals it. Also checks the metadata, that every rank's id
/// with coverage is in the manifest, that empty ranks hold (0, 0), and that
/// ranks are sorted by decreasing coverage.
pub fn decode_cryptomatte(exr: &Exr, layer: &str) -> Matte {
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
