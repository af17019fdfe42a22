//! USD read to the letter where the renderer had to change (issue 46): the
//! smallest stage that shows each attribute in the pixels, written here in
//! code and judged from the image; bad input judged from its warning.
//! Each test stands alone (its own stage, textures and scratch folder).
//!
//! - UsdPreviewSurface `opacityThreshold` (UsdPreviewSurface specification):
//!   opacity below a positive threshold cuts the surface out for every ray,
//!   at or above it the surface is opaque.
//! - UsdVol `OpenVDBAsset` `fieldClass` (and the VDB's own grid class): a
//!   level set is refused, never read as a density.
//! - UsdLux DomeLight `inputs:texture:format`: `latlong`, `angular` and
//!   `mirroredBall` images of one environment light alike.

use std::path::{Path, PathBuf};

use crate::common;
use crate::common::render::{Image, Render};

/// Renders the stage `usda` (an absolute path) at 64x48 with `spp` samples,
/// seed 1 and `extra` flags: the image and the render's log.
fn render(usda: &Path, spp: u32, extra: &[&str]) -> (Image, String) {
    let dir = usda.parent().unwrap();
    let scene = usda.to_str().unwrap();
    let (log, image) = Render {
        scene,
        res: (64, 48),
        spp,
        seed: 1,
        extra,
    }
    .run_logged(dir);
    (image.unwrap(), log.text)
}

/// Writes `text` as `dir/NAME.usda` and returns its path.
fn write_stage(dir: &Path, name: &str, text: &str) -> PathBuf {
    let usda = dir.join(format!("{name}.usda"));
    std::fs::write(&usda, text).unwrap();
    usda
}

/// How many pixels `(x, y)` accepted by `keep` differ between `a` and `b` by
/// more than `relative` of their larger value (plus 1e-6), in any channel.
fn differing(a: &Image, b: &Image, relative: f32, keep: impl Fn(usize, usize) -> bool) -> usize {
    let mut count = 0;
    for y in 0..a.height {
        for x in (0..a.width).filter(|&x| keep(x, y)) {
            let i = y * a.width + x;
            let far = (0..3).any(|c| {
                let (p, q) = (a.rgb[c][i], b.rgb[c][i]);
                (p - q).abs() > relative * p.abs().max(q.abs()) + 1e-6
            });
            count += usize::from(far);
        }
    }
    count
}

/// A grey floor lit by a distant light from above and behind a vertical
/// card (x and y in [-0.6, 0.6] x [0, 1.2] at z = 0, `st` 0 to 1 from left
/// to right), so the card covers the middle of the image and casts its
/// shadow towards the camera; `card` is the card's material (its
/// UsdPreviewSurface inputs), `None` leaves the card out.
fn cut_out_stage(card: Option<&str>) -> String {
    let card = card.map_or(String::new(), |inputs| {
        let surface = format!("color3f inputs:diffuseColor = (0.8, 0.3, 0.1)\n{inputs}");
        let looks = looks("Card", &surface, LEAF_SHADERS);
        format!(
            r#"
def Mesh "Card" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-0.6, 0, 0), (0.6, 0, 0), (0.6, 1.2, 0), (-0.6, 1.2, 0)]
    texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
    uniform bool doubleSided = 1
    rel material:binding = </Looks/Card>
}}
{looks}"#
        )
    });
    format!(
        r#"#usda 1.0
(
    upAxis = "Y"
)
def Camera "Camera"
{{
    double3 xformOp:translate = (0, 2, 6)
    float xformOp:rotateX = -15
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
}}
def DistantLight "Sun"
{{
    float inputs:intensity = 3
    float xformOp:rotateX = -120
    uniform token[] xformOpOrder = ["xformOp:rotateX"]
}}
def Mesh "Floor"
{{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-5, 0, 5), (5, 0, 5), (5, 0, -5), (-5, 0, -5)]
}}
{card}"#
    )
}

/// The leaf texture's UsdUVTexture (red channel out, clamped, reading
/// `leaf.exr`) and its `st` reader, inside Material `/Looks/Card`.
const LEAF_SHADERS: &str = r#"        def Shader "Texture"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @leaf.exr@
            token inputs:wrapS = "clamp"
            token inputs:wrapT = "clamp"
            float2 inputs:st.connect = </Looks/Card/St.outputs:result>
            float outputs:r
        }
        def Shader "St"
        {
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }
"#;

