//! USD to the letter (issue 46): authored features the exporter used to drop
//! silently, each on the smallest stage that shows it, written here in code
//! and judged from the pixels or from the exported manifest. Each test stands
//! alone, so the conformance suite can take them over one by one.

use std::path::{Path, PathBuf};

use crate::common;
use crate::common::render::{Image, Render, RenderLog};

/// A Y-up stage in metres: `body` after the layer header, with `metadata`
/// (e.g. `renderSettingsPrimPath`) inside its parentheses.
fn stage(metadata: &str, body: &str) -> String {
    format!("#usda 1.0\n(\n    upAxis = \"Y\"\n    metersPerUnit = 1\n{metadata}\n)\n{body}\n")
}

/// An orthographic camera at `/Cam`, 5 units up +Z looking down -Z, viewing
/// `width` x `height` scene units (10 pixels per unit at the test's
/// resolutions), with further `attributes`.
fn camera(width: f32, height: f32, attributes: &str) -> String {
    format!(
        "def Camera \"Cam\" {{\n token projection = \"orthographic\"\n float horizontalAperture = {}\n \
         float verticalAperture = {}\n double3 xformOp:translate = (0, 0, 5)\n \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n{attributes}\n}}\n",
        width * 10.0,
        height * 10.0
    )
}

/// A UsdPreviewSurface material `/Looks/NAME` emitting `rgb` (radiance,
/// W/m2/sr) with a black diffuse: seen under [`DARK`], pixels are `rgb`.
fn emitter(name: &str, rgb: &str) -> String {
    format!(
        "def Material \"{name}\" {{\n token outputs:surface.connect = </Looks/{name}/S.outputs:surface>\n \
         def Shader \"S\" {{\n uniform token info:id = \"UsdPreviewSurface\"\n \
         color3f inputs:diffuseColor = (0, 0, 0)\n color3f inputs:emissiveColor = {rgb}\n \
         token outputs:surface\n }}\n}}\n"
    )
}

/// A dome of radiance 0: a light, so no default white dome lights the stage.
const DARK: &str = "def DomeLight \"Dark\" {\n float inputs:intensity = 0\n}\n";

/// `text` written to a fresh scratch folder `name` as `stage.usda`.
fn write(name: &str, text: &str) -> PathBuf {
    let dir = common::scratch(name);
    let usda = dir.join("stage.usda");
    std::fs::write(&usda, text).unwrap();
    usda
}

/// `usda` rendered at `res`, 4 spp, seed 1, box filter, into its folder:
/// the log and the image.
fn render(usda: &Path, res: (u32, u32), extra: &[&str]) -> (RenderLog, Image) {
    let render = Render {
        scene: usda.to_str().unwrap(),
        res,
        spp: 4,
        seed: 1,
        extra,
    };
    let (log, image) = render.run_logged(usda.parent().unwrap());
    (log, image.expect("a whole image"))
}

/// The manifest of `text` exported by `cirrus export` in scratch folder `name`.
fn manifest(name: &str, text: &str) -> serde_json::Value {
    let out = common::export_usda(&common::scratch(name), text);
    let json = std::fs::read_to_string(out.join("scene.json")).unwrap();
    serde_json::from_str(&json).unwrap()
}

/// The manifest's warnings, one string.
fn warnings(manifest: &serde_json::Value) -> String {
    manifest["warnings"].to_string()
}

/// The `path` of every record of the manifest list `key`.
fn paths(manifest: &serde_json::Value, key: &str) -> Vec<String> {
    let records = manifest[key].as_array().unwrap();
    records
        .iter()
        .map(|r| r["path"].as_str().unwrap().to_owned())
        .collect()
}

/// The (x, y) of the pixels whose red exceeds one half.
fn lit(image: &Image) -> Vec<(usize, usize)> {
    (0..image.height)
        .flat_map(|y| (0..image.width).map(move |x| (x, y)))
        .filter(|&(x, y)| image.rgb[0][y * image.width + x] > 0.5)
        .collect()
}

