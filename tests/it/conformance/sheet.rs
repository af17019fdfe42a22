//! The conformance suite's stages and what it measures in them: a sheet of
//! cells side by side on the XY plane (Z up), seen straight down by an
//! orthographic camera over 16 x 12 units at 64 x 48 pixels, each cell a
//! square of `16 / cols` units whose contents are authored in a local
//! [-1, 1] square; rendered once per process (box filter, fixed seed, one
//! thread) and kept with its log for the rows that share it.

use crate::common;
use crate::common::render::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Image size in pixels: every sheet's.
pub const RES: (u32, u32) = (64, 48);

/// A finished render: its image and its log (the exporter's warnings too).
pub struct Shot {
    /// The beauty.
    pub image: Image,
    /// stderr of `cirrus render`.
    pub log: String,
    /// The folder it was rendered in.
    pub dir: PathBuf,
}

/// How a sheet is lit.
#[derive(Clone, Copy)]
pub enum Lighting {
    /// A white dome of radiance 1 and, 1 unit below the cells, a ground that
    /// only emits red radiance 1: what no cell covers reads (1, 0, 0).
    Dome,
    /// A distant light of irradiance pi on a facing surface (normalize),
    /// arriving from +X tilted 30 degrees from straight down, nothing else:
    /// a white Lambert cell reads cos 30 = 0.866, the background 0.
    Sun,
}

/// A stage of `cols` columns of cells (`cols` divides 64 and 0.75 `cols`
/// rows fit 48): `cells[k]` is the usda of cell k (row-major from the top
/// left), where `$CELL` stands for the cell's prim path. `extra` is
/// appended at the root (materials, render settings).
pub fn sheet(cols: usize, lighting: Lighting, cells: &[String], extra: &str) -> String {
    let size = 16.0 / cols as f64;
    let mut body = String::new();
    for (k, cell) in cells.iter().enumerate() {
        let (i, j) = (k % cols, k / cols);
        let x = -8.0 + size * (i as f64 + 0.5);
        let y = 6.0 - size * (j as f64 + 0.5);
        let path = format!("/Sheet/C{k}");
        body.push_str(&format!(
            "    def Xform \"C{k}\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n    {{\n        \
             double3 xformOp:translate = ({x}, {y}, 0)\n        double3 xformOp:scale = ({s}, {s}, {s})\n        \
             uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:scale\"]\n{}\n    }}\n",
            cell.replace("$CELL", &path),
            s = size / 2.0
        ));
    }
    format!(
        "{}{}\n{}\ndef Xform \"Sheet\"\n{{\n{body}}}\n\n{extra}\n",
        HEADER,
        top_camera("Camera", ""),
        lights(lighting)
    )
}

/// A Z-up layer's header; frames 0..1 for the stages that move.
pub const HEADER: &str = "#usda 1.0\n(\n    upAxis = \"Z\"\n    metersPerUnit = 1\n    startTimeCode = 0\n    endTimeCode = 1\n)\n\n";

/// The usda of `lighting`.
pub fn lights(lighting: Lighting) -> String {
    match lighting {
        Lighting::Dome => format!(
            "def DomeLight \"Sky\"\n{{\n}}\n\ndef Mesh \"Ground\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    \
             point3f[] points = [(-40, -40, -1), (40, -40, -1), (40, 40, -1), (-40, 40, -1)]\n    \
             int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    \
             rel material:binding = </GroundLook>\n}}\n\n{}",
            material("GroundLook", EMITTER_RED)
        ),
        Lighting::Sun => "def DistantLight \"Sun\"\n{\n    float xformOp:rotateY = 30\n    \
             uniform token[] xformOpOrder = [\"xformOp:rotateY\"]\n    float inputs:intensity = 3.14159265\n    \
             bool inputs:normalize = 1\n}\n"
            .to_owned(),
    }
}

/// The inputs of a black, non-reflecting UsdPreviewSurface emitting red 1.
const EMITTER_RED: &str = "color3f inputs:diffuseColor = (0, 0, 0)\n\
     int inputs:useSpecularWorkflow = 1\ncolor3f inputs:specularColor = (0, 0, 0)\n\
     color3f inputs:emissiveColor = (1, 0, 0)";

/// The inputs of a pure Lambert UsdPreviewSurface of albedo `rgb` (the
/// specular workflow with a black specularColor reflects nothing else).
pub fn lambert(rgb: (f64, f64, f64)) -> String {
    format!(
        "color3f inputs:diffuseColor = ({}, {}, {})\nint inputs:useSpecularWorkflow = 1\n\
         color3f inputs:specularColor = (0, 0, 0)",
        rgb.0, rgb.1, rgb.2
    )
}