/// The leaf texture: 8 x 1 texels, red 0 in the left half and 1 in the
/// right (bilinear lookups cross 0.5 at u = 0.5, the card's x = 0).
fn write_leaf_texture(dir: &Path) {
    exr::prelude::write_rgb_file(dir.join("leaf.exr"), 8, 1, |x, _| {
        let r = if x < 4 { 0.0f32 } else { 1.0 };
        (r, r, r)
    })
    .unwrap();
}

/// Opacity 0.3 under threshold 0.5 renders exactly as if the card were not
/// there (camera, shadow and indirect rays pass it); opacity 0.7 over the
/// same threshold exactly as an opaque card (opacity 1), which differs from
/// the empty stage over much of the image (so the comparison can fail).
#[test]
fn opacity_threshold_cuts_out_below_and_is_opaque_above() {
    let dir = common::scratch("usd_render_letter_opacity_threshold");
    write_leaf_texture(&dir);
    let stage = |name: &str, card: Option<&str>| {
        let usda = write_stage(&dir, name, &cut_out_stage(card));
        render(&usda, 8, &[]).0
    };
    let empty = stage("empty", None);
    let cut = stage(
        "cut",
        Some("float inputs:opacity = 0.3\n float inputs:opacityThreshold = 0.5"),
    );
    let masked_opaque = stage(
        "masked_opaque",
        Some("float inputs:opacity = 0.7\n float inputs:opacityThreshold = 0.5"),
    );
    let opaque = stage("opaque", Some("float inputs:opacity = 1"));
    let all = |_, _| true;
    let covered = differing(&opaque, &empty, 0.05, all);
    assert!(
        covered > 300,
        "the card changes only {covered} pixels: the stage does not show it"
    );
    let seen = differing(&cut, &empty, 1e-4, all);
    assert_eq!(seen, 0, "{seen} pixels see a cut-out card");
    let unlike = differing(&masked_opaque, &opaque, 1e-4, all);
    assert_eq!(
        unlike, 0,
        "{unlike} pixels: opacity over the threshold is not opaque"
    );
}

/// A textured opacity cuts per texel: the left half of the card (opacity
/// 0 under threshold 0.5) renders as the empty stage, the right half
/// (opacity 1) as the opaque card, column by column away from the seam
/// (direct light only, so no light crosses from one half to the other;
/// the light shines in the y-z plane, so each half's shadow stays on its
/// side of the image's middle column).
#[test]
fn opacity_threshold_cuts_a_textured_leaf_per_texel() {
    let dir = common::scratch("usd_render_letter_textured_leaf");
    write_leaf_texture(&dir);
    let stage = |name: &str, card: Option<&str>| {
        let usda = write_stage(&dir, name, &cut_out_stage(card));
        render(&usda, 4, &["--max-depth", "1"]).0
    };
    let empty = stage("leaf_empty", None);
    let opaque = stage("leaf_opaque", Some("float inputs:opacity = 1"));
    let leaf = stage(
        "leaf",
        Some(
            "float inputs:opacity.connect = </Looks/Card/Texture.outputs:r>\n \
             float inputs:opacityThreshold = 0.5",
        ),
    );
    let left = |x: usize, _| x < 30;
    let right = |x: usize, _| x > 33;
    assert!(differing(&opaque, &empty, 0.05, left) > 100);
    assert!(differing(&opaque, &empty, 0.05, right) > 100);
    assert_eq!(
        differing(&leaf, &empty, 1e-4, left),
        0,
        "the cut half is seen"
    );
    assert_eq!(
        differing(&leaf, &opaque, 1e-4, right),
        0,
        "the kept half is not opaque"
    );
}

/// An `opacityThreshold` outside [0, 1] is clamped, with a warning naming
/// the material: 1.5 reads as 1 (opacity 0.7 under it is cut out).
#[test]
fn opacity_threshold_outside_0_1_is_clamped_and_warned() {
    let dir = common::scratch("usd_render_letter_opacity_threshold_range");
    write_leaf_texture(&dir);
    let empty = render(
        &write_stage(&dir, "range_empty", &cut_out_stage(None)),
        4,
        &[],
    )
    .0;
    let usda = write_stage(
        &dir,
        "range",
        &cut_out_stage(Some(
            "float inputs:opacity = 0.7\n float inputs:opacityThreshold = 1.5",
        )),
    );
    let (image, log) = render(&usda, 4, &[]);
    assert!(
        log.contains(
            "material /Looks/Card: inputs:opacityThreshold 1.5 is outside [0, 1]; 1.0 used"
        ),
        "{log}"
    );
    assert_eq!(differing(&image, &empty, 1e-4, |_, _| true), 0);
}

