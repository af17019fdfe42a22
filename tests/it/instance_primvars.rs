//! Primvars carried per instance (docs/materials.md, "Primvars"): a
//! PointInstancer's per-instance and constant primvars, and constant ones on
//! native instance roots and their ancestors, drive the material inputs of
//! the meshes below that lack them; a mesh's own primvar wins.

use crate::common;
use std::path::Path;

use crate::common::render::{exported, Image, Render, PIXEL_ROUNDING};
use crate::common::{assert_within_4_sigma, estimate};
use serde_json::Value;

/// `scenes/tests/instance_primvars.usda`'s cells, rows top to bottom: each
/// quad's radiance (pure Lambert under a white dome of radiance 1), its tint.
const CELLS: [[[f64; 3]; 3]; 3] = [
    // PointInstancer, one value per instance.
    [[0.8, 0.2, 0.1], [0.1, 0.7, 0.2], [0.2, 0.3, 0.9]],
    // PointInstancer constant; the middle prototype's mesh carries its own.
    [[0.5, 0.1, 0.6], [0.9, 0.9, 0.1], [0.5, 0.1, 0.6]],
    // Native instances: inherited from Group, their root's own, the fallback.
    [[0.3, 0.6, 0.6], [0.7, 0.4, 0.2], [0.05, 0.05, 0.05]],
];

/// The scene's manifest.
fn manifest(scene: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(scene.join("scene.json")).unwrap()).unwrap()
}

/// The manifest's warnings that contain `text`.
fn warnings_with(manifest: &Value, text: &str) -> Vec<String> {
    manifest["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .filter(|w| w.contains(text))
        .map(str::to_owned)
        .collect()
}

#[test]
fn each_instance_renders_in_the_value_its_instancer_or_ancestor_gives_it() {
    let dir = common::scratch("instance_primvars_cells");
    let res = (30, 30);
    let image: Image = Render {
        scene: "instance_primvars",
        res,
        spp: 16,
        seed: 11,
        extra: &[],
    }
    .run(&dir);
    for (row, cells) in CELLS.iter().enumerate() {
        for (col, tint) in cells.iter().enumerate() {
            // The 6 x 6 pixels inside the cell's 10 x 10, clear of its edges.
            let inside = |x: usize, y: usize| {
                (col * 10 + 2..col * 10 + 8).contains(&x)
                    && (row * 10 + 2..row * 10 + 8).contains(&y)
            };
            for (c, &want) in tint.iter().enumerate() {
                let measured = estimate(image.pixels(c, inside));
                let what = format!("cell row {row} column {col} channel {c}");
                assert_within_4_sigma(&what, measured, want, PIXEL_ROUNDING);
            }
        }
    }
    // Only the copy with no tint anywhere is warned about, naming it.
    let warned = warnings_with(&manifest(&exported("instance_primvars")), "no primvar tint");
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(warned[0].ends_with("in copies /World/C"), "{warned:?}");
}

#[test]
fn instancer_primvars_of_the_wrong_length_are_warned_about_and_ignored() {
    let dir = common::scratch("instance_primvars_wrong_length");
    let stage = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/instance_primvars.usda"),
    )
    .unwrap()
    .replace(
        "[(0.8, 0.2, 0.1), (0.1, 0.7, 0.2), (0.2, 0.3, 0.9)]",
        "[(0.8, 0.2, 0.1), (0.1, 0.7, 0.2)]",
    );
    let scene = common::export_usda(&dir, &stage);
    let manifest = manifest(&scene);
    let warned = warnings_with(&manifest, "primvars:tint");
    assert_eq!(
        warned,
        ["PointInstancer /World/ByInstance: primvars:tint (vertex) has 2 values, expected 3 (one per \
          instance for vertex or varying, one for constant or uniform); ignored"],
    );
    // Its instances read the fallback, warned about as such.
    let lacking = warnings_with(&manifest, "Prototypes/Quad has no primvar tint");
    assert_eq!(lacking.len(), 1, "{lacking:?}");
    let runs = &manifest["instances"]["primvars"]["tint"];
    assert!(
        runs.as_array()
            .unwrap()
            .iter()
            .all(|r| r["first"].as_u64() >= Some(3)),
        "the ByInstance copies (0..3) carry no tint: {runs}"
    );
}

