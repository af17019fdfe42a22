//! UsdPreviewSurface rows: each input on its own quad, on a dome-lit sheet
//! (a white dome of radiance 1: a quad facing it reads its directional
//! albedo, a smooth dielectric seen head-on its Fresnel F0; what is
//! transparent shows the red ground) and a sun-lit one (irradiance pi at 30
//! degrees from +X: a white Lambert quad reads 0.866; a mirror seen from
//! above reflects the black sky).

use super::sheet::{self, ensure, near, Lighting, Shot};
use super::{row, Choice, Honoured, Row, Warned};
use std::sync::OnceLock;

const COLS: usize = 8;

fn dome_cells() -> Vec<String> {
    let black = sheet::lambert((0.0, 0.0, 0.0));
    let white = sheet::lambert((1.0, 1.0, 1.0));
    let grey = sheet::lambert((0.5, 0.5, 0.5));
    [
        sheet::lambert((0.1, 0.1, 0.8)),
        format!("{black}\ncolor3f inputs:emissiveColor = (0, 0, 2)"),
        "color3f inputs:diffuseColor = (0, 0, 0)\nint inputs:useSpecularWorkflow = 1\n\
         color3f inputs:specularColor = (0, 0, 1)\nfloat inputs:roughness = 0"
            .into(),
        "color3f inputs:diffuseColor = (0, 0, 0)\nint inputs:useSpecularWorkflow = 0\n\
         color3f inputs:specularColor = (0, 0, 1)\nfloat inputs:roughness = 0"
            .into(),
        "color3f inputs:diffuseColor = (0, 0, 0)\nfloat inputs:roughness = 0\nfloat inputs:ior = 1.5".into(),
        "color3f inputs:diffuseColor = (0, 0, 0)\nfloat inputs:roughness = 0\nfloat inputs:ior = 3".into(),
        format!("{black}\nfloat inputs:clearcoat = 1\nfloat inputs:clearcoatRoughness = 0"),
        black.clone(),
        format!("{white}\nfloat inputs:opacity = 0\nfloat inputs:ior = 1"),
        format!("{white}\nfloat inputs:opacity = 0.3\nfloat inputs:opacityThreshold = 0.5"),
        format!("{white}\nfloat inputs:opacity = 0.7\nfloat inputs:opacityThreshold = 0.5"),
        format!("{grey}\nfloat inputs:occlusion = 0"),
        grey.clone(),
        format!("{grey}\nfloat inputs:displacement = 0.5"),
        format!("{white}\nfloat inputs:opacity = 0"),
    ]
    .iter()
    .map(|inputs| sheet::tile(inputs))
    .collect()
}

fn dome() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        sheet::render_sheet(
            "surface_dome",
            &sheet::sheet(COLS, Lighting::Dome, &dome_cells(), ""),
            16,
        )
    })
}

/// The encoded tangent-space normal of [`sun_cells`]' normal map: (-0.7071,
/// 0, 0.7071), tilted 45 degrees away from the sun, as (n + 1) / 2.
const NORMAL_TEXEL: [f32; 3] = [0.146_446_6, 0.5, 0.853_553_4];

