//! Production looks on the exporter side (issue 21): MaterialX documents referenced as
//! layers, MaterialX and UsdPreviewSurface graphs resolved into scene inputs, Standard
//! Surface mapped to OpenPBR, primvar-driven inputs. Checked at the manifest
//! (scene.json), input by input; the MaterialX package reads the documents independently
//! in tests/python/check_mtlx.py.

use crate::common;
use serde_json::Value;
use std::path::Path;

/// scene.json of an exported scene folder.
fn manifest(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("scene.json")).unwrap()).unwrap()
}

/// `scenes/tests/materialx/looks.usda` exported once per test process (by the exporter
/// alone: this branch's loader does not read open_pbr records yet).
fn looks() -> (std::path::PathBuf, Value) {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let stage = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/materialx/looks.usda");
        let out = common::scratch("materialx_looks").join("looks");
        cirrus::scene::export(&stage, &out, &Default::default()).unwrap();
        out
    });
    (dir.clone(), manifest(dir))
}

/// The warnings of a manifest that contain every one of `words`.
fn warnings_with<'a>(scene: &'a Value, words: &[&str]) -> Vec<&'a str> {
    scene["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .filter(|w| words.iter().all(|word| w.contains(word)))
        .collect()
}

/// The material record at `path`.
fn material<'a>(scene: &'a Value, path: &str) -> &'a Value {
    scene["materials"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["path"] == path)
        .unwrap_or_else(|| panic!("no material {path}"))
}

