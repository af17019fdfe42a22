//! Cryptomatte names a compositor can use, end to end through the binary on
//! `scenes/tests/cryptomatte_instances.usda` (exported by the real usd-core
//! exporter): three instanceable references of one Teapot asset, four
//! PointInstancer copies of a Rock, a Floor, a Hidden sphere nobody sees and
//! an Extra sphere outside every model. Each object is named by the
//! instance's own prim path (never USD's `/__Prototype_N`, nor is a material
//! inside the asset), the ids are the
//! same from one export to the next, CryptoAsset groups the meshes of one
//! component, the manifests list only the ids the image holds, and a frame
//! merged from parts or resumed after a stop carries the same manifests as
//! one rendered whole. Cryptomatte is decoded with the specification's
//! reference algorithm (`tests/common/aovs.rs`).

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common::aovs::{decode_cryptomatte, Exr, Matte};

const SCENE: &str = "scenes/tests/cryptomatte_instances.usda";
const AOVS: &str = "CryptoObject,CryptoMaterial,CryptoAsset";

/// Exports the test scene into `dir`.
fn export(dir: &Path) -> PathBuf {
    let usda = Path::new(env!("CARGO_MANIFEST_DIR")).join(SCENE);
    let out = dir.join("scene");
    common::cirrus_ok(&[
        "export".as_ref(),
        usda.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    out
}

/// `cirrus render SCENE -o OUT` of the three Cryptomattes at 80x40 (one
/// pixel = 0.25 scene units), box filter, seed 7, then `extra`.
fn render_command(scene: &Path, out: &Path, spp: u32, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    c.arg("render").arg(scene).arg("-o").arg(out);
    c.args([
        "--res", "80x40", "--aovs", AOVS, "--filter", "box", "--seed", "7",
    ])
    .args(["--spp", &spp.to_string()])
    .args(extra)
    .stdout(Stdio::piped())
    .stderr(Stdio::piped());
    c
}

/// The `cryptomatte/*` attributes of an EXR.
fn crypto_attributes(exr: &Exr) -> Vec<(String, String)> {
    let attributes = exr
        .strings
        .iter()
        .filter(|(k, _)| k.starts_with("cryptomatte/"));
    attributes.map(|(k, v)| (k.clone(), v.clone())).collect()
}

/// The bits of every Cryptomatte channel of an EXR.
fn crypto_channels(exr: &Exr) -> Vec<(String, Vec<u32>)> {
    let crypto = exr
        .channels
        .iter()
        .filter(|(name, _)| name.starts_with("Crypto"));
    crypto
        .map(|(name, (_, v))| (name.clone(), v.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

/// Names and where each covers: every manifest name covers some pixel (the
/// manifest lists only ids the image holds).
fn names_of(matte: &Matte, layer: &str) -> Vec<String> {
    for (name, coverage) in &matte.coverage {
        assert!(
            coverage.iter().any(|&c| c > 0.0),
            "{layer}: {name} is in the manifest but covers no pixel"
        );
    }
    matte.manifest.keys().cloned().collect()
}

/// Pixel index of the scene point (x, y) (the camera shows x in [-10, 10],
/// y in [-5, 5] over 80x40 pixels, row 0 at the top).
fn pixel(x: f64, y: f64) -> usize {
    let column = ((x + 10.0) * 4.0) as usize;
    let row = ((5.0 - y) * 4.0) as usize;
    row * 80 + column
}

#[test]
fn instances_are_named_by_their_own_prim_paths_stably_across_exports() {
    let dir = common::scratch("cryptomatte_names");
    let mut renders = Vec::new();
    for export_dir in ["first", "second"] {
        let scene = export(&dir.join(export_dir));
        let exr = dir.join(format!("{export_dir}.exr"));
        common::succeeds(render_command(&scene, &exr, 4, &["--threads", "1"]));
        renders.push(Exr::read(&exr));
    }
    let exr = &renders[0];
    let objects = decode_cryptomatte(exr, "CryptoObject");
    let mut expected = vec!["/Extra".to_string(), "/World/Floor".to_string()];
    expected.extend((10..14).map(|i| format!("/World/scatter[{i}]/Geom")));
    for teapot in 1..=3 {
        expected.extend(["Body", "Lid"].map(|p| format!("/World/teapot_{teapot}/{p}")));
    }
    expected.sort();
    assert_eq!(names_of(&objects, "CryptoObject"), expected);

    // Each teapot's body is where that instance stands, wholly.
    for (teapot, x) in [(1, -6.0), (2, -2.0), (3, 2.0)] {
        let body = &objects.coverage[&format!("/World/teapot_{teapot}/Body")];
        assert_eq!(body[pixel(x - 0.3, 1.7)], 1.0, "teapot_{teapot}");
    }
    let rock = &objects.coverage["/World/scatter[12]/Geom"];
    assert_eq!(rock[pixel(1.0 - 0.3, -2.7)], 1.0, "the third rock (id 12)");

    // Two exports (USD numbers its prototypes anew each time): the same
    // names, ids and pixels.
    assert_eq!(
        crypto_attributes(&renders[0]),
        crypto_attributes(&renders[1])
    );
    assert_eq!(crypto_channels(&renders[0]), crypto_channels(&renders[1]));

    // CryptoAsset: a teapot's two meshes form its component; each rock is
    // its own component; the Floor belongs to the /World assembly; the
    // Extra sphere, in no model, is its own asset.
    let assets = decode_cryptomatte(exr, "CryptoAsset");
    let mut expected = vec!["/Extra".to_string(), "/World".to_string()];
    expected.extend((10..14).map(|i| format!("/World/scatter[{i}]")));
    expected.extend((1..=3).map(|i| format!("/World/teapot_{i}")));
    expected.sort();
    assert_eq!(names_of(&assets, "CryptoAsset"), expected);
    let n = exr.width * exr.height;
    let sum = |names: &[String]| -> Vec<f64> {
        (0..n)
            .map(|p| names.iter().map(|o| objects.coverage[o][p]).sum())
            .collect()
    };
    let groups: Vec<(String, Vec<String>)> = (1..=3)
        .map(|i| {
            let parts = ["Body", "Lid"].map(|p| format!("/World/teapot_{i}/{p}"));
            (format!("/World/teapot_{i}"), parts.to_vec())
        })
        .chain((10..14).map(|i| {
            let rock = format!("/World/scatter[{i}]");
            (rock.clone(), vec![format!("{rock}/Geom")])
        }))
        .chain([
            ("/World".into(), vec!["/World/Floor".into()]),
            ("/Extra".into(), vec!["/Extra".into()]),
        ])
        .collect();
    for (asset, members) in &groups {
        let expected = sum(members);
        for (p, (&got, want)) in assets.coverage[asset].iter().zip(expected).enumerate() {
            assert!(
                (got - want).abs() < 1e-6,
                "{asset} pixel {p}: {got} vs {want}"
            );
        }
    }
    // CryptoMaterial: the asset's material by its path through the first
    // instance (all three teapots share it), never `/__Prototype_N`.
    let materials = decode_cryptomatte(exr, "CryptoMaterial");
    assert_eq!(
        names_of(&materials, "CryptoMaterial"),
        ["/World/Looks/Ground", "/World/teapot_1/Looks/Glaze"]
    );
    assert!(!exr.strings.values().any(|v| v.contains("__Prototype")));
}

#[test]
fn merged_and_resumed_frames_carry_the_whole_renders_manifests() {
    let dir = common::scratch("cryptomatte_parts");
    let scene = export(&dir);
    let whole = dir.join("whole.exr");
    common::succeeds(render_command(&scene, &whole, 256, &["--threads", "2"]));
    let whole = Exr::read(&whole);

    // Two tiles, each seeing some of the objects, merged.
    let parts: Vec<PathBuf> = (0..2)
        .map(|i| {
            let part = dir.join(format!("part{i}.film"));
            let tile = format!("{i}/2");
            common::succeeds(render_command(&scene, &part, 256, &["--tile", &tile]));
            part
        })
        .collect();
    let merged = dir.join("merged.exr");
    let mut args: Vec<&std::ffi::OsStr> = vec!["merge".as_ref()];
    args.extend(parts.iter().map(|p| p.as_os_str()));
    args.extend(["-o".as_ref(), merged.as_os_str()]);
    common::cirrus_ok(&args);
    let merged = Exr::read(&merged);
    assert_eq!(crypto_attributes(&merged), crypto_attributes(&whole));
    assert_eq!(crypto_channels(&merged), crypto_channels(&whole));

    // Stopped after a checkpoint, then resumed.
    let resumed = dir.join("resumed.exr");
    let checkpoint = dir.join("resumed.checkpoint");
    let flags = ["--threads", "1", "--checkpoint-every", "0.1"];
    let render = render_command(&scene, &resumed, 256, &flags);
    common::interrupted_after_checkpoint(render, &checkpoint, "INT");
    common::succeeds(render_command(
        &scene,
        &resumed,
        256,
        &["--threads", "2", "--resume"],
    ));
    let resumed = Exr::read(&resumed);
    assert_eq!(crypto_attributes(&resumed), crypto_attributes(&whole));
    assert_eq!(crypto_channels(&resumed), crypto_channels(&whole));
}

#[test]
fn copies_of_nested_point_instancers_are_named_by_both_indices() {
    let dir = common::scratch("cryptomatte_nested");
    let usda = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/cryptomatte_nested.usda");
    let exr = dir.join("nested.exr");
    let mut render = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    render.arg("render").arg(&usda).arg("-o").arg(&exr);
    render.args([
        "--res",
        "48x24",
        "--aovs",
        "CryptoObject",
        "--filter",
        "box",
        "--spp",
        "2",
    ]);
    common::succeeds(render);
    let objects = decode_cryptomatte(&Exr::read(&exr), "CryptoObject");
    // (outer id, x) by (inner id, y): one pixel is 0.25 scene units.
    let copies = [(3, -3.0), (8, 3.0)]
        .into_iter()
        .flat_map(|outer| [(5, -2.0), (6, 0.0), (7, 2.0)].map(|inner| (outer, inner)));
    let mut expected = Vec::new();
    for ((outer, x), (inner, y)) in copies {
        let name = format!("/World/outer[{outer}]/inner[{inner}]/Geom");
        let (column, row) = (((x + 6.0) * 4.0) as usize, ((3.0 - y) * 4.0) as usize);
        assert_eq!(objects.coverage[&name][row * 48 + column], 1.0, "{name}");
        expected.push(name);
    }
    expected.sort();
    assert_eq!(names_of(&objects, "CryptoObject"), expected);
}
