//! EXRs written through the OpenImageIO bridge, read back by two independent
//! readers (the `exr` crate and the Python `OpenEXR` package), and texture
//! images read through the same bridge into linear floats.

use crate::common;
use std::path::Path;

use cirrus::image::{read_image, write_exr, Channel, Compression, ExrImage, ImageError, PixelType};
use cirrus::scene::ColorSpace;
use exr::prelude::{f16, read_all_flat_layers_from_file, FlatSamples};
use serde_json::Value;

const WIDTH: u32 = 7;
const HEIGHT: u32 = 5;

/// The channel set the AOV writer will use: colour as half, geometry as float.
fn channels() -> Vec<Channel> {
    let half = ["R", "G", "B", "A", "diffuse.R", "diffuse.G", "diffuse.B"];
    let float = ["N.X", "N.Y", "N.Z", "Z"];
    half.iter()
        .map(|n| (n, PixelType::Half))
        .chain(float.iter().map(|n| (n, PixelType::Float)))
        .map(|(n, t)| Channel {
            name: n.to_string(),
            pixel_type: t,
        })
        .collect()
}

/// Distinct values per (pixel, channel): multiples of 1/64 for half channels
/// (exactly representable), arbitrary floats for float channels.
fn pixels(channels: &[Channel]) -> Vec<f32> {
    let mut out = Vec::new();
    for p in 0..(WIDTH * HEIGHT) as usize {
        for (c, ch) in channels.iter().enumerate() {
            out.push(match ch.pixel_type {
                PixelType::Half => (p * 3 + c) as f32 / 64.0,
                PixelType::Float => 1234.567 + p as f32 * 0.001 + c as f32 * 10.0,
            });
        }
    }
    out
}

const WORLD_TO_CAMERA: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 3.0, -2.0, 5.5, 1.0,
];

fn write_test_exr(path: &Path, compression: Compression) {
    let channels = channels();
    let values = pixels(&channels);
    let image = ExrImage {
        width: WIDTH,
        height: HEIGHT,
        channels,
        pixels: &values,
        compression,
        strings: vec![
            ("software".into(), "cirrus test".into()),
            ("cirrus/settings".into(), "spp=4".into()),
        ],
        matrices: vec![("worldToCamera".into(), WORLD_TO_CAMERA)],
    };
    write_exr(path, &image).unwrap();
}

/// The value of channel `name` at pixel `p` in what we wrote.
fn expected(name: &str, p: usize) -> f32 {
    let channels = channels();
    let c = channels.iter().position(|ch| ch.name == name).unwrap();
    pixels(&channels)[p * channels.len() + c]
}

#[test]
fn exr_crate_reads_back_names_types_values_and_metadata() {
    let dir = common::scratch("exr_crate");
    let path = dir.join("aovs.exr");
    write_test_exr(&path, Compression::Zip);

    let image = read_all_flat_layers_from_file(&path).unwrap();
    assert_eq!(image.layer_data.len(), 1);
    let layer = &image.layer_data[0];
    assert_eq!((layer.size.0 as u32, layer.size.1 as u32), (WIDTH, HEIGHT));
    assert_eq!(
        layer.encoding.compression,
        exr::compression::Compression::ZIP16
    );
    let mut names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    names.sort();
    let mut wanted: Vec<String> = channels().into_iter().map(|c| c.name).collect();
    wanted.sort();
    assert_eq!(names, wanted);

    for ch in &layer.channel_data.list {
        let name = ch.name.to_string();
        let is_half = channels()
            .iter()
            .any(|c| c.name == name && c.pixel_type == PixelType::Half);
        match (&ch.sample_data, is_half) {
            (FlatSamples::F16(v), true) => {
                for (p, s) in v.iter().enumerate() {
                    assert_eq!(*s, f16::from_f32(expected(&name, p)), "{name} pixel {p}");
                }
            }
            (FlatSamples::F32(v), false) => {
                for (p, s) in v.iter().enumerate() {
                    assert_eq!(*s, expected(&name, p), "{name} pixel {p}");
                }
            }
            (other, _) => panic!("{name}: unexpected sample type {other:?}"),
        }
    }
    assert_eq!(
        layer
            .attributes
            .software_name
            .as_ref()
            .map(|t| t.to_string())
            .as_deref(),
        Some("cirrus test")
    );
    let m = layer.attributes.world_to_camera.expect("worldToCamera");
    assert_eq!(m, WORLD_TO_CAMERA);
    let custom = layer
        .attributes
        .other
        .get(&exr::meta::attribute::Text::from("cirrus/settings"));
    assert!(matches!(custom, Some(exr::meta::attribute::AttributeValue::Text(t)) if t == "spp=4"));
}