/// A `UsdGeomPlane` renders as the schema defines it: `width` x `length`
/// about the origin, for axis X along z and y (here 2 x 1 units, turned by
/// 90 degrees about y so width runs along the image's x: 20 x 10 pixels,
/// nothing else lit), where it used to render nothing (and `cirrus info`
/// counts it as a mesh).
#[test]
fn plane_renders_width_by_length_across_its_axis() {
    let body = format!(
        "{}{DARK}def Scope \"Looks\" {{\n{}}}\n\
         def Plane \"Card\" (\n prepend apiSchemas = [\"MaterialBindingAPI\"]\n) {{\n double width = 2\n \
         double length = 1\n uniform token axis = \"X\"\n float3[] extent = [(0, -0.5, -1), (0, 0.5, 1)]\n \
         float xformOp:rotateY = 90\n uniform token[] xformOpOrder = [\"xformOp:rotateY\"]\n \
         rel material:binding = </Looks/Glow>\n}}\n",
        camera(4.0, 4.0, ""),
        emitter("Glow", "(1, 1, 1)")
    );
    let usda = write("usd_letter_plane", &stage("", &body));
    let info = common::cirrus_ok(&["info".as_ref(), usda.as_os_str()]);
    assert!(
        info.contains("  meshes       1\n"),
        "cirrus info counts the plane:\n{info}"
    );
    let (_, image) = render(&usda, (40, 40), &[]);
    let lit = lit(&image);
    let columns = lit.iter().map(|p| p.0);
    let rows = lit.iter().map(|p| p.1);
    let span = |v: Vec<usize>| (v.iter().min().copied(), v.iter().max().copied());
    assert_eq!(
        lit.len(),
        200,
        "lit pixels of a 2 x 1 plane at 10 px per unit"
    );
    assert_eq!(
        span(columns.collect()),
        (Some(10), Some(29)),
        "columns: width 2 along x"
    );
    assert_eq!(
        span(rows.collect()),
        (Some(15), Some(24)),
        "rows: length 1 along y"
    );
}

/// A PointInstancer's instances of an inactive prototype are not exported
/// (they used to render); the active prototype's are.
#[test]
fn inactive_prototype_instances_are_not_rendered() {
    let body = "def PointInstancer \"Scatter\" {\n point3f[] positions = [(0, 0, 0), (3, 0, 0), (6, 0, 0)]\n \
                int[] protoIndices = [0, 1, 1]\n rel prototypes = [</Scatter/Protos/On>, </Scatter/Protos/Off>]\n \
                def Scope \"Protos\" {\n def Cube \"On\" {}\n def Cube \"Off\" ( active = false ) {}\n }\n}\n";
    let manifest = manifest("usd_letter_inactive_prototype", &stage("", body));
    assert_eq!(manifest["instances"]["count"], 1, "{manifest}");
    assert_eq!(paths(&manifest, "meshes"), ["/Scatter/Protos/On"]);
}

/// Three cubes with purposes default, render and proxy, exported with
/// `settings` (a RenderSettings body, or none): the mesh paths exported.
fn purpose_meshes(name: &str, settings: Option<&str>) -> (Vec<String>, String) {
    let cubes =
        "def Cube \"Plain\" {}\ndef Cube \"Full\" {\n uniform token purpose = \"render\"\n}\n\
                 def Cube \"Stand\" {\n uniform token purpose = \"proxy\"\n}\n";
    let text = match settings {
        Some(settings) => stage(
            "    renderSettingsPrimPath = \"/Settings\"",
            &format!("{cubes}def RenderSettings \"Settings\" {{\n{settings}\n}}\n"),
        ),
        None => stage("", cubes),
    };
    let manifest = manifest(name, &text);
    (paths(&manifest, "meshes"), warnings(&manifest))
}

/// `includedPurposes` decides which purposes render: by default (and
/// with no settings) default and render geometry; a proxy render
/// (`["default", "proxy"]`) shows the proxy and not the render geometry.
#[test]
fn included_purposes_choose_proxy_or_render_geometry() {
    let (meshes, _) = purpose_meshes("usd_letter_purposes_none", None);
    assert_eq!(meshes, ["/Plain", "/Full"]);
    let (meshes, _) = purpose_meshes("usd_letter_purposes_fallback", Some(""));
    assert_eq!(meshes, ["/Plain", "/Full"]);
    let proxy = "uniform token[] includedPurposes = [\"default\", \"proxy\"]";
    let (meshes, _) = purpose_meshes("usd_letter_purposes_proxy", Some(proxy));
    assert_eq!(meshes, ["/Plain", "/Stand"]);
}

/// An `includedPurposes` token that is no purpose is warned about, naming
/// the settings and attribute, and ignored.
#[test]
fn unknown_included_purpose_is_warned_and_ignored() {
    let settings = "uniform token[] includedPurposes = [\"render\", \"finals\"]";
    let (meshes, warnings) = purpose_meshes("usd_letter_purposes_unknown", Some(settings));
    assert_eq!(meshes, ["/Full"]);
    assert!(
        warnings.contains("/Settings: includedPurposes [") && warnings.contains("finals"),
        "{warnings}"
    );
}