fn sun_cells() -> Vec<String> {
    let white = sheet::lambert((1.0, 1.0, 1.0));
    let black = sheet::lambert((0.0, 0.0, 0.0));
    let mut cells: Vec<String> = [
        white.clone(),
        "color3f inputs:diffuseColor = (1, 1, 1)\nfloat inputs:metallic = 1\nfloat inputs:roughness = 0".into(),
        "color3f inputs:diffuseColor = (1, 1, 1)\nfloat inputs:metallic = 1\nfloat inputs:roughness = 0.7".into(),
        "color3f inputs:diffuseColor = (1, 1, 1)\nfloat inputs:metallic = 0\nfloat inputs:roughness = 0".into(),
        format!("{black}\nfloat inputs:clearcoat = 1\nfloat inputs:clearcoatRoughness = 0"),
        format!("{black}\nfloat inputs:clearcoat = 1\nfloat inputs:clearcoatRoughness = 0.7"),
    ]
    .iter()
    .map(|inputs| sheet::tile(inputs))
    .collect();
    cells.push(format!(
        "{}\n{}",
        sheet::quad(
            "Tile",
            "$CELL/Look",
            "normal3f[] normals = [(-0.7071068, 0, 0.7071068), (-0.7071068, 0, 0.7071068), \
         (-0.7071068, 0, 0.7071068), (-0.7071068, 0, 0.7071068)] (interpolation = \"vertex\")"
        ),
        sheet::material("$CELL/Look", &white)
    ));
    let nodes = "    def Shader \"Reader\"\n    {\n        uniform token info:id = \"UsdPrimvarReader_float2\"\n        \
                 string inputs:varname = \"st\"\n        float2 outputs:result\n    }\n    \
                 def Shader \"Map\"\n    {\n        uniform token info:id = \"UsdUVTexture\"\n        \
                 asset inputs:file = @normal.exr@\n        token inputs:sourceColorSpace = \"raw\"\n        \
                 float4 inputs:scale = (2, 2, 2, 1)\n        float4 inputs:bias = (-1, -1, -1, 0)\n        \
                 float2 inputs:st.connect = <$CELL/Look/Reader.outputs:result>\n        float3 outputs:rgb\n    }";
    cells.push(format!(
        "{}\n{}",
        sheet::quad("Tile", "$CELL/Look", ""),
        sheet::material_with(
            "$CELL/Look",
            &format!("{white}\nnormal3f inputs:normal.connect = <$CELL/Look/Map.outputs:rgb>"),
            nodes
        )
    ));
    cells
}

fn sun() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let usda = sheet::sheet(COLS, Lighting::Sun, &sun_cells(), "");
        sheet::render(
            "surface_sun",
            &usda,
            (16, &["--res", "64x48"], sheet::RES),
            |dir| sheet::write_texture(&dir.join("normal.exr"), (4, 4), |_, _| NORMAL_TEXEL),
        )
    })
}

/// White Lambert under the sun: cos 30 degrees.
const SUN_LAMBERT: f64 = 0.866_025_4;

