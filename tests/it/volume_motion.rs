//! Volumes advected by their velocity fields over the shutter, end to end
//! (docs/volumes.md, "Motion blur"): a blob moved by a uniform velocity
//! renders as the average of still frames of the blob translated by the
//! same displacement, within 4 sigma per band of columns; a closed shutter
//! renders bit for bit what the volume without a velocity field renders;
//! a fast blob never finds density above its (dilated) majorant; bad
//! velocity fields are refused or warned about by name. VDBs are written
//! with Debian's pyopenvdb, stages as USDA text.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::Output;

// Image size: an orthographic camera 8 x 4 scene units wide, 8 pixels per
// unit (RES); K still frames; bands of BAND columns.
use crate::common::motion::{
    assert_blur_is_average, export_frames, still_frames, BAND, HEIGHT, K, RES, WIDTH,
};

/// Writes `dir/blob.vdb`: `density`, a ball of radius 0.6 around (-1, 0, 0)
/// (voxels of 0.05), and velocity grids. `vel` (vec3s, voxels of 0.2 and
/// offset by half a voxel, so its transform differs from the density's) and
/// `vel.x`/`vel.y`/`vel.z` (float) both hold (`speed`, 0, 0) everywhere (as
/// their background); `nanvel` is `vel` with NaN voxels; `speed` is a float
/// grid that is not a velocity.
fn write_blob(dir: &Path, speed: f32) -> PathBuf {
    let vdb = dir.join("blob.vdb");
    let script = dir.join("blob.py");
    std::fs::write(
        &script,
        r#"
import sys, math, pyopenvdb as vdb
path, speed = sys.argv[1], float(sys.argv[2])
d = vdb.FloatGrid()
d.name = "density"
d.transform = vdb.createLinearTransform(voxelSize=0.05)
a = d.getAccessor()
for i in range(-35, -4):
    for j in range(-14, 15):
        for k in range(-14, 15):
            r = math.sqrt((i * 0.05 + 1.0) ** 2 + (j * 0.05) ** 2 + (k * 0.05) ** 2)
            if r < 0.6:
                a.setValueOn((i, j, k), 1.0 - (r / 0.6) ** 2)
def vector(name, value):
    g = vdb.Vec3SGrid(value)
    g.name = name
    g.transform = vdb.createLinearTransform(voxelSize=0.2)
    g.transform.translate((0.1, 0.1, 0.1))
    g.fill((-2, -2, -2), (2, 2, 2), value)
    return g
def component(axis, value):
    g = vdb.FloatGrid(value)
    g.name = "vel." + axis
    g.transform = vdb.createLinearTransform(voxelSize=0.2)
    g.fill((-2, -2, -2), (2, 2, 2), value)
    return g
nan = vector("nanvel", (speed, 0.0, 0.0))
nan.getAccessor().setValueOn((0, 0, 0), (float("nan"), 0.0, 0.0))
nan.getAccessor().setValueOn((1, 0, 0), (0.0, float("inf"), 0.0))
not_vector = vdb.FloatGrid()
not_vector.name = "speed"
not_vector.fill((0, 0, 0), (3, 3, 3), speed)
grids = [d, vector("vel", (speed, 0.0, 0.0)), nan, not_vector,
         component("x", speed), component("y", 0.0), component("z", 0.0)]
vdb.write(path, grids=grids)
"#,
    )
    .unwrap();
    let args = [vdb.to_str().unwrap(), &speed.to_string()];
    common::run_python(Path::new(common::SYSTEM_PYTHON), &script, &args);
    vdb
}

