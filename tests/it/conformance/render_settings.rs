//! UsdRender rows: a sheet rendered through its RenderSettings (no `-o`,
//! `--res` or `--aovs`: the settings choose camera, resolution, purposes
//! and the product's file and layers), and the settings that turn off
//! motion blur and depth of field on the camera family's stages.
//! `tests/it/render_settings.rs` tests products and vars in depth.

use super::camera;
use super::sheet::{self, ensure, spans, Lighting, Shot};
use super::{row, Approximated, Honoured, Row, Warned};
use std::sync::OnceLock;

const COLS: usize = 8;

/// The settings' camera looks one cell (2 units) further right than the
/// sheet's, so cell k shows where cell k - 1 would.
fn shot() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let blue = "/Looks/Blue";
        let cells = vec![
            String::new(),
            sheet::tile(&sheet::lambert((1.0, 1.0, 1.0))),
            String::new(),
            "def Sphere \"S\"\n{\n    double radius = 0.6\n    uniform token purpose = \"proxy\"\n}".to_owned(),
            "def Sphere \"S\"\n{\n    double radius = 0.6\n    uniform token purpose = \"render\"\n}".to_owned(),
            String::new(),
            sheet::quad("Q", blue, "rel material:binding:preview = </Looks/Green>\nrel material:binding:full = </Looks/Green>"),
        ];
        let settings = format!(
            "def Scope \"Looks\"\n{{\n{}\n{}\n}}\n\n{}\n\
             def Scope \"Render\"\n{{\n    def RenderSettings \"Shot\"\n    {{\n        int2 resolution = (64, 48)\n        \
             rel camera = </Side>\n        uniform token[] includedPurposes = [\"default\", \"proxy\"]\n        \
             uniform token[] materialBindingPurposes = [\"\"]\n        rel products = </Render/Out>\n    }}\n    \
             def RenderProduct \"Out\"\n    {{\n        token productName = \"out.exr\"\n        \
             uniform token aspectRatioConformPolicy = \"cropAperture\"\n        \
             rel orderedVars = [</Render/Beauty>, </Render/Diffuse>]\n    }}\n    \
             def RenderVar \"Beauty\"\n    {{\n        string sourceName = \"C.*L\"\n        token sourceType = \"lpe\"\n        \
             token dataType = \"color4f\"\n    }}\n    def RenderVar \"Diffuse\"\n    {{\n        \
             string sourceName = \"lpe:C<RD>.*L\"\n        token dataType = \"color3f\"\n    }}\n    \
             def RenderPass \"Pass\"\n    {{\n        token passType = \"prman\"\n        rel renderSource = </Render/Shot>\n    }}\n}}\n",
            sheet::material("Looks/Blue", &sheet::lambert((0.05, 0.05, 0.8))),
            sheet::material("Looks/Green", &sheet::lambert((0.05, 0.8, 0.05))),
            sheet::top_camera("Side", "").replace("(0, 0, 10)", "(2, 0, 10)")
        );
        let usda = sheet::sheet(COLS, Lighting::Dome, &cells, &settings);
        sheet::render(
            "settings",
            &usda,
            (8, &["--settings", "/Render/Shot"], sheet::RES),
            |_| {},
        )
    })
}

/// A ball of radius 1 at (4, 3) rendered through settings of 32 x 48
/// pixels twice as wide as tall (pixelAspectRatio 2: the 4:3 aperture
/// exactly) whose product keeps the image's top right quarter
/// (dataWindowNDC (0.5, 0.5, 1, 1), y up): the ball spans columns 22..26
/// and rows 8..16 of the whole image, columns 6..10 of the data window.
fn cropped() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let extra = "def Sphere \"Ball\"\n{\n    double radius = 1\n    double3 xformOp:translate = (4, 3, 0)\n    \
                     uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n\n\
                     def RenderSettings \"Shot\"\n{\n    int2 resolution = (32, 48)\n    float pixelAspectRatio = 2\n    \
                     rel camera = </Camera>\n    rel products = </Out>\n}\n\n\
                     def RenderProduct \"Out\"\n{\n    token productName = \"out.exr\"\n    float4 dataWindowNDC = (0.5, 0.5, 1, 1)\n}\n";
        let usda = sheet::sheet(COLS, Lighting::Dome, &[], extra);
        sheet::render(
            "settings_cropped",
            &usda,
            (4, &["--settings", "/Shot"], (16, 24)),
            |_| {},
        )
    })
}

