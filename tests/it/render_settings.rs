//! USD render settings drive a render (issue 25): the chosen
//! `RenderSettings`' raster products name the files (frame tokens
//! substituted), their resolution, camera and data window, and their
//! `RenderVar`s the EXR's layers, named as the vars; what we do not render
//! gets one warning naming it; a product's `dataWindowNDC` is the EXR's
//! data window and its `pixelAspectRatio` the pixels' shape, and `cirrus
//! merge` and `--resume` write the same files. Scene:
//! scenes/tests/render_settings.usda.

use crate::common;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn stage() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/render_settings.usda")
}

/// `cirrus render` of the stage in `dir` (relative product names land
/// there) at 2 spp with `args`.
fn render(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .current_dir(dir)
        .arg("render")
        .arg(stage())
        .args(["--spp", "2"])
        .args(args)
        .output()
        .unwrap()
}

/// `render`, which must succeed; its stderr.
fn render_ok(dir: &Path, args: &[&str]) -> String {
    let out = render(dir, args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "cirrus render {args:?}:\n{stderr}");
    stderr
}

/// Every channel of an EXR as raw bits, by name.
fn channels(path: &Path) -> BTreeMap<String, Vec<u32>> {
    common::channel_bits(path).into_iter().collect()
}

/// Channel values as f32, whatever their storage.
fn values(path: &Path, name: &str) -> Vec<f32> {
    use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let channel = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name);
    match &channel
        .unwrap_or_else(|| panic!("{name} missing"))
        .sample_data
    {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
    }
}

#[test]
fn one_product_with_four_vars_writes_those_layers_per_frame() {
    let dir = common::scratch("render_settings_product");
    render_ok(&dir, &["--frames", "7-8"]);
    for frame in ["0007", "0008"] {
        let exr = dir.join(format!("shot.{frame}.exr"));
        let names: Vec<String> = channels(&exr).into_keys().collect();
        let want = [
            "A",
            "B",
            "G",
            "R",
            "depth",
            "diffuse.B",
            "diffuse.G",
            "diffuse.R",
            "normal.X",
            "normal.Y",
            "normal.Z",
        ];
        assert_eq!(names, want, "{}", exr.display());
    }
    // The product's resolution (24x16, not the settings' 12x8) and camera
    // (cam_side, not the settings' cam_front): the same render asked for by flags.
    let flags = "-o flags.exr --camera /World/cam_side --res 24x16 --frame 7";
    let mut args: Vec<&str> = flags.split(' ').collect();
    args.extend(["--aovs", "diffuse_direct,diffuse_indirect,N,Z"]);
    render_ok(&dir, &args);
    let (ours, theirs) = (dir.join("shot.0007.exr"), dir.join("flags.exr"));
    let (a, b) = (channels(&ours), channels(&theirs));
    assert_eq!(a["R"].len(), 24 * 16);
    for (mine, flag) in [("R", "R"), ("A", "A"), ("normal.Y", "N.Y"), ("depth", "Z")] {
        assert_eq!(a[mine], b[flag], "{mine} differs from {flag}");
    }
    // diffuse = C<RD>.*L = diffuse_direct + diffuse_indirect (half storage: one rounding).
    let diffuse = values(&ours, "diffuse.G");
    let direct = values(&theirs, "diffuse_direct.G");
    let indirect = values(&theirs, "diffuse_indirect.G");
    for ((d, x), y) in diffuse.iter().zip(&direct).zip(&indirect) {
        assert!(
            (d - (x + y)).abs() <= 2e-3 * (x + y).abs() + 1e-6,
            "{d} vs {x} + {y}"
        );
    }
    assert!(
        diffuse.iter().any(|&d| d > 0.0),
        "a lit floor has diffuse light"
    );
}

#[test]
fn flags_win_over_the_product() {
    let dir = common::scratch("render_settings_flags");
    render_ok(&dir, &["-o", "mine.exr", "--res", "8x4"]);
    assert!(
        !dir.join("shot.0001.exr").exists(),
        "-o replaces productName"
    );
    let mine = channels(&dir.join("mine.exr"));
    assert_eq!(mine["R"].len(), 8 * 4, "--res wins");
    assert!(
        mine.contains_key("diffuse.R"),
        "the vars still name the layers"
    );
    render_ok(&dir, &["-o", "beauty.exr", "--aovs", "beauty"]);
    let names: Vec<String> = channels(&dir.join("beauty.exr")).into_keys().collect();
    assert_eq!(names, ["A", "B", "G", "R"], "--aovs replaces the vars");
}