#[test]
fn the_intent_vfx_teapot_rings_carry_their_per_instance_colours() {
    needs_shared!();
    let dir = common::scratch("instance_primvars_teapots");
    let usd = common::asset("usd-wg/intent-vfx/scenes/teapotScene.usd");
    let out = dir.join("out");
    common::cirrus_ok(&[
        "export".as_ref(),
        usd.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let manifest = manifest(&out);
    let warned = warnings_with(&manifest, "custom_color");
    assert!(warned.is_empty(), "{warned:?}");
    // Thirteen rings' PointInstancers author custom_color, one colour per teapot.
    let runs = manifest["instances"]["primvars"]["custom_color"]
        .as_array()
        .unwrap();
    assert_eq!(runs.len(), 13);
    assert!(runs.iter().all(|r| r["values"]["width"] == 3));
}

#[test]
fn overlapping_instance_primvar_runs_are_refused_naming_the_run() {
    let dir = common::scratch("instance_primvars_overlap");
    let scene = exported("instance_primvars");
    std::fs::copy(scene.join("scene.bin"), dir.join("scene.bin")).unwrap();
    let mut m = manifest(&scene);
    // The second run (the Constant instancer's, from instance 3) moved onto the first.
    m["instances"]["primvars"]["tint"][1]["first"] = 1.into();
    std::fs::write(dir.join("scene.json"), m.to_string()).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(["info".as_ref(), dir.as_os_str()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("instances.primvars.tint[1]") && stderr.contains("overlap"),
        "{stderr}"
    );
}

/// The values of `instances.primvars.NAME`'s only run, which must start at
/// instance 0, from the exported `scene`'s scene.bin.
fn only_run(scene: &Path, manifest: &Value, name: &str) -> Vec<f32> {
    let runs = manifest["instances"]["primvars"][name].as_array().unwrap();
    assert_eq!(runs.len(), 1, "{name}: {runs:?}");
    assert_eq!(runs[0]["first"], 0);
    let values = &runs[0]["values"];
    let at = values["offset"].as_u64().unwrap() as usize;
    let n = (values["count"].as_u64().unwrap() * values["width"].as_u64().unwrap()) as usize;
    let blob = std::fs::read(scene.join("scene.bin")).unwrap();
    blob[at..at + 4 * n]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

#[test]
fn nested_instancers_give_the_nearest_value_and_masked_copies_none() {
    let scene = exported("instance_primvars_nested");
    let manifest = manifest(&scene);
    assert_eq!(manifest["instances"]["count"], 4);
    // Copies outer-major: Outer 0 x Inner (0, 2), then Outer 1 x Inner (0, 2).
    let tint = only_run(&scene, &manifest, "tint");
    let inner = [0.1f32, 0.3, 0.1, 0.3].map(|v| [v; 3]).concat();
    assert_eq!(tint, inner);
    assert_eq!(
        only_run(&scene, &manifest, "grey"),
        [0.25, 0.25, 0.75, 0.75]
    );
}

/// A stage of three unbound 10 x 10 quads in a row, seen straight down by an
/// orthographic camera they fill, under a white dome of radiance 1: the
/// first two are PointInstancer `Coloured`'s copies, the third
/// `Plain`'s. `coloured` is that instancer's prototypes and primvars.
fn unbound_quads(coloured: &str) -> String {
    let quad = "uniform token subdivisionScheme = \"none\"
                point3f[] points = [(-5, 0, -5), (-5, 0, 5), (5, 0, 5), (5, 0, -5)]
                int[] faceVertexCounts = [4]
                int[] faceVertexIndices = [0, 1, 2, 3]";
    format!(
        "#usda 1.0
(
    defaultPrim = \"World\"
    metersPerUnit = 1
    upAxis = \"Y\"
)

def Xform \"World\"
{{
    def Camera \"Camera\"
    {{
        double3 xformOp:translate = (0, 1, 0)
        float xformOp:rotateX = -90
        uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateX\"]
        token projection = \"orthographic\"
        float horizontalAperture = 300
        float verticalAperture = 100
        float2 clippingRange = (0.01, 100)
    }}

    def DomeLight \"Dome\"
    {{
        color3f inputs:color = (1, 1, 1)
        float inputs:intensity = 1
    }}

    def PointInstancer \"Coloured\"
    {{
        point3f[] positions = [(-10, 0, 0), (0, 0, 0)]
        {coloured}
    }}

    def PointInstancer \"Plain\"
    {{
        point3f[] positions = [(10, 0, 0)]
        int[] protoIndices = [0]
        rel prototypes = [</World/Plain/Prototypes/Quad>]

        def Scope \"Prototypes\"
        {{
            def Mesh \"Quad\"
            {{
                {quad}
            }}
        }}
    }}
}}
",
        coloured = coloured.replace("QUAD", quad)
    )
}

/// The three cells' red, green and blue pixel estimates (the 6 x 6 pixels
/// clear of each cell's edges) of `stage`, rendered from its export, whose
/// warnings must be none.
fn unbound_cells(test: &str, stage: &str) -> Vec<[common::Estimate; 3]> {
    let dir = common::scratch(test);
    let scene = common::export_usda(&dir, stage);
    let warnings = &manifest(&scene)["warnings"];
    assert_eq!(warnings.as_array().map(Vec::len), Some(0), "{warnings}");
    let image = Render {
        scene: scene.to_str().unwrap(),
        res: (30, 10),
        spp: 16,
        seed: 5,
        extra: &[],
    }
    .run(&dir);
    (0..3)
        .map(|cell| {
            let inside = |x: usize, y: usize| {
                (cell * 10 + 2..cell * 10 + 8).contains(&x) && (2..8).contains(&y)
            };
            [0, 1, 2].map(|c| estimate(image.pixels(c, inside)))
        })
        .collect()
}

#[test]
fn an_instancers_display_colour_colours_its_unbound_copies_as_their_own_would() {
    // Per instance: each copy reads its instancer's displayColor (Hydra's
    // fallback material); the Plain instancer's copy, given none, silently
    // keeps the unbound look.
    let per_instance = unbound_quads(
        "int[] protoIndices = [0, 0]
        rel prototypes = [</World/Coloured/Prototypes/Quad>]
        color3f[] primvars:displayColor = [(0.8, 0.2, 0.1), (0.1, 0.7, 0.2)] (
            interpolation = \"vertex\"
        )

        def Scope \"Prototypes\"
        {
            def Mesh \"Quad\"
            {
                QUAD
            }
        }",
    );
    // The reference: each prototype's mesh carries the colour itself.
    let own = unbound_quads(
        "int[] protoIndices = [0, 1]
        rel prototypes = [</World/Coloured/Prototypes/Red>, </World/Coloured/Prototypes/Green>]

        def Scope \"Prototypes\"
        {
            def Mesh \"Red\"
            {
                QUAD
                color3f[] primvars:displayColor = [(0.8, 0.2, 0.1)]
            }

            def Mesh \"Green\"
            {
                QUAD
                color3f[] primvars:displayColor = [(0.1, 0.7, 0.2)]
            }
        }",
    );
    let measured = unbound_cells("instance_display_colour", &per_instance);
    let reference = unbound_cells("instance_display_colour_own", &own);
    for (cell, (a, b)) in measured.iter().zip(&reference).enumerate() {
        for (c, (a, b)) in a.iter().zip(b).enumerate() {
            let sigma = a.sigma.hypot(b.sigma).max(PIXEL_ROUNDING * b.mean);
            eprintln!(
                "cell {cell} channel {c}: {:.5} vs {:.5}, sigma {sigma:.1e}",
                a.mean, b.mean
            );
            assert!(
                (a.mean - b.mean).abs() <= 4.0 * sigma,
                "cell {cell} channel {c}: {} vs its own colour's {} (sigma {sigma})",
                a.mean,
                b.mean
            );
        }
    }
    // The colours are seen: the first copy is redder than the second.
    assert!(measured[0][0].mean > measured[1][0].mean + 0.2);
}

#[test]
fn unbound_instanced_meshes_without_display_colour_keep_the_default_look_unwarned() {
    let dir = common::scratch("instance_display_colour_none");
    let stage = unbound_quads(
        "int[] protoIndices = [0, 0]
        rel prototypes = [</World/Coloured/Prototypes/Quad>]

        def Scope \"Prototypes\"
        {
            def Mesh \"Quad\"
            {
                QUAD
            }
        }",
    );
    let manifest = manifest(&common::export_usda(&dir, &stage));
    assert_eq!(manifest["warnings"], serde_json::json!([]));
    // No material at all: the renderer's unbound look, as before instances
    // could colour them.
    assert_eq!(manifest["materials"], serde_json::json!([]));
    assert!(manifest["instances"].get("primvars").is_none());
}