/// Two cubes seen side by side: /Left binds Red for purpose full, Green for
/// preview and Blue for all purposes; /Right binds Green for preview and
/// Blue for all purposes. `purposes` is the settings'
/// `materialBindingPurposes` (none: no settings). Returns the render's log
/// and each cube's centre pixel (R, G, B).
fn bound_colours(name: &str, purposes: Option<&str>) -> (String, [[f32; 3]; 2]) {
    let looks: String = [
        ("Red", "(1, 0, 0)"),
        ("Green", "(0, 1, 0)"),
        ("Blue", "(0, 0, 1)"),
    ]
    .iter()
    .map(|(name, rgb)| emitter(name, rgb))
    .collect();
    let cube = |name: &str, x: f32, bindings: &str| {
        format!(
            "def Cube \"{name}\" (\n prepend apiSchemas = [\"MaterialBindingAPI\"]\n) {{\n \
             double size = 1.8\n double3 xformOp:translate = ({x}, 0, 0)\n \
             uniform token[] xformOpOrder = [\"xformOp:translate\"]\n{bindings}\n}}\n"
        )
    };
    let left =
        "rel material:binding:full = </Looks/Red>\nrel material:binding:preview = </Looks/Green>\n\
                rel material:binding = </Looks/Blue>";
    let right =
        "rel material:binding:preview = </Looks/Green>\nrel material:binding = </Looks/Blue>";
    let mut body = format!(
        "{}{DARK}def Scope \"Looks\" {{\n{looks}}}\n{}{}",
        camera(4.0, 2.0, ""),
        cube("Left", -1.0, left),
        cube("Right", 1.0, right)
    );
    let mut metadata = "";
    if let Some(purposes) = purposes {
        body += &format!(
            "def RenderSettings \"Settings\" {{\n uniform token[] materialBindingPurposes = {purposes}\n}}\n"
        );
        metadata = "    renderSettingsPrimPath = \"/Settings\"";
    }
    let (log, image) = render(&write(name, &stage(metadata, &body)), (40, 20), &[]);
    let at = |x: usize| [0, 1, 2].map(|c| image.rgb[c][10 * image.width + x]);
    (log.text, [at(10), at(30)])
}

/// Asserts each cube's centre shows the named primary, as emitted (1 in its
/// channel, 0 in the others, within rounding).
fn assert_colours(what: &str, got: [[f32; 3]; 2], want: [usize; 2]) {
    for (pixel, channel) in got.iter().zip(want) {
        let expected: Vec<f32> = (0..3).map(|c| f32::from(u8::from(c == channel))).collect();
        let close = pixel
            .iter()
            .zip(&expected)
            .all(|(a, b)| (a - b).abs() < 1e-3);
        assert!(close, "{what}: pixels {got:?}, want channels {want:?}");
    }
}

/// Final renders resolve purpose `full`, then all purposes (USD's fallback
/// `materialBindingPurposes`, with or without settings), not the preview
/// look; settings asking for `preview` get the preview bindings.
#[test]
fn material_binding_purposes_full_then_all_purpose() {
    let (_, got) = bound_colours("usd_letter_binding_default", None);
    assert_colours("no settings", got, [0, 2]);
    let (_, got) = bound_colours("usd_letter_binding_preview", Some("[\"preview\", \"\"]"));
    assert_colours("[preview, allPurpose]", got, [1, 1]);
    let (_, got) = bound_colours("usd_letter_binding_all", Some("[\"\"]"));
    assert_colours("[allPurpose]", got, [2, 2]);
}

/// A `materialBindingPurposes` token that is no material purpose is warned
/// about (settings, attribute and token named) and the others resolved.
#[test]
fn unknown_material_binding_purpose_is_warned_and_ignored() {
    let (log, got) = bound_colours(
        "usd_letter_binding_unknown",
        Some("[\"lookdev\", \"full\", \"\"]"),
    );
    assert_colours("[lookdev, full, allPurpose]", got, [0, 2]);
    assert!(
        log.contains("/Settings: materialBindingPurposes [") && log.contains("lookdev"),
        "{log}"
    );
}

/// A moving cube seen by a camera with depth of field and an open shutter,
/// exported with `flags` authored on its render settings: the camera
/// record, whether the instances move, and the warnings.
fn camera_effects(name: &str, flags: &str) -> (serde_json::Value, bool, String) {
    let lens = " float fStop = 2\n float focusDistance = 5\n double shutter:open = -0.25\n double shutter:close = 0.25";
    let body = format!(
        "{}def Cube \"Mover\" {{\n double3 xformOp:translate.timeSamples = {{ 0: (-1, 0, 0), 2: (1, 0, 0) }}\n \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}}\n\
         def RenderSettings \"Settings\" {{\n rel camera = </Cam>\n{flags}\n}}\n",
        camera(4.0, 4.0, lens)
    );
    let metadata =
        "    startTimeCode = 1\n    endTimeCode = 1\n    renderSettingsPrimPath = \"/Settings\"";
    let manifest = manifest(name, &stage(metadata, &body));
    let moving = !manifest["instances"]["motion"].is_null();
    (manifest["camera"].clone(), moving, warnings(&manifest))
}