#[test]
fn unknown_product_types_source_names_and_data_types_warn_once_each() {
    let dir = common::scratch("render_settings_odd");
    let stderr = render_ok(&dir, &["--settings", "/Render/odd"]);
    let warned = |needles: &[&str]| {
        let lines: Vec<&str> = stderr
            .lines()
            .filter(|l| needles.iter().all(|n| l.contains(n)))
            .collect();
        assert_eq!(lines.len(), 1, "one warning with {needles:?} in:\n{stderr}");
    };
    warned(&[
        "/Render/Products/deep",
        "productType",
        "deepRaster",
        "skipped",
    ]);
    warned(&[
        "/Render/Products/Vars/mystery",
        "sourceName",
        "C<XY>.*L",
        "skipped",
    ]);
    warned(&[
        "/Render/Products/Vars/counts",
        "dataType",
        "\"int\"",
        "skipped",
    ]);
    // A primvar no prim has (tests/primvar_aovs.rs renders ones they have).
    warned(&["/Render/Products/Vars/uv", "primvar st", "layer is 0"]);
    warned(&[
        "/Render/Products/odd",
        "aspectRatioConformPolicy",
        "cropAperture",
    ]);
    assert!(!dir.join("deep.exr").exists());
    let names: Vec<String> = channels(&dir.join("odd.exr")).into_keys().collect();
    assert_eq!(
        names,
        ["A", "B", "G", "R", "uv.G", "uv.R"],
        "only the beauty and primvar vars are produced"
    );
}

/// Settings without a raster product give only their resolution and camera:
/// their pixelAspectRatio, dataWindowNDC and conform policy are each warned
/// about once, and the whole image is rendered with square pixels.
#[test]
fn settings_without_products_warn_about_what_they_cannot_give() {
    let dir = common::scratch("render_settings_bare");
    let stderr = render_ok(&dir, &["--settings", "/Render/bare", "-o", "bare.exr"]);
    for needles in [
        ["pixelAspectRatio 2", "square pixels"],
        ["dataWindowNDC", "whole image"],
        ["aspectRatioConformPolicy", "adjustPixelAspectRatio"],
    ] {
        let said = stderr
            .lines()
            .filter(|l| l.contains("/Render/bare") && needles.iter().all(|n| l.contains(n)));
        assert_eq!(
            said.count(),
            1,
            "one warning with {needles:?} in:\n{stderr}"
        );
    }
    let image = frame(&dir.join("bare.exr"));
    assert_eq!((image.size, image.display), ((8, 4), (8, 4)));
    assert_eq!(image.pixel_aspect, 1.0);
}

