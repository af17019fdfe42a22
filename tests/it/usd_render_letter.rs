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
def Scope "Looks"
{{
    def Material "Card"
    {{
        token outputs:surface.connect = </Looks/Card/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.8, 0.3, 0.1)
            {inputs}
            token outputs:surface
        }}
        def Shader "Texture"
        {{
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @leaf.exr@
            token inputs:wrapS = "clamp"
            token inputs:wrapT = "clamp"
            float2 inputs:st.connect = </Looks/Card/St.outputs:result>
            float outputs:r
        }}
        def Shader "St"
        {{
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }}
    }}
}}
"#
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
    format!(
        r#"#usda 1.0
(
    upAxis = "Y"
)
def Camera "Camera"
{{
    double3 xformOp:translate = (0, 0, 8)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Mesh "BehindTheCamera"
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
    )
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