#[test]
fn python_openexr_reads_back_identical_channels_for_each_compression() {
    let dir = common::scratch("exr_python");
    let python = common::venv_python();
    for (compression, name) in [
        (Compression::Zip, "ZIP_COMPRESSION"),
        (Compression::Piz, "PIZ_COMPRESSION"),
        (Compression::Dwaa, "DWAA_COMPRESSION"),
        (Compression::None, "NO_COMPRESSION"),
    ] {
        let path = dir.join(format!("{name}.exr"));
        write_test_exr(&path, compression);
        let json = common::run_python(
            &python,
            &common::python_script("read_exr.py"),
            &[path.to_str().unwrap()],
        );
        let got: Value = serde_json::from_str(&json).unwrap();
        assert_eq!(got["compression"], name);
        assert_eq!(
            (got["width"].as_u64(), got["height"].as_u64()),
            (Some(WIDTH as u64), Some(HEIGHT as u64))
        );
        let read = got["channels"].as_object().unwrap();
        assert_eq!(
            read.len(),
            channels().len(),
            "{name}: {:?}",
            read.keys().collect::<Vec<_>>()
        );
        // DWAA is lossy for half channels; every other case must round-trip exactly.
        let lossless = compression != Compression::Dwaa;
        for ch in channels() {
            let entry = &read[&ch.name];
            let want_type = if ch.pixel_type == PixelType::Half {
                "half"
            } else {
                "float"
            };
            assert_eq!(entry["type"], want_type, "{name}: {}", ch.name);
            for (p, v) in entry["values"].as_array().unwrap().iter().enumerate() {
                let (v, want) = (v.as_f64().unwrap(), expected(&ch.name, p) as f64);
                let exact = lossless || ch.pixel_type == PixelType::Float;
                let tol = if exact {
                    0.0
                } else {
                    0.02 * want.abs().max(1.0)
                };
                assert!(
                    (v - want).abs() <= tol,
                    "{name}: {} pixel {p}: {v} vs {want}",
                    ch.name
                );
            }
        }
        let m: Vec<f64> = got["matrices"]["worldToCamera"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(
            m,
            WORLD_TO_CAMERA
                .iter()
                .map(|&v| v as f64)
                .collect::<Vec<_>>()
        );
        assert_eq!(got["strings"]["cirrus/settings"], "spp=4");
    }
}

#[test]
fn unwritable_path_is_a_clear_error_and_leaves_nothing_behind() {
    let dir = common::scratch("exr_unwritable");
    let missing_dir = dir.join("no/such/folder/beauty.exr");
    let values = [0.0f32; 4];
    let image = ExrImage {
        width: 1,
        height: 1,
        channels: ["R", "G", "B", "A"]
            .iter()
            .map(|n| Channel {
                name: n.to_string(),
                pixel_type: PixelType::Half,
            })
            .collect(),
        pixels: &values,
        compression: Compression::Zip,
        strings: vec![],
        matrices: vec![],
    };
    let e = write_exr(&missing_dir, &image).unwrap_err();
    assert!(matches!(e, ImageError::Write { .. }));
    assert!(e.to_string().contains("no/such/folder/beauty.exr"), "{e}");

    // A read-only folder (skipped when running as root, who may write anywhere).
    let ro = dir.join("readonly");
    std::fs::create_dir(&ro).unwrap();
    let mut perms = std::fs::metadata(&ro).unwrap().permissions();
    perms.set_readonly(true);
    std::fs::set_permissions(&ro, perms).unwrap();
    if std::fs::write(ro.join("probe"), b"x").is_err() {
        let e = write_exr(&ro.join("beauty.exr"), &image).unwrap_err();
        assert!(e.to_string().contains("readonly/beauty.exr"), "{e}");
    }
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "no stray temp files"
    );

    // A pixel buffer of the wrong size is refused before anything is written.
    let short = ExrImage {
        pixels: &values[..3],
        ..image.clone()
    };
    let target = dir.join("short.exr");
    assert!(write_exr(&target, &short).is_err());
    assert!(!target.exists());
}

