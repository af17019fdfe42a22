//! Bad input everywhere: each kind of bad input, end to end through
//! `cirrus`, with what the user sees: the exit
//! code (0 success, 1 an error, 2 bad usage; `src/cli/mod.rs`), one message
//! naming the problem, and nothing under the output's name after a failure.
//!
//! | Row of the issue                                   | Test                                                              |
//! |----------------------------------------------------|-------------------------------------------------------------------|
//! | truncated / corrupted intermediate scene           | `scene::every_corruption_is_refused_naming_the_field`             |
//! | VDB with NaN, Inf or negative densities            | `volumes::non_finite_and_negative_densities_are_read_as_zero_and_reported` |
//! | fire: NaN/Inf/negative temperatures, negative heatScale or emissionScale, a vec3 emission grid, a cold fire | `fire::bad_fire_input_is_reported_by_name` |
//! | VDB whose grid is not float (library level)        | `vdb::bad_inputs_give_clear_errors_naming_file_and_grid` (`VolumeError::NotFloat`) |
//! | VDB whose density grid is not float (CLI)          | [`density_grid_that_is_not_float_fails_naming_file_and_grid`]     |
//! | scene with zero lights                             | [`scene_without_lights_renders_under_the_default_dome_with_a_warning`] |
//! | meshes with NaN points                             | `export::bad_inputs_fail_with_one_clear_message` (exporter, exit 2), `export::a_bad_mesh_is_skipped_and_the_rest_exported`, `scene::` "NaN point" corruption (loader) |
//! | degenerate triangles                               | [`degenerate_triangles_render_without_a_nan`]                     |
//! | textures missing, corrupt or huge                  | [`unusable_textures_read_their_fallback_with_a_warning_each`] (and `materials::texture` unit tests) |
//! | absurd CLI values: 0 spp, 0 size, time, clamp       | `render::render_command_line_contract`                            |
//! | absurd CLI values: negative and huge resolutions   | [`absurd_command_line_values_fail_before_writing`]                |
//! | resource limits (`--memory-limit`)                 | [`memory_limit_refuses_early_with_the_estimate`] (`memory` unit tests for the estimate) |

use crate::common;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};

/// `scenes/tests/NAME.usda`.
fn test_scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/tests")
        .join(format!("{name}.usda"))
}

/// Small renders on one thread, unless the test's own arguments say otherwise.
const DEFAULTS: [(&str, &str); 3] = [("--res", "16x16"), ("--spp", "8"), ("--threads", "1")];

/// Runs `cirrus render SCENE -o DIR/out/out.exr` with `extra` arguments
/// and each of [`DEFAULTS`] that `extra` does not set (`--time` replaces
/// `--spp`); the output folder is created empty first.
fn render(scene: &Path, dir: &Path, extra: &[&str]) -> (Output, PathBuf) {
    let out_dir = dir.join("out");
    let _ = std::fs::remove_dir_all(&out_dir);
    std::fs::create_dir_all(&out_dir).unwrap();
    let exr = out_dir.join("out.exr");
    let set = |flag: &str| extra.iter().any(|a| a.split('=').next() == Some(flag));
    let defaults = DEFAULTS
        .iter()
        .filter(|(flag, _)| !(set(flag) || *flag == "--spp" && set("--time")))
        .flat_map(|(flag, value)| [*flag, *value]);
    let output = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args([OsStr::new("render"), scene.as_os_str(), "-o".as_ref()])
        .arg(&exr)
        .args(defaults)
        .args(extra)
        .output()
        .unwrap();
    (output, exr)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A render that must succeed: its stderr.
fn render_ok(scene: &Path, dir: &Path, extra: &[&str]) -> (String, PathBuf) {
    let (out, exr) = render(scene, dir, extra);
    assert!(
        out.status.success(),
        "{} failed:\n{}",
        scene.display(),
        stderr(&out)
    );
    (stderr(&out), exr)
}

/// Asserts a failed render: exit `code`, every needle in stderr, and
/// nothing at all in the output folder (no EXR, no preview, no temporary).
fn assert_refused(out: &Output, exr: &Path, code: i32, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "{err}");
    for needle in needles {
        assert!(err.contains(needle), "{needle:?} not in:\n{err}");
    }
    let left: Vec<_> = std::fs::read_dir(exr.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "a failed render left {left:?}");
}

/// Every channel of every layer of `exr`, by name.
fn channels(exr: &Path) -> Vec<(String, Vec<f32>)> {
    let image = read_all_flat_layers_from_file(exr).unwrap();
    image
        .layer_data
        .iter()
        .flat_map(|layer| {
            let prefix = layer
                .attributes
                .layer_name
                .as_ref()
                .map_or(String::new(), |n| format!("{n}."));
            layer.channel_data.list.iter().map(move |c| {
                let values = match &c.sample_data {
                    FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                    FlatSamples::F32(v) => v.clone(),
                    FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
                };
                (format!("{prefix}{}", c.name), values)
            })
        })
        .collect()
}