/// What the cropped render's EXR header says.
struct Header {
    /// The data window's top-left pixel.
    origin: (i32, i32),
    /// The display window's size, pixels.
    display: (usize, usize),
    /// `pixelAspectRatio`: a pixel's width over its height.
    aspect: f32,
}

fn cropped_header() -> Result<Header, String> {
    let exr = exr::prelude::read_all_flat_layers_from_file(cropped().dir.join("out.exr"))
        .map_err(|e| e.to_string())?;
    let origin = exr.layer_data[0].attributes.layer_position;
    let display = exr.attributes.display_window.size;
    Ok(Header {
        origin: (origin.x(), origin.y()),
        display: (display.x(), display.y()),
        aspect: exr.attributes.pixel_aspect,
    })
}

/// The cropped render's covered pixels (green over 0.03), in the data
/// window's columns and rows.
fn cropped_ball() -> Vec<(usize, usize)> {
    let image = &cropped().image;
    (0..image.width * image.height)
        .filter(|&i| image.rgb[1][i] > 0.03)
        .map(|i| (i % image.width, i / image.width))
        .collect()
}

/// Cell `k`'s covered pixels (green over 0.03).
fn covered(k: usize) -> usize {
    shot().covered(COLS, k, 1, 0.03).len()
}

/// The moving ball of the camera family under render settings `attrs`.
fn still(name: &str, cache: &'static OnceLock<Shot>, attrs: &str) -> &'static Shot {
    sheet::once(cache, || {
        let settings = format!(
            "def RenderSettings \"Shot\"\n{{\n    int2 resolution = (64, 48)\n    {attrs}\n}}\n"
        );
        sheet::render_sheet(name, &camera::moving_sheet(&settings), 16)
    })
}

/// Ok when the moving ball of `shot` renders sharp.
fn sharp(shot: &Shot) -> Result<(), String> {
    let (x, y) = spans(&shot.covered(8, 0, 1, 0.01));
    ensure(x <= 4 && y <= 4 && x > 0, || {
        format!("{x} columns x {y} rows")
    })
}

pub fn rows() -> Vec<Row> {
    vec![
        row("RenderSettings", "camera", Honoured, "the settings' camera, one cell to the right of the first camera, is the one rendered", || {
            let (left, right) = (shot().cell(COLS, 0), shot().cell(COLS, 1));
            ensure(left[1] > 0.8 && right[1] < 0.03, || format!("cell 0 {left:.3?}, cell 1 {right:.3?}"))
        }),
        row("RenderSettings", "resolution", Honoured, "the image is the settings' 64 x 48 (no --res given)", || {
            let image = &shot().image;
            ensure((image.width, image.height) == (64, 48), || format!("{} x {}", image.width, image.height))
        }),
        row("RenderSettings", "includedPurposes", Honoured, "[default, proxy]: the proxy sphere is drawn, the render one is not", || {
            let (proxy, render) = (covered(2), covered(3));
            ensure(proxy > 10 && render == 0, || format!("proxy {proxy} pixels, render {render}"))
        }),
        row("RenderSettings", "materialBindingPurposes", Honoured, "[\"\"] (all-purpose bindings only): a quad bound blue for all purposes, green for preview and full, renders blue", || {
            let c = shot().cell(COLS, 5);
            ensure(c[2] > 0.6 && c[1] < 0.15, || format!("{c:.3?}"))
        }),
        row("RenderSettings", "disableMotionBlur", Honoured, "a ball moving over the open shutter renders sharp", || {
            static SHOT: OnceLock<Shot> = OnceLock::new();
            sharp(still("settings_no_blur", &SHOT, "uniform bool disableMotionBlur = 1"))
        }),
        row("RenderSettings", "instantaneousShutter", Approximated("read as disableMotionBlur: the frame is rendered sharp, not the instant shutter:open (warned)"), "a ball moving over the open shutter renders sharp", || {
            static SHOT: OnceLock<Shot> = OnceLock::new();
            sharp(still("settings_instant", &SHOT, "bool instantaneousShutter = 1"))
        }),
        row("RenderSettings", "disableDepthOfField", Honoured, "the camera family's f/8 ball renders sharp: its middle black", || {
            static SHOT: OnceLock<Shot> = OnceLock::new();
            let shot = sheet::once(&SHOT, || {
                let settings = "def RenderSettings \"Shot\"\n{\n    int2 resolution = (64, 48)\n    uniform bool disableDepthOfField = 1\n}\n";
                sheet::render_sheet("settings_no_dof", &camera::lens_stage(camera::DOF, settings), 16)
            });
            let c = shot.mean((31, 33), (23, 25));
            ensure(c[1] < 0.03, || format!("{c:.3?}"))
        }),
        row("RenderProduct", "productName, orderedVars", Honoured, "the product's file holds its vars as layers named as the vars: the beauty and Diffuse.R/G/B", || {
            let names: Vec<String> = crate::common::channel_bits(&shot().dir.join("out.exr")).into_iter().map(|(n, _)| n).collect();
            ensure(["R", "G", "B", "Diffuse.R", "Diffuse.G", "Diffuse.B"].iter().all(|n| names.iter().any(|m| m == n)), || format!("{names:?}"))
        }),
        row("RenderVar", "sourceName, sourceType (lpe)", Honoured, "the diffuse var C<RD>.*L of a white Lambert quad equals its beauty", || {
            let exr = shot().dir.join("out.exr");
            let image = exr::prelude::read_all_flat_layers_from_file(&exr).map_err(|e| e.to_string())?;
            let channel = |name: &str| -> Vec<f32> {
                let c = image.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == name).unwrap();
                match &c.sample_data {
                    exr::prelude::FlatSamples::F32(v) => v.clone(),
                    exr::prelude::FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                    exr::prelude::FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
                }
            };
            let (beauty, diffuse) = (channel("G"), channel("Diffuse.G"));
            let at = |v: &[f32]| (2..6).flat_map(|y| (2..6).map(move |x| (x, y))).map(|(x, y)| f64::from(v[y * 64 + x])).sum::<f64>() / 16.0;
            let (b, d) = (at(&beauty), at(&diffuse));
            ensure(b > 0.8 && (b - d).abs() < 0.01 * b, || format!("beauty {b:.4}, diffuse {d:.4}"))
        }),
        row("RenderProduct", "dataWindowNDC", Honoured,
            "(0.5, 0.5, 1, 1) of 32 x 48: the EXR's data window is the top right 16 x 24 pixels at (16, 0) of a 32 x 48 display window, holding the ball where the whole image has it (columns 6..10 of the window)", || {
                let Header { origin, display, .. } = cropped_header()?;
                let c = cropped_ball();
                let x = sheet::centroid_x(&c);
                ensure(origin == (16, 0) && display == (32, 48) && (x - 8.0).abs() < 1.0, || format!("origin {origin:?}, display {display:?}, ball centred on column {x:.2}"))
            }),
        row("RenderSettings", "pixelAspectRatio", Honoured,
            "2: the EXR says so, and a ball of radius 1 spans half as many columns (4) as rows (8)", || {
                let aspect = cropped_header()?.aspect;
                let (x, y) = spans(&cropped_ball());
                ensure(aspect == 2.0 && (3..=5).contains(&x) && (7..=9).contains(&y), || format!("pixel aspect {aspect}, the ball {x} columns x {y} rows"))
            }),
        row("RenderProduct", "aspectRatioConformPolicy", Warned, "not modelled: a warning names the product and the policy", || {
            shot().warned(&["/Render/Out", "aspectRatioConformPolicy"])
        }),
        row("RenderPass", "passType, renderSource", Warned, "not rendered: a warning names the pass", || {
            shot().warned(&["/Render/Pass"])
        }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