/// A stage of the blob in front of a white dome, absorbing only (albedo 0,
/// densityScale 4), seen by an orthographic camera whose shutter is open
/// over frame 0..1. `velocity`: the grid its `field:velocity` names (none
/// for `None`), with `motion:velocityScale` 0.5; `translate`: the Volume's
/// `xformOp:translate` (a USDA value, time samples allowed).
fn blob_stage(
    dir: &Path,
    name: &str,
    vdb: &Path,
    velocity: Option<&str>,
    translate: &str,
) -> PathBuf {
    let vdb = vdb.display();
    let velocity = velocity.map_or(String::new(), |grid| {
        format!(
            r#"rel field:velocity = </World/Blob/velocity>
        float motion:velocityScale = 0.5
        def OpenVDBAsset "velocity"
        {{
            asset filePath = @{vdb}@
            token fieldName = "{grid}"
        }}"#
        )
    });
    let usda = dir.join(format!("{name}.usda"));
    std::fs::write(
        &usda,
        format!(
            r#"#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 1
)
def Xform "World"
{{
    def Camera "Camera"
    {{
        double3 xformOp:translate = (0, 0, 10)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        token projection = "orthographic"
        float horizontalAperture = 80
        float verticalAperture = 40
        float2 clippingRange = (0.01, 100)
        double shutter:open = 0
        double shutter:close = 1
    }}
    def DomeLight "Dome"
    {{
        float inputs:intensity = 1
    }}
    def Volume "Blob" (
        prepend apiSchemas = ["MotionAPI"]
    )
    {{
        {translate}
        uniform token[] xformOpOrder = ["xformOp:translate"]
        float primvars:densityScale = 4
        color3f primvars:albedo = (0, 0, 0)
        float primvars:anisotropy = 0
        rel field:density = </World/Blob/density>
        def OpenVDBAsset "density"
        {{
            asset filePath = @{vdb}@
            token fieldName = "density"
        }}
        {velocity}
    }}
}}
"#
        ),
    )
    .unwrap();
    usda
}

/// Runs `cirrus ARGS...`.
fn cirrus(args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(args)
        .output()
        .unwrap()
}

/// `cirrus render SCENE -o OUT` at [`RES`] (box filter, beauty and
/// variance, one thread) with `extra` flags: its log, after checking it
/// succeeded and dropped no NaN sample.
fn render(scene: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend([
        "--res",
        RES,
        "--filter",
        "box",
        "--aovs",
        "variance",
        "--threads",
        "1",
    ]);
    args.extend(extra);
    let result = cirrus(&args);
    let log = String::from_utf8_lossy(&result.stderr).into_owned();
    assert!(result.status.success(), "cirrus {args:?} failed:\n{log}");
    assert!(!log.contains("NaN/Inf sample"), "{log}");
    log
}

/// The G channel and its variance, per pixel.
fn planes(out: &Path) -> (Vec<f64>, Vec<f64>) {
    let channels = common::channel_bits(out);
    let plane = |name: &str| -> Vec<f64> {
        let (_, bits) = channels.iter().find(|(n, _)| n == name).unwrap();
        bits.iter().map(|&b| f64::from(f32::from_bits(b))).collect()
    };
    (plane("G"), plane("variance.G"))
}

/// `cirrus export STAGE -o DIR`: the scene folder.
fn export(stage: &Path, dir: PathBuf) -> PathBuf {
    let result = cirrus(&[
        "export",
        stage.to_str().unwrap(),
        "-o",
        dir.to_str().unwrap(),
    ]);
    let log = String::from_utf8_lossy(&result.stderr);
    assert!(result.status.success(), "{log}");
    dir
}

/// A blob moved 2 units along +x over the shutter by a uniform velocity
/// (96 units/s x velocityScale 0.5 / 24 frames/s, read from a grid whose
/// voxels and offset differ from the density's) renders as the average of
/// K still frames of the blob translated by the displacement at the
/// midpoints of the shutter's K parts: every band within 4 sigma; and the
/// blur is visible against frame 0.
#[test]
fn a_blob_moved_by_a_uniform_velocity_is_the_average_of_translated_stills() {
    let dir = common::scratch("volume_motion_uniform");
    let vdb = write_blob(&dir, 96.0);
    let moving = blob_stage(
        &dir,
        "moving",
        &vdb,
        Some("vel"),
        "double3 xformOp:translate = (0, 0, 0)",
    );
    let translated = blob_stage(
        &dir,
        "translated",
        &vdb,
        None,
        "double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 1: (2, 0, 0) }",
    );
    export_frames(&translated, &dir.join("stills"), "0,0", &still_frames());

    let scene = export(&moving, dir.join("moving"));
    let out = dir.join("blurred.exr");
    render(&scene, &out, &["--spp", "64", "--seed", "1"]);
    let blurred = planes(&out);
    let still = |k: usize, seed: usize| {
        let out = dir.join(format!("still{k}.exr"));
        let scene = dir.join(format!("stills/frame{k}"));
        render(&scene, &out, &["--spp", "16", "--seed", &seed.to_string()]);
        planes(&out)
    };
    let stills: Vec<_> = (0..K).map(|k| still(k, 100 + k)).collect();
    assert_blur_is_average("advected blob", &blurred, &stills, &still(K, 7));
}

