//! UsdUVTexture, UsdTransform2d and primvar reader rows: Lambert quads
//! under a dome of radiance 1 (a pixel reads the albedo the network gives
//! it) on a sheet of 4 x 3 cells of 16 pixels, textured by an 8 x 4 EXR whose
//! left half is red (0.8, 0.1, 0.1) and right half blue (0.1, 0.1, 0.8);
//! `st` runs 0..1 across each quad unless the cell says otherwise; and three
//! primvar readers on a sheet of 8 columns.

use super::sheet::{self, ensure, near, Lighting, Rgb, Shot};
use super::{row, Honoured, Row};
use std::sync::OnceLock;

const COLS: usize = 4;
const RED: Rgb = [0.8, 0.1, 0.1];
const BLUE: Rgb = [0.1, 0.1, 0.8];

/// Parts of a quad, as fractions of its width: left, middle left, middle
/// right, right.
const L: (f64, f64) = (0.05, 0.2);
const ML: (f64, f64) = (0.3, 0.45);
const MR: (f64, f64) = (0.55, 0.7);
const R: (f64, f64) = (0.8, 0.95);

/// A textured quad: mesh attribute lines `mesh` (e.g. another `st`), the
/// texture's extra input lines `texture` (file `stripes.exr` unless given),
/// the reader's varname, and a UsdTransform2d's input lines between reader
/// and texture when `transform` is not empty.
fn textured(mesh: &str, texture: &str, varname: &str, transform: &str) -> String {
    let reader = "<$CELL/Look/Reader.outputs:result>";
    let (xform, st) = if transform.is_empty() {
        (String::new(), reader.to_owned())
    } else {
        (
            format!(
                "    def Shader \"Xf\"\n    {{\n        uniform token info:id = \"UsdTransform2d\"\n        \
                 float2 inputs:in.connect = {reader}\n        {}\n        float2 outputs:result\n    }}\n",
                transform.replace('\n', "\n        ")
            ),
            "<$CELL/Look/Xf.outputs:result>".to_owned(),
        )
    };
    let file = if texture.contains("inputs:file") {
        ""
    } else {
        "asset inputs:file = @stripes.exr@"
    };
    let nodes = format!(
        "    def Shader \"Reader\"\n    {{\n        uniform token info:id = \"UsdPrimvarReader_float2\"\n        \
         string inputs:varname = \"{varname}\"\n        float2 outputs:result\n    }}\n{xform}    \
         def Shader \"Tex\"\n    {{\n        uniform token info:id = \"UsdUVTexture\"\n        {file}\n        {}\n        \
         float2 inputs:st.connect = {st}\n        float3 outputs:rgb\n    }}",
        texture.replace('\n', "\n        ")
    );
    let inputs = format!(
        "{}\ncolor3f inputs:diffuseColor.connect = <$CELL/Look/Tex.outputs:rgb>",
        sheet::lambert((0.0, 0.0, 0.0))
    );
    format!(
        "{}\n{}",
        mesh_quad(mesh),
        sheet::material_with("$CELL/Look", &inputs, &nodes)
    )
}

/// The quad of [`sheet::quad`], its `st` replaced when `mesh` authors one.
fn mesh_quad(mesh: &str) -> String {
    let q = sheet::quad("Tile", "$CELL/Look", mesh);
    if mesh.contains("primvars:st") || mesh.contains("primvars:uv") {
        let line = q
            .lines()
            .find(|l| l.contains("texCoord2f[] primvars:st = [(0, 0)"))
            .unwrap()
            .to_owned();
        q.replace(&line, "")
    } else {
        q
    }
}

fn st(s: f64, t: f64) -> String {
    format!("texCoord2f[] primvars:st = [(0, 0), ({s}, 0), ({s}, {t}), (0, {t})] (interpolation = \"vertex\")")
}

