//! `output::read_exr` and `cirrus aovs`: a layered EXR (beauty, colour AOV,
//! normals, positions, depth, a single channel, two Cryptomatte ranks)
//! written with `write_exr` reads back with the same names, types, values and
//! string metadata; the contact sheet has the documented grid size and draws
//! each kind of layer as documented; bad inputs fail naming the file.

use crate::common;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use cirrus::image::{
    read_exr, read_image, write_exr, Channel, ChannelFormat, Compression, ExrImage, PixelType,
};
use cirrus::output::{write_contact_sheet, write_preview};
use cirrus::scene::ColorSpace;

const WIDTH: u32 = 32;
const HEIGHT: u32 = 16;

/// Channel names and storage of the test EXR, in written order.
const CHANNELS: &[(&str, PixelType)] = &[
    ("R", PixelType::Half),
    ("G", PixelType::Half),
    ("B", PixelType::Half),
    ("A", PixelType::Half),
    ("diffuse_direct.R", PixelType::Half),
    ("diffuse_direct.G", PixelType::Half),
    ("diffuse_direct.B", PixelType::Half),
    ("N.X", PixelType::Float),
    ("N.Y", PixelType::Float),
    ("N.Z", PixelType::Float),
    ("P.X", PixelType::Float),
    ("P.Y", PixelType::Float),
    ("P.Z", PixelType::Float),
    ("Z", PixelType::Float),
    ("sample_count.Y", PixelType::Float),
    ("CryptoObject00.R", PixelType::Float),
    ("CryptoObject00.G", PixelType::Float),
    ("CryptoObject00.B", PixelType::Float),
    ("CryptoObject00.A", PixelType::Float),
    ("CryptoObject01.R", PixelType::Float),
    ("CryptoObject01.G", PixelType::Float),
    ("CryptoObject01.B", PixelType::Float),
    ("CryptoObject01.A", PixelType::Float),
];

/// The beauty's constant colour, exact in half.
const BEAUTY: [f32; 3] = [0.1875, 0.5, 2.0];

/// The value of channel `c` at pixel `p`. The beauty, `N` (+Z) and `A`
/// (0.25) are constant so the sheet's tiles have known colours; other half
/// channels are multiples of 1/64 below 8 (exact in half); Cryptomatte ids
/// are finite floats from hash-like bits, with coverages 1/2, 1/4, 1/8, 1/8
/// over the four ranks; other float channels are arbitrary.
fn value(p: usize, c: usize) -> f32 {
    let (name, pixel_type) = CHANNELS[c];
    match name {
        "R" => BEAUTY[0],
        "G" => BEAUTY[1],
        "B" => BEAUTY[2],
        "A" => 0.25,
        "N.X" | "N.Y" => 0.0,
        "N.Z" => 1.0,
        "CryptoObject00.G" => 0.5,
        "CryptoObject00.A" => 0.25,
        "CryptoObject01.G" | "CryptoObject01.A" => 0.125,
        _ if name.starts_with("Crypto") => {
            f32::from_bits(0x3e00_0000 | ((p % 3) as u32 * 0x0012_3457 + c as u32))
        }
        _ if pixel_type == PixelType::Half => ((p * 7 + c * 3) % 512) as f32 / 64.0,
        _ => 1234.567 + p as f32 * 0.013 - c as f32 * 17.0,
    }
}

/// Writes the test EXR into a fresh scratch folder and returns its path.
fn write_test_exr(test: &str) -> std::path::PathBuf {
    let dir = common::scratch(test);
    let path = dir.join("layers.exr");
    let pixels: Vec<f32> = (0..(WIDTH * HEIGHT) as usize)
        .flat_map(|p| (0..CHANNELS.len()).map(move |c| value(p, c)))
        .collect();
    let image = ExrImage {
        width: WIDTH,
        height: HEIGHT,
        channels: CHANNELS
            .iter()
            .map(|&(name, pixel_type)| Channel {
                name: name.into(),
                pixel_type,
            })
            .collect(),
        pixels: &pixels,
        compression: Compression::Zip,
        strings: vec![
            ("cryptomatte/f834d0a/name".into(), "CryptoObject".into()),
            ("cryptomatte/f834d0a/hash".into(), "MurmurHash3_32".into()),
            ("cirrus/version".into(), "test".into()),
        ],
        matrices: Vec::new(),
    };
    write_exr(&path, &image).unwrap();
    path
}

#[test]
fn layered_exr_reads_back_with_names_types_values_and_metadata() {
    let path = write_test_exr("aovs_read_back");
    let exr = read_exr(&path).unwrap();
    assert_eq!((exr.width, exr.height), (WIDTH, HEIGHT));
    assert_eq!(exr.channels.len(), CHANNELS.len());
    for (c, &(name, pixel_type)) in CHANNELS.iter().enumerate() {
        let index = exr
            .channel_index(name)
            .unwrap_or_else(|| panic!("{name} missing from {:?}", exr.channels));
        let want_format = match pixel_type {
            PixelType::Half => ChannelFormat::Half,
            PixelType::Float => ChannelFormat::Float,
        };
        assert_eq!(exr.channels[index].format, want_format, "{name}");
        let values: Vec<f32> = exr.channel_values(index).collect();
        let want: Vec<f32> = (0..(WIDTH * HEIGHT) as usize)
            .map(|p| value(p, c))
            .collect();
        assert_eq!(values, want, "{name}");
    }
    assert_eq!(exr.strings["cryptomatte/f834d0a/name"], "CryptoObject");
    assert_eq!(exr.strings["cryptomatte/f834d0a/hash"], "MurmurHash3_32");
    assert_eq!(exr.strings["cirrus/version"], "test");
}