/// Writes `dir/NAME.vdb` with Debian's pyopenvdb: a grid called `density`,
/// either OpenVDB's level-set sphere of radius 1 (voxel 0.1, class "level
/// set": negative inside, positive in its narrow band outside) or a fog box
/// of density 5 over the same region (class unset).
fn write_vdb(dir: &Path, name: &str, level_set: bool) -> PathBuf {
    let vdb = dir.join(format!("{name}.vdb"));
    let grid = if level_set {
        "g = vdb.createLevelSetSphere(radius=1.0, center=(0, 0, 0), voxelSize=0.1, halfWidth=3.0)"
    } else {
        "g = vdb.FloatGrid()\ng.fill((-10, -10, -10), (10, 10, 10), 5.0)\n\
         g.transform = vdb.createLinearTransform(voxelSize=0.1)"
    };
    let script = format!(
        "import sys\nimport pyopenvdb as vdb\n{grid}\ng.name = 'density'\nvdb.write(sys.argv[1], grids=[g])\n"
    );
    let py = dir.join(format!("{name}.py"));
    std::fs::write(&py, script).unwrap();
    common::run_python(
        Path::new(common::SYSTEM_PYTHON),
        &py,
        &[vdb.to_str().unwrap()],
    );
    vdb
}

/// A Volume at the origin with one density field from `vdb`, `field_class`
/// authored on its OpenVDBAsset when given, black (albedo 0), before the
/// camera; no lights, so the white dome of radiance 1 shows behind it (a
/// triangle behind the camera keeps the stage from being empty when the
/// volume is skipped).
fn volume_stage(vdb: &Path, field_class: Option<&str>) -> String {
    let class = field_class.map_or(String::new(), |c| format!("token fieldClass = \"{c}\""));
    let body = format!(
        r#"def Mesh "BehindTheCamera"
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 20), (1, 0, 20), (0, 1, 20)]
}}
def Volume "Cloud"
{{
    color3f primvars:albedo = (0, 0, 0) (interpolation = "constant")
    rel field:density = </Cloud/Density>
    def OpenVDBAsset "Density"
    {{
        asset filePath = @{}@
        token fieldName = "density"
        {class}
    }}
}}
"#,
        vdb.display()
    );
    camera_on_z(8.0, &body)
}

/// A level-set grid is never read as a density: refused by its VDB grid
/// class or by `fieldClass = "levelSet"`, each with a warning naming field
/// and prim; the volume, left without density, is not rendered (every pixel
/// is the dome's radiance 1). The same fog box without the class is seen
/// (so the stage shows a volume where there is one).
#[test]
fn level_set_fields_are_refused_naming_field_and_prim() {
    let dir = common::scratch("usd_render_letter_level_set");
    let sphere = write_vdb(&dir, "sphere", true);
    let fog = write_vdb(&dir, "fog", false);
    let cases = [
        (
            "by_grid_class",
            &sphere,
            None,
            "its VDB grid class is level set",
        ),
        (
            "by_field_class",
            &fog,
            Some("levelSet"),
            "fieldClass levelSet",
        ),
    ];
    for (name, vdb, class, why) in cases {
        let usda = write_stage(&dir, name, &volume_stage(vdb, class));
        let (image, log) = render(&usda, 2, &[]);
        let warning = format!(
            "volume /Cloud: field /Cloud/Density is a level set ({why}): a signed distance, \
             not a density; field refused"
        );
        assert!(log.contains(&warning), "{name}: {log}");
        let lit = image
            .rgb
            .iter()
            .flatten()
            .filter(|&&v| (v - 1.0).abs() > 1e-5);
        assert_eq!(lit.count(), 0, "{name}: the refused field is rendered");
    }
    let usda = write_stage(&dir, "fog_box", &volume_stage(&fog, Some("fogVolume")));
    let (image, log) = render(&usda, 2, &[]);
    assert!(!log.contains("level set"), "{log}");
    let dark = image.rgb[0].iter().filter(|&&v| v < 0.5).count();
    assert!(dark > 100, "the fog box darkens only {dark} pixels");
}