/// With the shutter closed at the frame the velocity field is not read:
/// the image equals, bit for bit, that of the same volume without one; and
/// three float grids `vel.x/.y/.z` advect exactly as the vec3s grid `vel`
/// holding the same values (bit for bit, shutter open).
#[test]
fn a_closed_shutter_ignores_velocity_and_split_grids_equal_the_vector_grid() {
    let dir = common::scratch("volume_motion_closed");
    let vdb = write_blob(&dir, 96.0);
    let still = "double3 xformOp:translate = (0, 0, 0)";
    let with = export(
        &blob_stage(&dir, "with", &vdb, Some("vel"), still),
        dir.join("with"),
    );
    let without = export(
        &blob_stage(&dir, "without", &vdb, None, still),
        dir.join("without"),
    );
    let split = export(
        &blob_stage(&dir, "split", &vdb, Some("vel.y"), still),
        dir.join("split"),
    );
    let image = |scene: &Path, name: &str, shutter: &str| {
        let out = dir.join(name);
        render(
            scene,
            &out,
            &["--spp", "8", "--seed", "3", "--shutter", shutter],
        );
        common::channel_bits(&out)
    };
    assert!(
        image(&with, "with.exr", "0,0") == image(&without, "without.exr", "0,0"),
        "a closed shutter read the velocity field"
    );
    let vector = image(&with, "vector_open.exr", "0,1");
    assert!(
        vector == image(&split, "split_open.exr", "0,1"),
        "vel.x/.y/.z advect differently from vel"
    );
    assert!(
        vector != image(&without, "without_open.exr", "0,1"),
        "the velocity field moved nothing"
    );
}

/// A blob swept 20 units (400 voxels, 50 majorant cells) over the shutter:
/// the dilated majorant grid stays above every density lookup (the render
/// reports no violation) for each majorant kind and estimator family.
#[test]
fn a_fast_blob_never_exceeds_its_majorant() {
    let dir = common::scratch("volume_motion_fast");
    let vdb = write_blob(&dir, 960.0);
    let stage = blob_stage(
        &dir,
        "fast",
        &vdb,
        Some("vel"),
        "double3 xformOp:translate = (0, 0, 0)",
    );
    let scene = export(&stage, dir.join("fast"));
    for (majorant, estimator) in [
        ("grid", "null-scattering-mis"),
        ("adaptive", "residual-ratio"),
        ("global", "ratio"),
    ] {
        let out = dir.join(format!("{majorant}.exr"));
        let flags = ["--spp", "4", "--shutter=-0.5,0.5", "--majorant", majorant];
        let log = render(
            &scene,
            &out,
            &[&flags[..], &["--volume-estimator", estimator]].concat(),
        );
        assert!(
            !log.contains("exceeded their majorant"),
            "{majorant}: {log}"
        );
    }
}