/// Every material of the OpenChessSet is read from its MaterialX document (29 warnings,
/// 21 grey fallbacks before; now none), and every image input matches what the MaterialX
/// package reads from the documents.
#[test]
fn chess_set_exports_every_look() {
    needs_shared!();
    let stage = common::asset("usd-wg/full_assets/OpenChessSet/chess_set.usda");
    let out = common::scratch("materialx_chess").join("chess");
    cirrus::scene::export(&stage, &out, &Default::default()).unwrap();
    let scene = manifest(&out);
    let materials = scene["materials"].as_array().unwrap();
    assert_eq!(materials.len(), 21);
    for m in materials {
        assert_eq!(m["fallback"], false, "{}", m["path"]);
        assert_eq!(m["model"], "open_pbr", "{}", m["path"]);
        assert_eq!(m["shader"], "mtlx:standard_surface", "{}", m["path"]);
        assert!(m["geometry_normal"]["texture"].is_u64(), "{}", m["path"]);
    }
    assert!(warnings_with(&scene, &["grey fallback"]).is_empty());
    let warnings = scene["warnings"].as_array().unwrap().len();
    assert!(warnings <= 5, "{:#?}", scene["warnings"]);
    let documents = stage.parent().unwrap().join("assets");
    let mut args = vec!["inputs".to_owned(), out.display().to_string()];
    for piece in [
        "Bishop",
        "Chessboard",
        "King",
        "Knight",
        "Pawn",
        "Queen",
        "Rook",
    ] {
        let file = documents.join(piece).join(format!("{piece}_mat.mtlx"));
        args.push(file.display().to_string());
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let script = common::python_script("check_mtlx.py");
    let report = common::run_python(&common::venv_python(), &script, &args);
    assert!(report.contains("62 inputs match"), "{report}");
}

/// A document of constant looks converts, input by input, to what the MaterialX package reads.
#[test]
fn constant_document_matches_the_materialx_package() {
    needs_shared!();
    let (dir, scene) = looks();
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/materialx/looks.mtlx");
    let script = common::python_script("check_mtlx.py");
    let args = ["inputs", dir.to_str().unwrap(), doc.to_str().unwrap()];
    let report = common::run_python(&common::venv_python(), &script, &args);
    assert!(report.contains("5 inputs match"), "{report}");
    let folded = &material(&scene, "/Looks/folded")["open_pbr"];
    assert_eq!(folded["base_color"], serde_json::json!([0.25, 0.125, 0.5]));
    assert_eq!(folded["specular_roughness"], 0.25);
}

/// Standard Surface -> OpenPBR on a table of parameter sets (check_mtlx.py's TABLE).
#[test]
fn standard_surface_maps_to_open_pbr() {
    let script = common::python_script("check_mtlx.py");
    let report = common::run_python(&common::venv_python(), &script, &["table"]);
    assert!(report.contains("38 inputs match"), "{report}");
}

/// A missing, non-XML or unsupported-version document: one warning naming each file, the
/// materials bound from them fall back, the rest exports.
#[test]
fn unusable_documents_are_named_and_fall_back() {
    needs_shared!();
    let (_, scene) = looks();
    for (file, problem) in [
        ("missing.mtlx", "missing MaterialX document"),
        ("not_xml.mtlx", "unreadable MaterialX document"),
        ("old_version.mtlx", "unsupported version 1.20"),
    ] {
        assert_eq!(warnings_with(&scene, &[problem, file]).len(), 1, "{file}");
    }
    for path in ["/Looks/from_missing", "/Looks/from_not_xml"] {
        assert_eq!(material(&scene, path)["fallback"], true);
    }
    assert_eq!(material(&scene, "/Looks/gold")["fallback"], false);
}

/// A cycle and an unknown node: one warning each naming node and input; defaults used.
#[test]
fn cycles_and_unknown_nodes_use_the_default() {
    needs_shared!();
    let (_, scene) = looks();
    let graphs = &material(&scene, "/Looks/Graphs")["open_pbr"];
    let cycle = ["base_color", "/Looks/Graphs/loop_a", "cycle"];
    assert_eq!(warnings_with(&scene, &cycle).len(), 1);
    let base: Vec<f64> = serde_json::from_value(graphs["base_color"].clone()).unwrap();
    assert!(base.iter().all(|c| (c - 0.8).abs() < 1e-6), "{base:?}");
    let unknown = ["specular_roughness", "/Looks/Graphs/noise", "noise3d"];
    assert_eq!(warnings_with(&scene, &unknown).len(), 1);
    assert!((graphs["specular_roughness"].as_f64().unwrap() - 0.3).abs() < 1e-6);
}

/// An image whose file is missing gives its `default`, with one warning.
#[test]
fn missing_image_gives_its_default() {
    needs_shared!();
    let (_, scene) = looks();
    let warned = ["no_such_texture.png", "/Looks/Graphs/lost_image"];
    assert_eq!(warnings_with(&scene, &warned).len(), 1);
    let coat = &material(&scene, "/Looks/Graphs")["open_pbr"]["coat_color"];
    assert_eq!(coat, &serde_json::json!([0.25, 0.5, 0.75]));
}

/// Primvar readers become primvar inputs; the mesh carries the primvar once per point; a
/// mesh without it is warned about once (the reader's fallback is used).
#[test]
fn primvar_readers_drive_inputs() {
    needs_shared!();
    let (_, scene) = looks();
    let tinted = &material(&scene, "/Looks/Tinted")["diffuse_color"];
    assert_eq!(tinted["primvar"], "tint");
    assert_eq!(tinted["channel"], "rgb");
    let metal = &material(&scene, "/Looks/Graphs")["open_pbr"]["base_metalness"];
    assert_eq!(metal["primvar"], "metal_mask");
    let meshes = scene["meshes"].as_array().unwrap();
    let mesh = |path: &str| meshes.iter().find(|m| m["path"] == path).unwrap();
    assert_eq!(mesh("/World/Tinted")["primvars"]["tint"]["width"], 3);
    assert_eq!(mesh("/World/Tinted")["primvars"]["tint"]["count"], 4);
    assert_eq!(mesh("/World/Graphs")["primvars"]["metal_mask"]["width"], 1);
    let missing = ["/World/Untinted", "no primvar tint"];
    assert_eq!(warnings_with(&scene, &missing).len(), 1);
}

/// displayColor / displayOpacity on a mesh with no material make a preview_surface record.
#[test]
fn display_color_without_a_material() {
    needs_shared!();
    let (_, scene) = looks();
    let shown = material(&scene, "/World/Shown.displayColor");
    assert_eq!(shown["shader"], "displayColor");
    assert_eq!(shown["diffuse_color"]["primvar"], "displayColor");
    assert_eq!(shown["opacity"], 0.5);
}

/// A `tiledimage`'s uvtiling and uvoffset become the texture's st transform (uv = st
/// tiling - offset, realworld sizes 1); an image read through `texcoord` index 1 (a UV set
/// we do not carry) gives the surface input's default with one warning naming the node.
#[test]
fn tiled_images_transform_and_other_uv_sets_are_named() {
    needs_shared!();
    let (_, scene) = looks();
    let base = &material(&scene, "/Looks/Tiled")["open_pbr"]["base_color"];
    let texture = &scene["textures"][base["texture"].as_u64().unwrap() as usize];
    assert_eq!(
        texture["st_transform"],
        serde_json::json!({"translation": [-0.25, -0.5], "rotation_deg": 0.0, "scale": [2.0, 3.0]})
    );
    let warned = [
        "/Looks/Tiled/uv1",
        "texcoord",
        "specular_roughness",
        "default",
    ];
    assert_eq!(warnings_with(&scene, &warned).len(), 1);
    let roughness = &material(&scene, "/Looks/Tiled")["open_pbr"]["specular_roughness"];
    assert!(
        (roughness.as_f64().unwrap() - 0.3).abs() < 1e-6,
        "{roughness}"
    );
}