#[test]
fn settings_naming_another_prim_is_refused_listing_the_settings() {
    let dir = common::scratch("render_settings_refused");
    let out = render(&dir, &["--settings", "/World/Ball"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let error: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(error.len(), 1, "{stderr}");
    for needle in ["/World/Ball", "/Render/shot", "/Render/odd", "/Render/pair"] {
        assert!(error[0].contains(needle), "{needle} not in {}", error[0]);
    }
}

/// Where an EXR's pixels sit, as the `exr` crate reads its header: the
/// data window's top-left pixel and size, the display window's size and
/// `pixelAspectRatio`.
#[derive(Debug, PartialEq)]
struct Frame {
    origin: (i32, i32),
    size: (usize, usize),
    display: (usize, usize),
    pixel_aspect: f32,
}

fn frame(path: &Path) -> Frame {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let (layer, attributes) = (&image.layer_data[0], &image.attributes);
    let display = &attributes.display_window;
    assert_eq!((display.position.x(), display.position.y()), (0, 0));
    let origin = layer.attributes.layer_position;
    Frame {
        origin: (origin.x(), origin.y()),
        size: (layer.size.x(), layer.size.y()),
        display: (display.size.x(), display.size.y()),
        pixel_aspect: attributes.pixel_aspect,
    }
}

/// `cirrus merge` with `args` in `dir`, which must succeed.
fn merge(dir: &Path, args: &[&str]) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    command.current_dir(dir).arg("merge").args(args);
    common::succeeds(command);
}

/// `cirrus render` in `dir` of the stage's `settings` at `spp`, then `more`.
fn settings_render(dir: &Path, settings: &str, spp: &str, more: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    let flags = ["--settings", settings, "--spp", spp];
    command.current_dir(dir).arg("render").arg(stage());
    command.args(flags).args(more);
    command
}

/// dataWindowNDC (0.25, 0.5, 0.75, 1) of 16x8 pixels, y up: columns 4..12
/// of rows 0..4 counted from the top.
const CROP: Frame = Frame {
    origin: (4, 0),
    size: (8, 4),
    display: (16, 8),
    pixel_aspect: 1.0,
};

#[test]
fn a_data_window_is_the_exrs_data_window_holding_the_full_renders_pixels() {
    let dir = common::scratch("render_settings_crop");
    render_ok(&dir, &["--settings", "/Render/crop"]);
    let args = "-o full.exr --camera /World/cam_front --res 16x8 --aovs Z";
    render_ok(&dir, &args.split(' ').collect::<Vec<_>>());
    let (crop, full) = (dir.join("crop.exr"), dir.join("full.exr"));
    assert_eq!(frame(&crop), CROP);
    let (c, f) = (channels(&crop), channels(&full));
    for (mine, flag) in [
        ("R", "R"),
        ("G", "G"),
        ("B", "B"),
        ("A", "A"),
        ("depth", "Z"),
    ] {
        assert_eq!(c[mine].len(), 8 * 4);
        for (i, bits) in c[mine].iter().enumerate() {
            let (x, y) = (4 + i % 8, i / 8);
            assert_eq!(*bits, f[flag][y * 16 + x], "{mine} at ({x}, {y})");
        }
    }
    assert!(c["A"].iter().any(|&a| a != 0), "the window shows something");
    assert!(c.contains_key("diffuse.G"), "the vars name the layers");
}

/// The crop product split into two farm parts and merged, and rendered,
/// interrupted and resumed: both write what the uninterrupted render
/// writes (the vars' layer names, the data window, every value's bits).
#[test]
fn merged_parts_and_resumed_renders_write_what_the_render_writes() {
    let dir = common::scratch("render_settings_merge");
    let crop = |more: &[&str]| settings_render(&dir, "/Render/crop", "4096", more);
    common::succeeds(crop(&[]));
    for tile in ["0/2", "1/2"] {
        let part = format!("part{}.film", &tile[..1]);
        common::succeeds(crop(&["--tile", tile, "-o", &part]));
    }
    merge(&dir, &["part0.film", "part1.film", "-o", "merged.exr"]);
    let checkpointed = ["-o", "resumed.exr", "--checkpoint-every", "0.01"];
    let checkpoint = dir.join("resumed.checkpoint");
    common::interrupted_after_checkpoint(crop(&checkpointed), &checkpoint, "INT");
    let partial = dir.join("resumed.partial.exr");
    assert_eq!(frame(&partial), CROP);
    let whole = channels(&dir.join("crop.exr"));
    let names = |c: &BTreeMap<String, Vec<u32>>| c.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&channels(&partial)), names(&whole));
    common::succeeds(crop(&[&checkpointed[..], &["--resume"]].concat()));
    for file in ["merged.exr", "resumed.exr"] {
        let path = dir.join(file);
        assert_eq!(frame(&path), CROP, "{file}");
        assert_eq!(channels(&path), whole, "{file}");
    }
}