/// A density grid of another type than float (vec3s, bool) cannot be
/// rendered: `cirrus render` exits 1 with one error naming the file, the
/// grid and its type, before writing anything.
#[test]
fn density_grid_that_is_not_float_fails_naming_file_and_grid() {
    let dir = common::scratch("bad_input_vdb_type");
    for kind in ["vec3s", "bool"] {
        let vdb = dir.join(format!("density_{kind}.vdb"));
        common::run_python(
            Path::new(common::SYSTEM_PYTHON),
            &common::python_script("bad_vdb_grid.py"),
            &[&vdb.to_string_lossy(), kind],
        );
        let usda = dir.join(format!("fog_{kind}.usda"));
        std::fs::write(
            &usda,
            format!(
                "#usda 1.0\n(\n    defaultPrim = \"World\"\n)\ndef Xform \"World\"\n{{\n    \
                 def Volume \"Fog\"\n    {{\n        rel field:density = </World/Fog/density>\n        \
                 def OpenVDBAsset \"density\"\n        {{\n            asset filePath = @{}@\n            \
                 token fieldName = \"density\"\n        }}\n    }}\n}}\n",
                vdb.display()
            ),
        )
        .unwrap();
        let (out, exr) = render(&usda, &dir, &[]);
        assert_refused(
            &out,
            &exr,
            1,
            &[
                &format!("density_{kind}.vdb"),
                &format!("grid 'density' holds '{kind}' values"),
            ],
        );
        let errors = stderr(&out)
            .lines()
            .filter(|l| l.starts_with("error:"))
            .count();
        assert_eq!(errors, 1, "{}", stderr(&out));
    }
}

/// A stage without lights renders under the documented default, a white
/// dome of radiance 1, with a warning saying so: a Lambert plane of albedo
/// 0.5 filling the view is 0.5 in every pixel (within 4 sigma).
#[test]
fn scene_without_lights_renders_under_the_default_dome_with_a_warning() {
    let dir = common::scratch("bad_input_no_lights");
    let (err, exr) = render_ok(&test_scene("bad_no_lights"), &dir, &["--aovs", "beauty"]);
    assert!(
        err.contains("the scene has no lights: lighting it with a white dome of radiance 1"),
        "no warning in:\n{err}"
    );
    for (name, values) in channels(&exr) {
        if name == "A" {
            continue;
        }
        let e = common::estimate(values.iter().map(|&v| f64::from(v)));
        let tolerance = 4.0 * e.sigma + 1e-5;
        assert!(
            (e.mean - 0.5).abs() < tolerance,
            "{name}: {} +- {} instead of 0.5",
            e.mean,
            e.sigma
        );
    }
}

/// Zero-area triangles (a repeated index, collinear points, one point three
/// times, a one-point quad), a zero authored normal on a good triangle's
/// corner and an emitter made only of zero-area triangles render without a
/// single NaN or infinite sample, in the beauty and every AOV.
#[test]
fn degenerate_triangles_render_without_a_nan() {
    let dir = common::scratch("bad_input_degenerate");
    let (err, exr) = render_ok(
        &test_scene("bad_degenerate_triangles"),
        &dir,
        &["--aovs", "all"],
    );
    assert!(!err.contains("NaN/Inf sample"), "{err}");
    let all = channels(&exr);
    assert!(all.len() > 4, "AOVs missing: {}", all.len());
    for (name, values) in all {
        assert!(
            values.iter().all(|v| v.is_finite()),
            "{name} holds a non-finite value"
        );
    }
}

/// A CRC-32 (ISO-HDLC, PNG's) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

/// A PNG whose header declares `width` x `height` RGB pixels, followed by a
/// few bytes of image data: small on disk, huge once decoded.
fn png_declaring(width: u32, height: u32) -> Vec<u8> {
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        let body = [kind, data].concat();
        c.extend(&body);
        c.extend(crc32(&body).to_be_bytes());
        c
    };
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]); // 8-bit RGB, deflate, adaptive filter, no interlace
                                  // A stored (uncompressed) zlib stream of 8 zero bytes.
    let idat = [
        0x78, 0x01, 0x01, 0x08, 0x00, 0xf7, 0xff, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    ];
    [
        b"\x89PNG\r\n\x1a\n".to_vec(),
        chunk(b"IHDR", &ihdr),
        chunk(b"IDAT", &idat),
        chunk(b"IEND", &[]),
    ]
    .concat()
}