/// NaN and infinite velocities read as zero (one warning naming volume,
/// grid and file; no NaN reaches the film); a velocity field that is a
/// float grid without `.x/.y/.z` siblings is refused naming file and grid.
#[test]
fn bad_velocity_fields_are_warned_about_or_refused_by_name() {
    let dir = common::scratch("volume_motion_bad");
    let vdb = write_blob(&dir, 96.0);
    let still = "double3 xformOp:translate = (0, 0, 0)";
    let nan = export(
        &blob_stage(&dir, "nan", &vdb, Some("nanvel"), still),
        dir.join("nan"),
    );
    let log = render(&nan, &dir.join("nan.exr"), &["--spp", "4"]);
    let warning = format!(
        "volume /World/Blob: velocity grid nanvel of {} has 2 NaN or infinite values",
        vdb.display()
    );
    assert!(log.contains(&warning), "no NaN warning in:\n{log}");
    assert_eq!(log.matches("NaN or infinite values").count(), 1, "{log}");

    let wrong = export(
        &blob_stage(&dir, "wrong", &vdb, Some("speed"), still),
        dir.join("wrong"),
    );
    let out = dir.join("wrong.exr");
    let result = cirrus(&[
        "render",
        wrong.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--res",
        "8x8",
    ]);
    let log = String::from_utf8_lossy(&result.stderr);
    assert!(
        !result.status.success(),
        "a float velocity grid was accepted"
    );
    assert!(
        log.contains(&format!(
            "{}: grid 'speed' holds 'float' values; a velocity field needs a vec3s grid",
            vdb.display()
        )),
        "{log}"
    );
    // A closed shutter does not read it, so nothing fails.
    render(&wrong, &out, &["--spp", "1", "--shutter", "0,0"]);
}

/// Fire advected by its velocity field stays unbiased with light sampling:
/// the demo explosion (scenes/demo/explosion.usda over a 48^3 fireball of
/// scenes/make_explosion.py, whose `vel` grid rises and expands) under
/// `--shutter 0,0.5` renders the same with `--volume-light-sampling` on
/// (points picked by the emission at the frame, weighed by the source at
/// the sample's time) and off (tracking alone): per channel, the mean of
/// the paired per-pixel differences within 4 sigma, that sigma under 3% of
/// the image mean.
#[test]
fn advected_fire_renders_the_same_with_and_without_light_sampling() {
    let dir = common::scratch("volume_motion_fire");
    let vdb = dir.join("explosion.vdb");
    let make = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/make_explosion.py");
    let vdb_arg = vdb.to_string_lossy();
    common::run_python(
        Path::new(common::SYSTEM_PYTHON),
        &make,
        &[&vdb_arg, "--res", "48"],
    );
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/demo/explosion.usda");
    let text = std::fs::read_to_string(demo).unwrap();
    assert!(
        text.contains("rel field:velocity"),
        "the demo lost its velocity field"
    );
    let usda = dir.join("explosion.usda");
    std::fs::write(&usda, text.replace("../../out/explosion.vdb", &vdb_arg)).unwrap();
    let scene = export(&usda, dir.join("scene"));
    let (w, h) = (40usize, 24usize);
    let image = |name: &str, flags: &[&str]| {
        let out = dir.join(format!("{name}.exr"));
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(["--res", "40x24", "--filter", "box", "--aovs", "beauty"]);
        args.extend(flags);
        let result = cirrus(&args);
        let log = String::from_utf8_lossy(&result.stderr);
        assert!(result.status.success(), "{log}");
        assert!(!log.contains("exceeded their majorant"), "{log}");
        common::render::Image::read(&out, (w as u32, h as u32))
    };
    let blurred = ["--shutter", "0,0.5", "--spp", "256"];
    let on = image("on", &[&blurred[..], &["--seed", "1"]].concat());
    let off = image(
        "off",
        &[
            &blurred[..],
            &["--seed", "2", "--volume-light-sampling", "off"],
        ]
        .concat(),
    );
    for c in 0..3 {
        let pairs = |a: &common::render::Image, b: &common::render::Image| {
            let d = (0..w * h).map(|i| f64::from(a.rgb[c][i]) - f64::from(b.rgb[c][i]));
            common::estimate(d.collect::<Vec<_>>())
        };
        let d = pairs(&on, &off);
        let mean = common::estimate(on.pixels(c, |_, _| true)).mean;
        eprintln!(
            "channel {c} (mean {mean:.4}): on - off {:.5} +- {:.5}",
            d.mean, d.sigma
        );
        assert!(
            d.mean.abs() < 4.0 * d.sigma,
            "channel {c}: {} +- {}",
            d.mean,
            d.sigma
        );
        assert!(
            d.sigma < 0.03 * mean,
            "channel {c}: too noisy to tell: {} vs {mean}",
            d.sigma
        );
    }
}