/// An orthographic camera at z = 10 looking down -Z over 16 x 12 units,
/// with `extra` attribute lines.
pub fn top_camera(name: &str, extra: &str) -> String {
    format!(
        "def Camera \"{name}\"\n{{\n    double3 xformOp:translate = (0, 0, 10)\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    token projection = \"orthographic\"\n    \
         float horizontalAperture = 160\n    float verticalAperture = 120\n    \
         float2 clippingRange = (0.1, 100)\n{extra}\n}}\n"
    )
}

/// A Material `name` (a root prim unless `name` is a path) whose
/// UsdPreviewSurface has the input lines `inputs` (and any child shaders
/// in `nodes`).
pub fn material_with(name: &str, inputs: &str, nodes: &str) -> String {
    let path = if name.starts_with('/') || name.starts_with('$') {
        name.to_owned()
    } else {
        format!("/{name}")
    };
    let leaf = path.rsplit('/').next().unwrap();
    format!(
        "def Material \"{leaf}\"\n{{\n    token outputs:surface.connect = <{path}/Surface.outputs:surface>\n    \
         def Shader \"Surface\"\n    {{\n        uniform token info:id = \"UsdPreviewSurface\"\n        {}\n        \
         token outputs:surface\n    }}\n{nodes}\n}}\n",
        inputs.replace('\n', "\n        ")
    )
}

/// [`material_with`] without extra shaders.
pub fn material(name: &str, inputs: &str) -> String {
    material_with(name, inputs, "")
}

/// A flat square quad of half-size 0.8 facing +Z, named `name`, with
/// texture coordinates `st` 0..1 across it (vertex), bound to the material
/// at `binding` (none when empty), with `extra` attribute lines.
pub fn quad(name: &str, binding: &str, extra: &str) -> String {
    let bind = if binding.is_empty() {
        String::new()
    } else {
        format!("rel material:binding = <{binding}>")
    };
    format!(
        "def Mesh \"{name}\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    \
         uniform token subdivisionScheme = \"none\"\n    point3f[] points = [(-0.8, -0.8, 0), (0.8, -0.8, 0), (0.8, 0.8, 0), (-0.8, 0.8, 0)]\n    \
         int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    \
         texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = \"vertex\")\n    \
         {bind}\n    {}\n}}\n",
        extra.replace('\n', "\n    ")
    )
}

/// A quad bound to its own material `Look` (a child of the cell) with the
/// UsdPreviewSurface inputs `inputs`.
pub fn tile(inputs: &str) -> String {
    format!(
        "{}\n{}",
        quad("Tile", "$CELL/Look", ""),
        material("$CELL/Look", inputs)
    )
}

/// Renders `usda` (written as `stage.usda` in the scratch folder `name`,
/// after `prepare` has written any files it reads there) with `spp`
/// samples per pixel and `args`; `res` is the size to expect (the CLI's
/// `--res` in `args`, or the stage's render settings); panics with the log
/// when it fails.
pub fn render(
    name: &str,
    usda: &str,
    settings: (u32, &[&str], (u32, u32)),
    prepare: impl FnOnce(&Path),
) -> Shot {
    try_render(name, usda, settings, prepare).unwrap_or_else(|e| panic!("{e}"))
}

/// [`render`], its failure (a crash included) an error with the log.
pub fn try_render(
    name: &str,
    usda: &str,
    (spp, args, res): (u32, &[&str], (u32, u32)),
    prepare: impl FnOnce(&Path),
) -> Result<Shot, String> {
    let dir = common::scratch(&format!("conformance_{name}"));
    prepare(&dir);
    let stage = dir.join("stage.usda");
    std::fs::write(&stage, usda).unwrap();
    // With --settings the stage's product writes out.exr, its vars its layers.
    let settings = args.contains(&"--settings");
    let exr = dir.join("out.exr");
    let output = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .current_dir(&dir)
        .arg("render")
        .arg(&stage)
        .args(if settings {
            &[][..]
        } else {
            &["-o", "out.exr", "--aovs", "beauty"]
        })
        .args([
            "--spp",
            &spp.to_string(),
            "--seed",
            "1",
            "--filter",
            "box",
            "--threads",
            "1",
        ])
        .args(args)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&output.stderr).into_owned();
    if !output.status.success() {
        return Err(format!("{name}: cirrus render failed:\n{log}"));
    }
    Ok(Shot {
        image: Image::read(&exr, res),
        log,
        dir,
    })
}

/// [`render`] at 64 x 48 (the CLI's `--res`), with no files to prepare.
pub fn render_sheet(name: &str, usda: &str, spp: u32) -> Shot {
    render(name, usda, (spp, &["--res", "64x48"], RES), |_| {})
}

/// Writes a `w` x `h` float RGB EXR at `path`, texel (x, y) from `texel`
/// (y = 0 the top row).
pub fn write_texture(
    path: &Path,
    (w, h): (usize, usize),
    texel: impl Fn(usize, usize) -> [f32; 3] + Sync,
) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let [r, g, b] = texel(x, y);
        (r, g, b)
    })
    .unwrap();
}