/// The environment the dome tests light with: linear in the direction `d`
/// (light space), so brighter towards +X, +Y and +Z by different amounts
/// per channel, and smooth, so resampling it changes little.
fn environment(d: [f32; 3]) -> (f32, f32, f32) {
    (0.5 + 0.4 * d[0], 0.5 + 0.25 * d[1], 0.5 + 0.15 * d[2])
}

/// The light-space direction at image point `(u, v)` (from the top left)
/// of a dome image in `format`, as docs/usd-support.md and the UsdLux
/// DomeLight documentation give them; `None` outside a disk mapping's disk.
fn dome_direction(format: &str, u: f32, v: f32) -> Option<[f32; 3]> {
    use std::f32::consts::PI;
    if format == "latlong" {
        let (lon, theta) = (PI * (1.0 - 2.0 * u), PI * v);
        return Some([
            theta.sin() * lon.sin(),
            theta.cos(),
            theta.sin() * lon.cos(),
        ]);
    }
    let (a, b) = (2.0 * u - 1.0, 1.0 - 2.0 * v);
    let r = a.hypot(b);
    if r > 1.0 {
        return None;
    }
    let theta = if format == "angular" {
        PI * r
    } else {
        2.0 * r.asin()
    };
    let s = if r > 0.0 { theta.sin() / r } else { 0.0 };
    Some([-a * s, b * s, theta.cos()])
}

/// Writes [`environment`] as a `w` x `h` dome image in `format` (texel
/// centres), black outside a disk mapping's disk, left and right swapped
/// when `mirrored`: `dir/NAME.exr`.
fn write_dome(
    dir: &Path,
    name: &str,
    format: &str,
    (w, h): (usize, usize),
    mirrored: bool,
) -> PathBuf {
    let exr = dir.join(format!("{name}.exr"));
    exr::prelude::write_rgb_file(&exr, w, h, |x, y| {
        let x = if mirrored { w - 1 - x } else { x };
        let (u, v) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
        dome_direction(format, u, v).map_or((0.0, 0.0, 0.0), environment)
    })
    .unwrap();
    exr
}

/// A grey sphere of radius 1 filling the view of a camera 3 units away
/// along +Z, lit only by a dome with image `exr` in the USD `format`.
fn dome_stage(exr: &Path, format: &str) -> String {
    let surface = "color3f inputs:diffuseColor = (0.7, 0.7, 0.7)\nfloat inputs:roughness = 0.6";
    let looks = looks("Grey", surface, "");
    let body = format!(
        r#"def DomeLight "Sky"
{{
    asset inputs:texture:file = @{}@
    token inputs:texture:format = "{format}"
}}
def Sphere "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    double radius = 1
    rel material:binding = </Looks/Grey>
}}
{looks}"#,
        exr.display()
    );
    camera_on_z(3.0, &body)
}

/// A Y-up layer: a camera at `(0, 0, z)` looking down -Z, then `body`.
fn camera_on_z(z: f32, body: &str) -> String {
    format!(
        "#usda 1.0\n(\n    upAxis = \"Y\"\n)\ndef Camera \"Camera\"\n{{\n    \
         double3 xformOp:translate = (0, 0, {z})\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}}\n{body}"
    )
}

/// Asserts that `a` and `b` agree within 4 sigma plus `bound` (relative to
/// `a`'s mean), in the red channel (the one that varies with x): over the
/// whole image and over each quarter of its columns (a mirrored or turned
/// mapping moves light from one side to the other). The pixel differences
/// carry only the two renders' noise, so their mean and its standard error
/// decide.
fn assert_images_agree(what: &str, a: &Image, b: &Image, bound: f64) {
    let mean_a = common::estimate(a.pixels(0, |_, _| true)).mean;
    let bands = [(0, a.width), (0, 16), (16, 32), (32, 48), (48, 64)];
    for (lo, hi) in bands {
        let keep = |x: usize, _| (lo..hi).contains(&x);
        let diffs = a
            .pixels(0, keep)
            .into_iter()
            .zip(b.pixels(0, keep))
            .map(|(p, q)| p - q);
        let d = common::estimate(diffs);
        let tolerance = 4.0 * d.sigma + bound * mean_a;
        eprintln!(
            "{what}, columns {lo}..{hi}: difference {:.5} +- {:.5}",
            d.mean, d.sigma
        );
        assert!(
            d.mean.abs() <= tolerance,
            "{what}, columns {lo}..{hi}: mean difference {:.5} beyond {tolerance:.5}",
            d.mean
        );
    }
}