/// The crop product's output folder replaced by a file mid-render: the
/// rescued film state's command writes what the render would have written.
#[test]
fn the_rescue_command_writes_what_the_render_writes() {
    let dir = common::scratch("render_settings_rescue");
    let crop = |more: &[&str]| settings_render(&dir, "/Render/crop", "4096", more);
    common::succeeds(crop(&[]));
    let shot = dir.join("shot");
    let child = crop(&["-o", "shot/crop.exr", "--checkpoint-every", "0.01"])
        .env("XDG_CACHE_HOME", dir.join("cache"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while !shot.join("crop.checkpoint").exists() {
        assert!(start.elapsed().as_secs() < 60, "no checkpoint");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    std::fs::rename(&shot, dir.join("shot.gone")).unwrap();
    std::fs::write(&shot, b"not a folder").unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let command = stderr
        .lines()
        .find_map(|l| l.trim().strip_prefix("cirrus merge "))
        .unwrap_or_else(|| panic!("no command in: {stderr}"));
    std::fs::remove_file(&shot).unwrap();
    merge(&dir, &command.split_whitespace().collect::<Vec<_>>());
    let rescued = shot.join("crop.exr");
    assert_eq!(frame(&rescued), CROP);
    assert_eq!(channels(&rescued), channels(&dir.join("crop.exr")));
}

/// pixelAspectRatio 2 at 16x16 is a 2:1 image whose pixels are twice as
/// wide as tall: its alpha equals a 32x16 square-pixel render's averaged
/// over pairs of columns (mean difference 0.004 as measured, against 0.047
/// for the 16x16 square pixels rendered before; at 64 spp an edge pixel's
/// alpha has a standard deviation of at most 0.5 / 8 = 0.06, and about 40
/// of the 256 pixels are edges, so noise alone keeps the mean near 0.01).
#[test]
fn a_pixel_aspect_ratio_of_two_renders_wide_pixels_and_says_so() {
    let dir = common::scratch("render_settings_anamorphic");
    common::succeeds(settings_render(&dir, "/Render/anamorphic", "64", &[]));
    let path = dir.join("anamorphic.exr");
    let square = Frame {
        origin: (0, 0),
        size: (16, 16),
        display: (16, 16),
        pixel_aspect: 1.0,
    };
    let wide = Frame {
        pixel_aspect: 2.0,
        ..square
    };
    assert_eq!(frame(&path), wide);
    let alpha = |file: &str, res: &str| {
        // /Render/shot's product has square pixels.
        let flags = ["-o", file, "--camera", "/World/cam_front", "--res", res];
        let flags = [&flags[..], &["--aovs", "beauty"]].concat();
        common::succeeds(settings_render(&dir, "/Render/shot", "64", &flags));
        values(&dir.join(file), "A")
    };
    let (double, round) = (alpha("double.exr", "32x16"), alpha("round.exr", "16x16"));
    assert_eq!(frame(&dir.join("round.exr")), square);
    let pairs: Vec<f32> = double.chunks(2).map(|p| (p[0] + p[1]) / 2.0).collect();
    let mean_difference = |image: &[f32]| {
        let total: f32 = image.iter().zip(&pairs).map(|(a, b)| (a - b).abs()).sum();
        total / pairs.len() as f32
    };
    let (wide, round) = (
        mean_difference(&values(&path, "A")),
        mean_difference(&round),
    );
    assert!(
        wide < 0.02 && round > 0.035,
        "{wide} vs square pixels {round}"
    );
}

#[test]
fn several_settings_and_none_named_use_none_with_a_warning() {
    let dir = common::scratch("render_settings_several");
    let text = std::fs::read_to_string(stage()).unwrap();
    let metadata = "    renderSettingsPrimPath = \"/Render/shot\"\n";
    assert!(text.contains(metadata));
    let unnamed = dir.join("unnamed.usda");
    std::fs::write(&unnamed, text.replace(metadata, "")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .current_dir(&dir)
        .arg("render")
        .arg(&unnamed)
        .args(["-o", "out.exr", "--res", "8x4", "--spp", "1"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("RenderSettings prims and none chosen"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    for settings in ["/Render/shot", "/Render/odd", "/Render/crop"] {
        assert!(warnings[0].contains(settings), "{}", warnings[0]);
    }
    assert!(!dir.join("shot.0001.exr").exists() && dir.join("out.exr").exists());
}

#[test]
fn products_sharing_the_render_are_written_from_one_film() {
    let dir = common::scratch("render_settings_pair");
    let stderr = render_ok(&dir, &["--settings", "/Render/pair"]);
    let layers = |file: &str| -> Vec<String> { channels(&dir.join(file)).into_keys().collect() };
    assert_eq!(
        layers("pair_a.exr"),
        ["diffuse.B", "diffuse.G", "diffuse.R"]
    );
    assert_eq!(layers("pair_b.exr"), ["A", "B", "G", "R", "depth"]);
    // pair_c differs in resolution: not rendered, one warning naming it.
    assert!(!dir.join("pair_c.exr").exists());
    let warned = stderr
        .lines()
        .filter(|l| l.contains("/Render/Products/pair_c"))
        .count();
    assert_eq!(warned, 1, "{stderr}");
    assert_eq!(
        stderr.matches("wrote ").count(),
        0,
        "'wrote' goes to stdout"
    );
}