pub fn rows() -> Vec<Row> {
    vec![
        row("UsdPreviewSurface", "diffuseColor", Honoured, "a Lambert quad of albedo (0.1, 0.1, 0.8) under a dome of radiance 1 reads its albedo", || {
            near("diffuse", dome().cell(COLS, 0), [0.1, 0.1, 0.8], 0.1)
        }),
        row("UsdPreviewSurface", "emissiveColor", Honoured, "a black quad emitting (0, 0, 2) reads it", || {
            near("emission", dome().cell(COLS, 1), [0.0, 0.0, 2.0], 0.05)
        }),
        row("UsdPreviewSurface", "specularColor", Honoured, "a smooth black quad of specularColor (0, 0, 1) (specular workflow) mirrors the dome in blue", || {
            near("specular", dome().cell(COLS, 2), [0.0, 0.0, 1.0], 0.1)
        }),
        row("UsdPreviewSurface", "useSpecularWorkflow", Honoured, "off (the default), specularColor is ignored: the same quad reflects F0 = 0.04 in grey", || {
            let c = dome().cell(COLS, 3);
            ensure(c[2] < 0.1 && (c[2] - c[0]).abs() < 0.02, || format!("{c:.3?}"))
        }),
        row("UsdPreviewSurface", "ior", Honoured, "a smooth black dielectric seen head-on reflects F0 = ((ior - 1) / (ior + 1))^2: 0.04 at 1.5, 0.25 at 3", || {
            near("ior 1.5", dome().cell(COLS, 4), [0.04; 3], 0.25).and(near("ior 3", dome().cell(COLS, 5), [0.25; 3], 0.15))
        }),
        row("UsdPreviewSurface", "clearcoat", Honoured, "a coat over a black base reflects the coat's F0 0.04; without it nothing", || {
            near("coat", dome().cell(COLS, 6), [0.04; 3], 0.3).and(near("no coat", dome().cell(COLS, 7), [0.0; 3], 0.0))
        }),
        row("UsdPreviewSurface", "opacity", Honoured, "a white quad of opacity 0 and ior 1 (presence) shows the red ground through it, unreflected", || {
            near("presence", dome().cell(COLS, 8), [1.0, 0.0, 0.0], 0.05)
        }),
        row("UsdPreviewSurface", "opacity (with ior 1.5)", Honoured,
            "below 1, the spec's translucency: a single-sided quad of opacity 0 is a smooth interface into ior 1.5, the ground seen through it at (1 - F0) / ior^2 = 0.427, the dome reflected at F0 = 0.04", || {
                near("interface", dome().cell(COLS, 14), [0.427 + 0.04, 0.04, 0.04], 0.06)
            }),
        row("UsdPreviewSurface", "opacityThreshold", Honoured,
            "opacity 0.3 under threshold 0.5 cuts the quad out (the ground, unreflected); 0.7 over it is fully opaque (white, no ground)", || {
                near("cut out", dome().cell(COLS, 9), [1.0, 0.0, 0.0], 0.03).and(near("opaque", dome().cell(COLS, 10), [1.0; 3], 0.1))
            }),
        row("UsdPreviewSurface", "occlusion", Choice("ignored: a real-time hint for ambient occlusion, which a path tracer computes"),
            "a quad of occlusion 0 renders as the same quad without it (albedo 0.5)", || {
                near("occlusion 0", dome().cell(COLS, 11), [0.5; 3], 0.08).and(near("no occlusion", dome().cell(COLS, 12), [0.5; 3], 0.08))
            }),
        row("UsdPreviewSurface", "displacement", Warned,
            "not rendered: a warning names the material and displacement", || dome().warned(&["/Sheet/C13/Look", "displacement"])),
        row("UsdPreviewSurface", "metallic", Honoured, "a smooth white metal under the sun mirrors the black sky; the same dielectric is lit", || {
            let (metal, dielectric) = (sun().cell(COLS, 1), sun().cell(COLS, 3));
            ensure(metal[1] < 0.05 && dielectric[1] > 0.6, || format!("metal {metal:.3?}, dielectric {dielectric:.3?}"))
        }),
        row("UsdPreviewSurface", "roughness", Honoured, "a rough (0.7) white metal catches the sun's highlight seen from above, a smooth one does not", || {
            let (rough, smooth) = (sun().cell(COLS, 2), sun().cell(COLS, 1));
            ensure(rough[1] > 0.2 && smooth[1] < 0.05, || format!("rough {rough:.3?}, smooth {smooth:.3?}"))
        }),
        row("UsdPreviewSurface", "clearcoatRoughness", Honoured, "a rough coat (0.7) over black catches the sun's highlight, a smooth one does not", || {
            let (rough, smooth) = (sun().cell(COLS, 5), sun().cell(COLS, 4));
            ensure(rough[1] > 0.008 && smooth[1] < 0.004, || format!("rough {rough:.4?}, smooth {smooth:.4?}"))
        }),
        row("UsdPreviewSurface", "normal", Honoured, "a tangent-space normal map tilting 45 degrees away from the sun dims a white Lambert quad to cos 75 degrees", || {
            near("normal map", sun().cell(COLS, 7), [0.258_819; 3], 0.15)
        }),
        row("Mesh", "normals", Honoured, "vertex normals tilted 45 degrees away from the sun dim a white Lambert quad to cos 75 degrees (flat: cos 30)", || {
            near("flat", sun().cell(COLS, 0), [SUN_LAMBERT; 3], 0.08).and(near("tilted", sun().cell(COLS, 6), [0.258_819; 3], 0.15))
        }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