/// The Volume's translate keyed from (0, 0, 0) at frame 0 to (`x`, 0, 0)
/// at frame 1 (a USDA line for [`blob_stage`]).
fn keyed_translate(x: f32) -> String {
    format!("double3 xformOp:translate.timeSamples = {{ 0: (0, 0, 0), 1: ({x}, 0, 0) }}")
}

/// The issue's comparison: the blob moved 2 units along +x over the
/// shutter by a uniform velocity field and the same blob moved by its keyed
/// transform (translate 0 -> 2 over frames 0..1) render the same, every
/// band within 4 sigma; the keyed blob is visibly blurred (against itself
/// with the shutter closed); and with the shutter closed it renders bit for
/// bit as a still blob where it is at the frame.
#[test]
fn a_blob_moved_by_its_transform_equals_the_blob_moved_by_velocity() {
    let dir = common::scratch("volume_motion_transform");
    let vdb = write_blob(&dir, 96.0);
    let still = "double3 xformOp:translate = (0, 0, 0)";
    let advected = export(
        &blob_stage(&dir, "advected", &vdb, Some("vel"), still),
        dir.join("advected"),
    );
    let keyed = export(
        &blob_stage(&dir, "keyed", &vdb, None, &keyed_translate(2.0)),
        dir.join("keyed"),
    );
    let bands = |scene: &Path, name: &str, flags: &[&str]| {
        let out = dir.join(name);
        render(scene, &out, flags);
        common::column_bands(&[planes(&out)], (WIDTH, HEIGHT), BAND)
    };
    let by_velocity = bands(&advected, "advected.exr", &["--spp", "64", "--seed", "1"]);
    let by_transform = bands(&keyed, "keyed.exr", &["--spp", "64", "--seed", "2"]);
    let at_frame = bands(
        &keyed,
        "keyed_closed.exr",
        &["--spp", "64", "--seed", "3", "--shutter", "0,0"],
    );
    common::assert_bands_agree("by velocity vs by transform", &by_velocity, &by_transform);
    assert!(
        common::widest_gap(&by_transform, &at_frame) > 20.0,
        "the keyed blob looks still"
    );

    let still_scene = export(
        &blob_stage(&dir, "still", &vdb, None, still),
        dir.join("still"),
    );
    let closed = |scene: &Path, name: &str| {
        let out = dir.join(name);
        render(
            scene,
            &out,
            &["--spp", "8", "--seed", "4", "--shutter", "0,0"],
        );
        common::channel_bits(&out)
    };
    assert!(
        closed(&keyed, "keyed_bits.exr") == closed(&still_scene, "still_bits.exr"),
        "a closed shutter moved the keyed blob"
    );
}

/// A blob swept 20 units (400 voxels, 50 majorant cells) by its keyed
/// transform over the shutter: every density lookup stays under the
/// majorant grid the ray crosses at its time (the render reports no
/// violation) for each majorant kind and estimator family.
#[test]
fn a_fast_keyed_blob_never_exceeds_its_majorant() {
    let dir = common::scratch("volume_motion_fast_keyed");
    let vdb = write_blob(&dir, 0.0);
    let stage = blob_stage(&dir, "fast", &vdb, None, &keyed_translate(20.0));
    let scene = export(&stage, dir.join("fast"));
    for (majorant, estimator) in [
        ("grid", "null-scattering-mis"),
        ("adaptive", "residual-ratio"),
        ("global", "ratio"),
    ] {
        let out = dir.join(format!("{majorant}.exr"));
        let flags = ["--spp", "4", "--majorant", majorant];
        let log = render(
            &scene,
            &out,
            &[&flags[..], &["--volume-estimator", estimator]].concat(),
        );
        assert!(
            !log.contains("exceeded their majorant"),
            "{majorant}: {log}"
        );
        assert!(!log.contains("moves over the shutter"), "{log}");
    }
}