/// The same environment as a lat-long, an angular and a mirrored-ball image
/// lights the sphere alike (within 4 sigma and 0.5% for resampling: the
/// environment is smooth and each image samples it at its texel centres);
/// the angular image mirrored left to right does not (so the test can fail).
#[test]
fn dome_texture_formats_map_one_environment_alike() {
    let dir = common::scratch("usd_render_letter_dome_formats");
    let render_dome = |name: &str, format: &str, exr: &Path, extra: &[&str]| {
        let usda = write_stage(&dir, name, &dome_stage(exr, format));
        let (image, log) = render(&usda, 16, extra);
        assert!(!log.contains("texture:format"), "{name}: {log}");
        image
    };
    let latlong = write_dome(&dir, "sky_latlong", "latlong", (256, 128), false);
    let reference = render_dome("latlong", "latlong", &latlong, &[]);
    for format in ["angular", "mirroredBall"] {
        let exr = write_dome(&dir, &format!("sky_{format}"), format, (256, 256), false);
        let image = render_dome(format, format, &exr, &[]);
        assert_images_agree(
            &format!("{format} against latlong"),
            &reference,
            &image,
            0.005,
        );
    }
    let mirrored = write_dome(&dir, "sky_mirrored", "angular", (256, 256), true);
    let misread = render_dome("mirrored", "angular", &mirrored, &[]);
    let keep = |x: usize, _| x < 16;
    let gap = common::estimate(reference.pixels(0, keep)).mean
        - common::estimate(misread.pixels(0, keep)).mean;
    assert!(
        gap.abs() > 0.02,
        "a mirrored angular image renders alike ({gap})"
    );
}

/// For the angular and mirrored-ball mappings, light sampling alone and
/// BSDF sampling alone render the same image (within 4 sigma): the
/// importance map's density and the lookup agree, Jacobian included.
#[test]
fn dome_disk_formats_agree_between_light_and_bsdf_sampling() {
    let dir = common::scratch("usd_render_letter_dome_strategies");
    for format in ["angular", "mirroredBall"] {
        let exr = write_dome(&dir, &format!("sky_{format}"), format, (128, 128), false);
        let by = |strategy: &str| {
            let name = format!("{format}_{strategy}");
            let usda = write_stage(&dir, &name, &dome_stage(&exr, format));
            render(&usda, 32, &["--strategy", strategy]).0
        };
        assert_images_agree(
            &format!("{format}: nee against bsdf"),
            &by("nee"),
            &by("bsdf"),
            0.0,
        );
    }
}

/// An angular or mirrored-ball texture that is not square is warned about,
/// naming the light, the file and its size.
#[test]
fn dome_texture_not_matching_its_format_is_warned() {
    let dir = common::scratch("usd_render_letter_dome_aspect");
    let exr = write_dome(&dir, "wide", "latlong", (64, 32), false);
    for format in ["angular", "mirroredBall"] {
        let usda = write_stage(&dir, format, &dome_stage(&exr, format));
        let (_, log) = render(&usda, 1, &[]);
        let warning = format!(
            "light /Sky: texture {} is 64x32, not square ({format})",
            exr.display()
        );
        assert!(log.contains(&warning), "{format}: {log}");
    }
}

/// A `Scope "Looks"` holding Material `/Looks/NAME`, its UsdPreviewSurface
/// `Surface` with the input lines `inputs`, then the Shader prims `shaders`.
fn looks(name: &str, inputs: &str, shaders: &str) -> String {
    format!(
        "def Scope \"Looks\"\n{{\ndef Material \"{name}\"\n{{\n\
         token outputs:surface.connect = </Looks/{name}/Surface.outputs:surface>\n\
         def Shader \"Surface\"\n{{\nuniform token info:id = \"UsdPreviewSurface\"\n\
         {inputs}\ntoken outputs:surface\n}}\n{shaders}}}\n}}\n"
    )
}