/// An RGB mean.
pub type Rgb = [f64; 3];

impl Shot {
    /// The mean of the pixels `(x, y)` in `[x0, x1) x [y0, y1)`.
    pub fn mean(&self, (x0, x1): (usize, usize), (y0, y1): (usize, usize)) -> Rgb {
        [0, 1, 2].map(|c| {
            let v = self
                .image
                .pixels(c, |x, y| (x0..x1).contains(&x) && (y0..y1).contains(&y));
            v.iter().sum::<f64>() / v.len() as f64
        })
    }

    /// Pixel bounds of cell `k` of a `cols`-column sheet.
    pub fn cell_bounds(cols: usize, k: usize) -> ((usize, usize), (usize, usize)) {
        let px = 64 / cols;
        let (i, j) = (k % cols, k / cols);
        ((i * px, (i + 1) * px), (j * px, (j + 1) * px))
    }

    /// The mean of the middle half (each way) of cell `k`.
    pub fn cell(&self, cols: usize, k: usize) -> Rgb {
        self.part(cols, k, (0.25, 0.75), (0.25, 0.75))
    }

    /// The mean of the part of cell `k` between the fractions `u` (left to
    /// right) and `v` (bottom to top) of the quad of [`quad`] (which spans
    /// 0.1..0.9 of the cell), rounded outwards to whole pixels.
    pub fn part(&self, cols: usize, k: usize, u: (f64, f64), v: (f64, f64)) -> Rgb {
        let ((x0, _), (y0, _)) = Self::cell_bounds(cols, k);
        let px = (64 / cols) as f64;
        let at = |f: f64| 0.1 + 0.8 * f;
        let xs = (
            x0 + (px * at(u.0)).round() as usize,
            x0 + (px * at(u.1)).round() as usize,
        );
        let ys = (
            y0 + (px * (1.0 - at(v.1))).round() as usize,
            y0 + (px * (1.0 - at(v.0))).round() as usize,
        );
        self.mean(xs, (ys.0, ys.1.max(ys.0 + 1)))
    }

    /// The pixels of cell `k` (columns, rows relative to the cell) whose
    /// channel `c` exceeds `above`.
    pub fn covered(&self, cols: usize, k: usize, c: usize, above: f64) -> Vec<(usize, usize)> {
        let ((x0, x1), (y0, y1)) = Self::cell_bounds(cols, k);
        let w = self.image.width;
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| f64::from(self.image.rgb[c][y * w + x]) > above)
            .map(|(x, y)| (x - x0, y - y0))
            .collect()
    }

    /// Ok when a log line has every fragment (a warning naming prim and
    /// attribute), else the warnings there are.
    pub fn warned(&self, fragments: &[&str]) -> Result<(), String> {
        if self
            .log
            .lines()
            .any(|l| fragments.iter().all(|f| l.contains(f)))
        {
            return Ok(());
        }
        let warnings: Vec<&str> = self.log.lines().filter(|l| l.contains("warn")).collect();
        Err(format!("no warning with {fragments:?} among {warnings:?}"))
    }
}

/// Ok when `what` holds, else `message`.
pub fn ensure(what: bool, message: impl FnOnce() -> String) -> Result<(), String> {
    if what {
        Ok(())
    } else {
        Err(message())
    }
}

/// Ok when every channel of `measured` is within `relative` of `expected`'s
/// brightest channel (and within 0.01 absolute) of `expected`'s.
pub fn near(what: &str, measured: Rgb, expected: Rgb, relative: f64) -> Result<(), String> {
    let scale = expected.iter().fold(0.0f64, |a, e| a.max(e.abs()));
    let fits = measured
        .iter()
        .zip(expected)
        .all(|(m, e)| (m - e).abs() <= (relative * scale).max(0.01));
    ensure(fits, || {
        format!("{what}: measured {measured:.3?}, expected {expected:.3?} within {relative}")
    })
}

/// Column and row extents (in pixels) of a set of covered pixels.
pub fn spans(pixels: &[(usize, usize)]) -> (usize, usize) {
    let span = |f: fn(&(usize, usize)) -> usize| {
        let v: Vec<usize> = pixels.iter().map(f).collect();
        match (v.iter().min(), v.iter().max()) {
            (Some(a), Some(b)) => b - a + 1,
            _ => 0,
        }
    };
    (span(|p| p.0), span(|p| p.1))
}

/// The mean column of a set of covered pixels (NaN when empty).
pub fn centroid_x(pixels: &[(usize, usize)]) -> f64 {
    pixels.iter().map(|p| p.0 as f64 + 0.5).sum::<f64>() / pixels.len() as f64
}

/// Renders once per process: `static NAME: OnceLock<Shot>` initialised by
/// `make` on first use.
pub fn once(
    cache: &'static std::sync::OnceLock<Shot>,
    make: impl FnOnce() -> Shot,
) -> &'static Shot {
    cache.get_or_init(make)
}