/// `disableMotionBlur` closes the shutter (no camera shutter, nothing
/// moving) and `disableDepthOfField` makes the camera a pinhole (fStop 0);
/// without them the same stage blurs and has its lens.
#[test]
fn disable_motion_blur_and_depth_of_field() {
    let (camera, moving, _) = camera_effects("usd_letter_effects_on", "");
    assert_eq!(camera["shutter"], serde_json::json!([-0.25, 0.25]));
    assert_eq!(camera["f_stop"], 2.0);
    assert!(moving, "the cube moves over the open shutter");
    let flags = " uniform bool disableMotionBlur = true\n uniform bool disableDepthOfField = true";
    let (camera, moving, _) = camera_effects("usd_letter_effects_off", flags);
    assert!(camera["shutter"].is_null(), "{camera}");
    assert_eq!(camera["f_stop"], 0.0);
    assert!(!moving, "nothing moves with motion blur disabled");
}

/// The deprecated `instantaneousShutter` closes the shutter as
/// `disableMotionBlur` does, with a warning saying it is read so (the
/// frame, not `shutter:open`, is rendered).
#[test]
fn instantaneous_shutter_is_read_as_disable_motion_blur() {
    let flags = " uniform bool instantaneousShutter = true";
    let (camera, moving, warnings) = camera_effects("usd_letter_effects_instant", flags);
    assert!(camera["shutter"].is_null() && !moving, "{camera}");
    assert_eq!(camera["f_stop"], 2.0, "the lens is kept");
    assert!(
        warnings.contains("instantaneousShutter (deprecated)"),
        "{warnings}"
    );
}

/// An emitter of radiance 1 filling the view of a camera with `exposure`
/// attributes, rendered at 8 x 8: its pixels and EXR header's
/// `cirrus/exposure_scale`.
fn exposed(name: &str, exposure: &str) -> (Image, String) {
    let body = format!(
        "{}{DARK}def Scope \"Looks\" {{\n{}}}\n\
         def Cube \"Wall\" (\n prepend apiSchemas = [\"MaterialBindingAPI\"]\n) {{\n double size = 4\n \
         rel material:binding = </Looks/Glow>\n}}\n",
        camera(0.8, 0.8, exposure),
        emitter("Glow", "(1, 1, 1)")
    );
    let usda = write(name, &stage("", &body));
    let (_, image) = render(&usda, (8, 8), &[]);
    let exr = usda.parent().unwrap().join("stage-8x8-4spp-seed1-.exr");
    let meta = exr::meta::MetaData::read_from_file(&exr, false).unwrap();
    let attribute = meta.headers[0]
        .own_attributes
        .other
        .get(&exr::prelude::Text::from("cirrus/exposure_scale"))
        .cloned();
    let header = match attribute {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => t.to_string(),
        other => panic!("cirrus/exposure_scale is {other:?}"),
    };
    (image, header)
}

/// The camera's exposure scales the image by UsdGeomCamera's linear
/// exposure scale, responsivity x time x iso/100 x 2^exposure / fStop^2
/// (here 1 x 0.5 x 1 x 2 / 4 = 0.25), and the EXR header states it; the
/// fallbacks scale by exactly 1.
#[test]
fn camera_exposure_scales_the_image() {
    let attributes = " float exposure = 1\n float exposure:fStop = 2\n float exposure:time = 0.5";
    let (image, header) = exposed("usd_letter_exposure", attributes);
    assert_eq!(header, "0.25");
    assert!(
        image.rgb.iter().flatten().all(|&v| (v - 0.25).abs() < 1e-5),
        "{:?}",
        image.rgb
    );
    let (image, header) = exposed("usd_letter_exposure_fallback", "");
    assert_eq!(header, "1");
    assert!(
        image.rgb.iter().flatten().all(|&v| (v - 1.0).abs() < 1e-5),
        "{:?}",
        image.rgb
    );
}

/// A NaN `exposure` is refused by the export with an error naming the
/// camera and the attribute.
#[test]
fn nan_camera_exposure_is_refused_naming_the_camera() {
    let text = stage(
        "",
        &format!(
            "{}def Cube \"C\" {{}}\n",
            camera(4.0, 4.0, " float exposure = nan")
        ),
    );
    let dir = common::scratch("usd_letter_exposure_nan");
    std::fs::write(dir.join("stage.usda"), text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args([
            "export".as_ref(),
            dir.join("stage.usda").as_os_str(),
            "-o".as_ref(),
        ])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "the export succeeded:\n{stderr}");
    assert!(stderr.contains("camera /Cam: exposure is nan"), "{stderr}");
}