#[test]
fn uint_channels_read_back_by_value() {
    use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Image, SmallVec, WritableImage};
    let dir = common::scratch("aovs_uint");
    let path = dir.join("ids.exr");
    let ids: Vec<u32> = vec![0, 7, 1 << 24, 123_456];
    let depth: Vec<f32> = vec![0.5, 1.5, -2.0, 1e30];
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        AnyChannel::new("id", FlatSamples::U32(ids.clone())),
        AnyChannel::new("Z", FlatSamples::F32(depth.clone())),
    ]));
    Image::from_channels((2, 2), channels)
        .write()
        .to_file(&path)
        .unwrap();
    let exr = read_exr(&path).unwrap();
    let id = exr.channel_index("id").unwrap();
    let z = exr.channel_index("Z").unwrap();
    assert_eq!(exr.channels[id].format, ChannelFormat::Uint);
    assert_eq!(exr.channels[z].format, ChannelFormat::Float);
    let want_ids: Vec<f32> = ids.iter().map(|&i| i as f32).collect();
    assert_eq!(exr.channel_values(id).collect::<Vec<_>>(), want_ids);
    assert_eq!(exr.channel_values(z).collect::<Vec<_>>(), depth);
}

#[test]
fn cirrus_aovs_writes_the_sheet_beside_the_exr() {
    let path = write_test_exr("aovs_cli");
    let stdout = common::cirrus_ok(&["aovs".as_ref(), path.as_os_str()]);
    for layer in [
        "RGB",
        "A",
        "diffuse_direct",
        "N",
        "P",
        "Z",
        "sample_count",
        "CryptoObject",
    ] {
        assert!(
            stdout
                .lines()
                .any(|l| l.split_whitespace().nth(2) == Some(layer)),
            "layer {layer} not listed:\n{stdout}"
        );
    }
    // 8 tiles of 256x128 (32x16 scaled up), 4 per row, 2-pixel separators.
    let sheet = read_image(&path.with_extension("aovs.png"), ColorSpace::Raw).unwrap();
    assert_eq!(
        (sheet.width, sheet.height),
        (4 * 256 + 5 * 2, 2 * 128 + 3 * 2)
    );
    assert_eq!(sheet.channels, 3);

    // -o puts it elsewhere.
    let other = path.with_file_name("elsewhere.png");
    common::cirrus_ok(&[
        "aovs".as_ref(),
        path.as_os_str(),
        "-o".as_ref(),
        other.as_os_str(),
    ]);
    assert!(other.exists());
}

#[test]
fn sheet_tiles_show_normals_alpha_and_separators() {
    let path = write_test_exr("aovs_tiles");
    let exr = read_exr(&path).unwrap();
    let sheet_path = path.with_file_name("tiles.png");
    let sheet = write_contact_sheet(&exr, &sheet_path).unwrap();
    let png = read_image(&sheet_path, ColorSpace::Raw).unwrap();
    assert_eq!((png.width, png.height), (sheet.width, sheet.height));
    let pixel = |x: u32, y: u32| {
        let i = ((y * png.width + x) * 3) as usize;
        [png.pixels[i], png.pixels[i + 1], png.pixels[i + 2]]
    };
    // The centre of a tile, away from its label.
    let centre = |layer: &str| {
        let tile = sheet.tiles.iter().find(|t| t.layer == layer).unwrap();
        pixel(
            2 + tile.column * (256 + 2) + 128,
            2 + tile.row * (128 + 2) + 64,
        )
    };
    let near = |got: [f32; 3], want: [f32; 3]| {
        got.iter()
            .zip(want)
            .all(|(g, w)| (g - w).abs() <= 1.0 / 255.0)
    };
    // The beauty looks as in the preview PNG; N = +Z is drawn as
    // 0.5 + 0.5 n; A = 0.25 as grey.
    let preview_path = path.with_file_name("preview.png");
    write_preview(&preview_path, 1, 1, &BEAUTY).unwrap();
    let preview = read_image(&preview_path, ColorSpace::Raw).unwrap().pixels;
    assert!(
        near(centre("RGB"), [preview[0], preview[1], preview[2]]),
        "{:?} {preview:?}",
        centre("RGB")
    );
    assert!(near(centre("N"), [0.5, 0.5, 1.0]), "{:?}", centre("N"));
    assert!(near(centre("A"), [0.25; 3]), "{:?}", centre("A"));
    // The separator at the top-left corner is dark.
    assert!(pixel(0, 0).iter().all(|&v| v < 0.2), "{:?}", pixel(0, 0));
    let names: BTreeMap<&str, (u32, u32)> = sheet
        .tiles
        .iter()
        .map(|t| (t.layer.as_str(), (t.row, t.column)))
        .collect();
    assert_eq!(names.len(), 8, "{names:?}");
}

#[test]
fn bad_inputs_fail_naming_the_file() {
    let dir = common::scratch("aovs_bad");
    let missing = dir.join("missing.exr");
    let png = dir.join("picture.png");
    let exr = write_test_exr("aovs_bad_source");
    common::cirrus_ok(&[
        "aovs".as_ref(),
        exr.as_os_str(),
        "-o".as_ref(),
        png.as_os_str(),
    ]);
    for (input, reason) in [
        (missing.as_path(), "No such file"),
        (png.as_path(), "not an OpenEXR file"),
    ] {
        let stderr = cirrus_fails(input);
        assert!(
            stderr.contains(&input.display().to_string()) && stderr.contains(reason),
            "{stderr}"
        );
    }
}

/// Runs `cirrus aovs INPUT`, checks that it fails, and returns its stderr.
fn cirrus_fails(input: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(["aovs".as_ref(), input.as_os_str()])
        .output()
        .unwrap();
    assert!(!out.status.success(), "cirrus aovs {input:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}