fn cells() -> Vec<String> {
    let uv =
        "texCoord2f[] primvars:uv = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = \"vertex\")";
    vec![
        textured("", "", "st", ""),
        textured(
            uv,
            "token inputs:wrapS = \"repeat\"",
            "uv",
            "float2 inputs:scale = (2, 1)",
        ),
        textured(&st(2.0, 1.0), "token inputs:wrapS = \"repeat\"", "st", ""),
        textured(&st(2.0, 1.0), "token inputs:wrapS = \"clamp\"", "st", ""),
        textured(&st(2.0, 1.0), "token inputs:wrapS = \"black\"", "st", ""),
        textured(&st(2.0, 1.0), "token inputs:wrapS = \"mirror\"", "st", ""),
        textured(&st(1.0, 2.0), "token inputs:wrapT = \"black\"", "st", ""),
        textured("", "float4 inputs:scale = (0.5, 0.5, 0.5, 1)", "st", ""),
        textured("", "float4 inputs:bias = (0, 0.3, 0, 0)", "st", ""),
        textured(
            "",
            "asset inputs:file = @missing.exr@\nfloat4 inputs:fallback = (0, 0.7, 0, 1)",
            "st",
            "",
        ),
        textured(
            "",
            "token inputs:wrapS = \"repeat\"",
            "st",
            "float2 inputs:translation = (0.5, 0)",
        ),
        textured(
            "",
            "token inputs:wrapS = \"repeat\"\ntoken inputs:wrapT = \"repeat\"",
            "st",
            "float inputs:rotation = 180",
        ),
    ]
}

fn shot() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let usda = sheet::sheet(COLS, Lighting::Dome, &cells(), "");
        sheet::render(
            "texture",
            &usda,
            (16, &["--res", "64x48"], sheet::RES),
            |dir| {
                sheet::write_texture(&dir.join("stripes.exr"), (8, 4), |x, _| {
                    if x < 4 {
                        [0.8, 0.1, 0.1]
                    } else {
                        [0.1, 0.1, 0.8]
                    }
                })
            },
        )
    })
}

/// Ok when part `u` (rows 0.2..0.8) of cell `k` reads `expected`.
fn reads(k: usize, u: (f64, f64), expected: Rgb) -> Result<(), String> {
    near(
        &format!("cell {k} at u {u:?}"),
        shot().part(COLS, k, u, (0.2, 0.8)),
        expected,
        0.15,
    )
}

/// The primvar readers' sheet: a quad whose diffuseColor reads a constant
/// primvar `tint` (0.1, 0.1, 0.8) through UsdPrimvarReader_float3; one
/// without the primvar (the reader's fallback (0.1, 0.8, 0.1)); one whose
/// opacity reads a float primvar `cut` = 0 through UsdPrimvarReader_float;
/// two quads textured by an 8-bit PNG, read as sRGB and as raw.
fn readers() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let reader = |id: &str, name: &str, out: &str, fallback: &str| {
            format!(
                "    def Shader \"Reader\"\n    {{\n        uniform token info:id = \"{id}\"\n        \
                 string inputs:varname = \"{name}\"\n        {fallback}\n        {out} outputs:result\n    }}"
            )
        };
        let colour = |mesh: &str| {
            format!(
                "{}\n{}",
                sheet::quad("Tile", "$CELL/Look", mesh),
                sheet::material_with(
                    "$CELL/Look",
                    &format!("{}\ncolor3f inputs:diffuseColor.connect = <$CELL/Look/Reader.outputs:result>", sheet::lambert((0.0, 0.0, 0.0))),
                    &reader("UsdPrimvarReader_float3", "tint", "float3", "float3 inputs:fallback = (0.1, 0.8, 0.1)")
                )
            )
        };
        let cells = vec![
            colour("color3f[] primvars:tint = [(0.1, 0.1, 0.8)] (interpolation = \"constant\")"),
            colour(""),
            format!(
                "{}\n{}",
                sheet::quad("Tile", "$CELL/Look", "float[] primvars:cut = [0] (interpolation = \"constant\")"),
                sheet::material_with(
                    "$CELL/Look",
                    &format!("{}\nfloat inputs:ior = 1\nfloat inputs:opacity.connect = <$CELL/Look/Reader.outputs:result>", sheet::lambert((1.0, 1.0, 1.0))),
                    &reader("UsdPrimvarReader_float", "cut", "float", "float inputs:fallback = 1")
                )
            ),
            grey("sRGB"),
            grey("raw"),
        ];
        let usda = sheet::sheet(8, Lighting::Dome, &cells, "");
        sheet::render(
            "readers",
            &usda,
            (16, &["--res", "64x48"], sheet::RES),
            |dir| {
                cirrus::image::write_display_png(
                    &dir.join("grey.png"),
                    2,
                    2,
                    &[GREY as f32; 12],
                    &[],
                )
                .unwrap();
            },
        )
    })
}

