//! UsdGeomCamera rows: a perspective camera 10 units above a grey Lambert
//! quad (albedo 0.5, so 0.5 under the dome of radiance 1) over the red
//! ground, its lens and film read from where the quad lands; depth of field
//! from a small black ball halfway to the quad; the shutter from a ball
//! moving across a sheet cell. The orthographic projection is every other
//! sheet's (`sheet.rs`).

use super::sheet::{self, ensure, spans, Lighting, Shot};
use super::{row, Honoured, Row};
use std::sync::OnceLock;

/// A stage seen by `camera` (the first and only camera) over the dome
/// lighting: the grey quad 2 x 2 at z = 0 and `extra` usda.
pub fn lens_stage(camera: &str, extra: &str) -> String {
    format!(
        "{}def Camera \"Lens\"\n{{\n    double3 xformOp:translate = (0, 0, 10)\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    float focalLength = 50\n    \
         float horizontalAperture = 20\n    float verticalAperture = 15\n    {}\n}}\n\n{}\n\
         def Xform \"Quad\"\n{{\n    float3 xformOp:scale = (1.25, 1.25, 1)\n    uniform token[] xformOpOrder = [\"xformOp:scale\"]\n{}\n}}\n\n{}\n\
         def Sphere \"Ball\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    double radius = 0.1\n    \
         double3 xformOp:translate = (0, 0, 5)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    \
         rel material:binding = </Black>\n}}\n{extra}\n",
        sheet::HEADER,
        camera.replace('\n', "\n    "),
        sheet::lights(Lighting::Dome),
        sheet::quad("Tile", "/Grey", ""),
        [
            sheet::material("Grey", &sheet::lambert((0.5, 0.5, 0.5))),
            sheet::material("Black", &sheet::lambert((0.0, 0.0, 0.0))),
        ]
        .concat()
    )
}

/// Film offsets, near clipping and exposure: the quad lands on columns
/// 8..40 and rows 12.8..44.8; a black dot 0.5 in front of the lens (inside
/// the near plane, 1) would cover the image's middle. Its own ball is moved
/// out of view.
fn film() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let camera = "float horizontalApertureOffset = 2.5\nfloat verticalApertureOffset = 1.5\n\
                      float2 clippingRange = (1, 100)\nfloat exposure = 1";
        let dot = "def Sphere \"Dot\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{\n    double radius = 0.02\n    \
                   double3 xformOp:translate = (0.025, 0.015, 9.5)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    \
                   rel material:binding = </Black>\n}\n";
        let usda = lens_stage(camera, dot).replace(
            "double3 xformOp:translate = (0, 0, 5)",
            "double3 xformOp:translate = (0, -30, 5)",
        );
        sheet::render_sheet("camera_film", &usda, 8)
    })
}

/// Depth of field: f-stop 8 focused at 10 (on the quad): the ball at 5
/// blurs over a disk of 10 pixels, its middle pixel seeing the quad through
/// 59% of the lens.
pub const DOF: &str = "float fStop = 8\nfloat focusDistance = 10";

fn dof() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        sheet::render_sheet("camera_dof", &lens_stage(DOF, ""), 32)
    })
}

/// A ball of radius 0.3 moving 1 unit along X over frame 0..1 in cell 0 of
/// a sheet, under `extra` (render settings).
pub fn moving_sheet(extra: &str) -> String {
    let cell = "def Sphere \"S\"\n{\n    double radius = 0.3\n    double3 xformOp:translate.timeSamples = {\n        \
                0: (-0.5, 0, 0),\n        1: (0.5, 0, 0),\n    }\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}";
    sheet::sheet(8, Lighting::Dome, &[cell.to_owned()], extra).replace(
        "float2 clippingRange = (0.1, 100)\n",
        "float2 clippingRange = (0.1, 100)\n    double shutter:open = 0\n    double shutter:close = 1\n",
    )
}

fn motion() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        sheet::render_sheet("camera_motion", &moving_sheet(""), 16)
    })
}

/// Columns and rows where the quad covers more than half of a pixel.
fn quad_extent(shot: &Shot) -> ((usize, usize), (usize, usize)) {
    let w = shot.image.width;
    let lit: Vec<(usize, usize)> = (0..shot.image.height)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            f64::from(shot.image.rgb[1][y * w + x])
                > 0.5 * f64::from(shot.image.rgb[1][24 * w + 24]).max(0.2)
        })
        .collect();
    let (cols, rows): (Vec<usize>, Vec<usize>) = lit.iter().copied().unzip();
    let range = |v: &[usize]| (*v.iter().min().unwrap_or(&0), *v.iter().max().unwrap_or(&0));
    (range(&cols), range(&rows))
}

pub fn rows() -> Vec<Row> {
    vec![
        row("Camera", "projection, focalLength, horizontalAperture", Honoured,
            "focal length 50 over a 20 aperture (tenths of a unit) sees 4 units at 10: the 2-unit quad spans 32 of 64 columns", || {
                let ((x0, x1), _) = quad_extent(film());
                ensure((31..=33).contains(&(x1 + 1 - x0)), || format!("columns {x0}..={x1}"))
            }),
        row("Camera", "verticalAperture", Honoured, "15, matching the image's 4:3: the quad spans 32 rows (other aspects: the render settings' conform policy)", || {
            let (_, (y0, y1)) = quad_extent(film());
            ensure((31..=33).contains(&(y1 + 1 - y0)), || format!("rows {y0}..={y1}"))
        }),
        row("Camera", "horizontalApertureOffset", Honoured, "2.5 shifts the view right by 8 pixels: the quad starts at column 8", || {
            let ((x0, _), _) = quad_extent(film());
            ensure((7..=9).contains(&x0), || format!("first column {x0}"))
        }),
        row("Camera", "verticalApertureOffset", Honoured, "1.5 shifts the view up by 4.8 pixels: the quad starts at row 13", || {
            let (_, (y0, _)) = quad_extent(film());
            ensure((12..=14).contains(&y0), || format!("first row {y0}"))
        }),
        row("Camera", "clippingRange", Honoured, "a black dot 0.5 in front of a near plane at 1 is not drawn: the image's middle shows the quad", || {
            let c = film().mean((30, 34), (22, 26));
            ensure(c[1] > 0.3, || format!("{c:.3?}"))
        }),
        row("Camera", "exposure", Honoured, "exposure 1 doubles the image: the quad reads 2 x 0.5", || {
            let c = film().mean((12, 36), (16, 40));
            sheet::near("exposed quad", c, [1.0; 3], 0.05)
        }),
        row("Camera", "fStop", Honoured, "f/8 blurs a black ball at half the focus distance over 10 pixels: its middle sees the quad through 59% of the lens", || {
            let c = dof().mean((31, 33), (23, 25));
            ensure(c[1] > 0.15 && c[1] < 0.45, || format!("{c:.3?}"))
        }),
        row("Camera", "focusDistance", Honoured, "the quad at the focus distance keeps a sharp edge (column 17 the quad's, 14 the ground's)", || {
            let (inside, outside) = (dof().mean((17, 18), (12, 36)), dof().mean((14, 15), (12, 36)));
            ensure(inside[1] > 0.45 && outside[1] < 0.03, || format!("inside {inside:.3?}, outside {outside:.3?}"))
        }),
        row("Camera", "shutter:open, shutter:close", Honoured, "a ball 0.6 across moving 1 unit over an open shutter smears over 6 or more columns (still: 3 or 4)", || {
            let (x, y) = spans(&motion().covered(8, 0, 1, 0.01));
            ensure(x >= 6 && y <= 4, || format!("{x} columns x {y} rows"))
        }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