/// Textures that cannot be used (a PNG declaring 10^6 x 10^6 pixels,
/// garbage bytes named .png, a missing file) never fail the render: each
/// is named in one warning and reads its `inputs:fallback`, so the image is
/// exactly that of the same stage with the fallbacks as constants.
#[test]
fn unusable_textures_read_their_fallback_with_a_warning_each() {
    let dir = common::scratch("bad_input_textures");
    let stage = std::fs::read_to_string(test_scene("bad_textures")).unwrap();
    std::fs::write(
        dir.join("bad_huge.png"),
        png_declaring(1_000_000, 1_000_000),
    )
    .unwrap();
    std::fs::write(
        dir.join("bad_corrupt.png"),
        b"not a PNG at all, just bytes".repeat(9),
    )
    .unwrap();
    let textured = dir.join("bad_textures.usda");
    std::fs::write(&textured, &stage).unwrap();
    let constants = dir.join("constants.usda");
    let mut constant_stage = stage.clone();
    for (connection, constant) in [
        (
            "color3f inputs:diffuseColor.connect = </World/Looks/Tex/Diffuse.outputs:rgb>",
            "color3f inputs:diffuseColor = (0.5, 0.5, 0.5)",
        ),
        (
            "float inputs:roughness.connect = </World/Looks/Tex/Rough.outputs:r>",
            "float inputs:roughness = 0.5",
        ),
        (
            "float inputs:metallic.connect = </World/Looks/Tex/Metal.outputs:r>",
            "float inputs:metallic = 0",
        ),
    ] {
        assert!(constant_stage.contains(connection), "{connection}");
        constant_stage = constant_stage.replace(connection, constant);
    }
    std::fs::write(&constants, constant_stage).unwrap();

    let args = ["--aovs", "beauty", "--seed", "3"];
    let (err, exr) = render_ok(&textured, &dir, &args);
    // A missing image is reported once, by the exporter (issue 25); files
    // that exist but cannot be read, by the texture loader.
    for (file, why) in [
        ("bad_huge.png", "MiB to read; only"),
        ("bad_corrupt.png", "cannot read image"),
        ("bad_missing.png", "is missing; its fallback"),
    ] {
        let path = dir.join(file).display().to_string();
        let warnings: Vec<_> = err.lines().filter(|l| l.contains(&path)).collect();
        assert_eq!(warnings.len(), 1, "{file}:\n{err}");
        assert!(
            warnings[0].contains(why) && warnings[0].contains("fallback"),
            "{}",
            warnings[0]
        );
    }
    let textured_image = channels(&exr);
    let reference_dir = dir.join("reference");
    std::fs::create_dir_all(&reference_dir).unwrap();
    let (_, reference) = render_ok(&constants, &reference_dir, &args);
    assert_eq!(
        textured_image,
        channels(&reference),
        "fallbacks differ from constants"
    );
}

/// Resolutions outside 1..=65536 per side, negative ones included, are bad
/// usage: exit 2, the value named, nothing written.
#[test]
fn absurd_command_line_values_fail_before_writing() {
    let dir = common::scratch("bad_input_cli");
    let scene = test_scene("bad_no_lights");
    for (bad, needles) in [
        (
            "--res=-5x10",
            &["'-5x10'", "\"-5\" is not a size in 1..=65536"][..],
        ),
        ("--res=100000x100000", &["\"100000\" is not a size"][..]),
        ("--res=0x0", &["\"0\" is not a size"][..]),
        ("--res=16", &["expected WIDTHxHEIGHT"][..]),
        ("--spp=-1", &["'-1'", "--spp"][..]),
        ("--max-depth=-1", &["'-1'", "--max-depth"][..]),
        ("--threads=-2", &["'-2'", "--threads"][..]),
    ] {
        let (out, exr) = render(&scene, &dir, &[bad]);
        assert_refused(&out, &exr, 2, needles);
    }
}

/// Values that cannot mean what they say are bad usage: `--threads 0`
/// (rayon would read it as "all cores") and a `--time` beyond what a
/// `Duration` holds (once a panic, exit 101).
#[test]
fn threads_zero_and_endless_time_are_bad_usage() {
    let dir = common::scratch("bad_input_cli_accepted");
    let scene = test_scene("bad_no_lights");
    for (args, needle) in [
        (&["--threads", "0"][..], "--threads"),
        (&["--time", "1e300"][..], "--time"),
    ] {
        let (out, exr) = render(&scene, &dir, args);
        assert!(
            matches!(out.status.code(), Some(1 | 2)),
            "{args:?}: {}",
            stderr(&out)
        );
        assert_refused(&out, &exr, out.status.code().unwrap(), &[needle]);
    }
}

/// `--memory-limit`: a render whose estimate exceeds the limit (or, without
/// one, the memory available) is refused before anything large is built,
/// with the estimate by part; a sufficient limit renders.
#[test]
fn memory_limit_refuses_early_with_the_estimate() {
    let dir = common::scratch("bad_input_memory");
    let scene = test_scene("bad_no_lights");
    // 2^32 pixels of film: hundreds of GiB, refused from the estimate alone.
    let (out, exr) = render(&scene, &dir, &["--res", "65536x65536"]);
    assert_refused(&out, &exr, 1, &["needs about", "film", "lower --res"]);
    let (out, exr) = render(&scene, &dir, &["--memory-limit", "1M"]);
    assert_refused(
        &out,
        &exr,
        1,
        &[
            "needs about",
            "but only 1.0 MiB is available (--memory-limit)",
        ],
    );
    let (out, exr) = render(&scene, &dir, &["--memory-limit", "lots"]);
    assert_refused(&out, &exr, 2, &["'lots'", "--memory-limit"]);
    let (err, exr) = render_ok(&scene, &dir, &["--memory-limit", "4G"]);
    assert!(exr.is_file(), "{err}");
}