/// The linear grey of `grey.png`, an 8-bit sRGB-encoded PNG: byte 128.
const GREY: f64 = 0.2158;

/// A quad textured by `grey.png` read with sourceColorSpace `space`.
fn grey(space: &str) -> String {
    textured(
        "",
        &format!("asset inputs:file = @grey.png@\ntoken inputs:sourceColorSpace = \"{space}\""),
        "st",
        "",
    )
}

pub fn rows() -> Vec<Row> {
    vec![
        row("UsdUVTexture", "file, st, outputs:rgb", Honoured, "the image's left half red, right half blue, across the quad", || {
            reads(0, L, RED).and(reads(0, R, BLUE))
        }),
        row("UsdPrimvarReader_float2", "varname", Honoured, "st read from the primvar `uv` the reader names", || reads(1, L, RED)),
        row("UsdTransform2d", "scale", Honoured, "scale (2, 1) repeats the image twice across the quad", || {
            reads(1, ML, BLUE).and(reads(1, MR, RED))
        }),
        row("UsdTransform2d", "translation", Honoured, "translation (0.5, 0), wrapping, swaps the halves", || {
            reads(10, L, BLUE).and(reads(10, R, RED))
        }),
        row("UsdTransform2d", "rotation", Honoured, "rotation 180 degrees (st -> -st), wrapping, swaps the halves", || {
            reads(11, L, BLUE).and(reads(11, R, RED))
        }),
        row("UsdUVTexture", "wrapS", Honoured, "st 0..2 across: repeat starts the image again, clamp holds its edge, black is black, mirror reflects it", || {
            reads(2, MR, RED)
                .and(reads(3, MR, BLUE))
                .and(reads(4, MR, [0.0; 3]))
                .and(reads(5, MR, BLUE))
                .and(reads(2, L, RED))
        }),
        row("UsdUVTexture", "wrapT", Honoured, "t 0..2 up the quad, black: its upper half is black", || {
            let s = shot();
            near("lower half", s.part(COLS, 6, L, (0.1, 0.4)), RED, 0.15)
                .and(near("upper half", s.part(COLS, 6, L, (0.6, 0.9)), [0.0; 3], 0.15))
        }),
        row("UsdUVTexture", "scale", Honoured, "scale 0.5 halves the texel", || reads(7, L, [0.4, 0.05, 0.05])),
        row("UsdUVTexture", "bias", Honoured, "bias (0, 0.3, 0) adds to the texel", || reads(8, L, [0.8, 0.4, 0.1])),
        row("UsdUVTexture", "fallback", Honoured, "a missing file reads the fallback, with a warning naming material and file", || {
            reads(9, L, [0.0, 0.7, 0.0]).and(shot().warned(&["/Sheet/C9/Look", "missing.exr"]))
        }),
        row("UsdUVTexture", "sourceColorSpace", Honoured,
            "an 8-bit PNG of byte 128 reads 0.216 as sRGB (decoded) and 128 / 255 = 0.502 as raw (the bytes as they are)", || {
                let raw = 128.0 / 255.0;
                near("sRGB", readers().cell(8, 3), [GREY; 3], 0.1).and(near("raw", readers().cell(8, 4), [raw; 3], 0.1))
            }),
        row("UsdPrimvarReader_float3", "varname", Honoured, "diffuseColor reads the mesh's constant primvar", || {
            near("tint", readers().cell(8, 0), [0.1, 0.1, 0.8], 0.1)
        }),
        row("UsdPrimvarReader_float3", "fallback", Honoured, "a primvar the mesh lacks reads the reader's fallback", || {
            near("fallback", readers().cell(8, 1), [0.1, 0.8, 0.1], 0.1)
        }),
        row("UsdPrimvarReader_float", "varname", Honoured, "opacity reads a float primvar 0: the ground shows through", || {
            let c = readers().cell(8, 2);
            ensure(c[0] > 0.8 && c[1] < 0.06, || format!("{c:.3?}"))
        }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