#[test]
fn existing_file_is_replaced_whole() {
    let dir = common::scratch("exr_replace");
    let path = dir.join("beauty.exr");
    std::fs::write(&path, b"old contents").unwrap();
    write_test_exr(&path, Compression::Piz);
    assert!(read_all_flat_layers_from_file(&path).is_ok());
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["beauty.exr"]);
}

#[test]
fn textures_read_as_linear_floats() {
    needs_shared!();
    // An EXR is linear: read back exactly what was written (half channels rounded).
    let dir = common::scratch("texture_read");
    let exr_path = dir.join("linear.exr");
    write_test_exr(&exr_path, Compression::Zip);
    let img = read_image(&exr_path, ColorSpace::Auto).unwrap();
    assert_eq!(
        (img.width, img.height, img.channels as usize),
        (WIDTH, HEIGHT, channels().len())
    );

    // An 8-bit sRGB PNG from the shared assets decodes through the sRGB curve.
    let png = read_image(
        &common::asset("openusd/testUsdImagingGLPreviewSurface/grid.png"),
        ColorSpace::Auto,
    )
    .unwrap();
    assert!(png.width > 0 && png.height > 0);
    assert!(png.pixels.iter().all(|v| (0.0..=1.0).contains(v)));

    // A hand-made 2x1 uncompressed TGA (sRGB by convention for 8-bit files):
    // pixel values 128 and 255 decode to 0.2158605 and 1.0.
    let tga = dir.join("two.tga");
    let mut bytes = vec![0u8, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 1, 0, 24, 0x20];
    bytes.extend_from_slice(&[128, 128, 128, 255, 255, 255]); // BGR, top-left origin
    std::fs::write(&tga, &bytes).unwrap();
    let img = read_image(&tga, ColorSpace::Auto).unwrap();
    assert_eq!((img.width, img.height, img.channels), (2, 1, 3));
    assert!(
        (img.pixels[0] - 0.215_860_5).abs() < 1e-4,
        "{:?}",
        img.pixels
    );
    assert!((img.pixels[3] - 1.0).abs() < 1e-6, "{:?}", img.pixels);
    // `raw` (normal maps, roughness) keeps the stored values: 128 / 255.
    let raw = read_image(&tga, ColorSpace::Raw).unwrap();
    assert!(
        (raw.pixels[0] - 128.0 / 255.0).abs() < 1e-4,
        "{:?}",
        raw.pixels
    );

    // A JPEG texture from a production asset.
    let jpg = read_image(
        &common::asset("usd-wg/full_assets/Teapot/textures/tea_set_01_diff_2k.jpg"),
        ColorSpace::Auto,
    )
    .unwrap();
    assert_eq!((jpg.width, jpg.height), (2048, 2048));

    // Missing and corrupt files are errors naming the file.
    let e = read_image(&dir.join("missing.png"), ColorSpace::Auto).unwrap_err();
    assert!(e.to_string().contains("missing.png"), "{e}");
    let corrupt = dir.join("corrupt.png");
    std::fs::write(&corrupt, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let e = read_image(&corrupt, ColorSpace::Auto).unwrap_err();
    assert!(
        matches!(e, ImageError::Read { .. }) && e.to_string().contains("corrupt.png"),
        "{e}"
    );
}
