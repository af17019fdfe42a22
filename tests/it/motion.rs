//! Motion blur end to end: a render whose shutter is open equals the
//! average of still renders at stratified times over the shutter (a
//! translating sphere, a rotating instance, PointInstancer velocities, a
//! moving camera, a deforming mesh, a moving point cloud; mesh and point
//! velocities against their time-sampled equivalents; a skinned mesh posed
//! per key), within 4 sigma
//! per band of columns; a shutter closed at the frame renders the still
//! frame bit for bit; farm parts and resumed renders of a blurred frame stay
//! bit-identical; bad shutters and non-finite transform samples are refused
//! or warned about by name.

use crate::common;
use cirrus::scene::{Refinement, Scene};

use crate::common::motion::{
    blurred_equals_average_of_stills, closed_shutter_renders_the_still_frame, exported, render,
    render_command, stage, velocities_blur_as_their_time_sampled_equivalent, BAND, BLURRED_SPP,
    HEIGHT, WIDTH,
};
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// Runs `cirrus ARGS...`.
fn cirrus(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(args)
        .output()
        .unwrap()
}

/// Runs `cirrus ARGS...`, panicking with its log unless it succeeds; the log.
fn cirrus_ok(args: &[&str]) -> String {
    let out = cirrus(args);
    let log = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "cirrus {args:?} failed:\n{log}");
    log
}

#[test]
fn a_translating_sphere_blurs_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_sphere");
}

#[test]
fn a_rotating_instance_blurs_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_instance");
}

#[test]
fn point_instancer_velocities_blur_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_points");
}

#[test]
fn a_moving_emitter_lights_the_floor_as_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_emitter");
}

#[test]
fn a_moving_camera_blurs_the_still_world_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_camera");
}

#[test]
fn a_deforming_mesh_blurs_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_deform");
}

#[test]
fn a_moving_point_cloud_blurs_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_points_sampled");
}

/// A mesh moved by `velocities` (scene units per second, 24 time codes per
/// second) renders as the mesh whose time-sampled points make the same
/// motion: every band of columns within 4 sigma (independent seeds).
#[test]
fn mesh_velocities_blur_as_their_time_sampled_equivalent() {
    velocities_blur_as_their_time_sampled_equivalent("motion_deform", "motion_velocities");
}

/// A point cloud moved by `velocities` renders as the cloud whose
/// time-sampled points make the same motion (every band within 4 sigma),
/// and it blurs: some band differs from the closed-shutter render by far
/// more than its noise.
#[test]
fn point_velocities_blur_as_their_time_sampled_equivalent() {
    let driven = velocities_blur_as_their_time_sampled_equivalent(
        "motion_points_sampled",
        "motion_points_velocities",
    );
    let dir = common::scratch("motion_points_closed");
    let flags = ["--spp", BLURRED_SPP, "--seed", "13", "--shutter", "0,0"];
    let closed = render(
        &exported("motion_points_velocities"),
        &dir.join("closed.exr"),
        &flags,
    );
    let closed = common::column_bands(std::slice::from_ref(&closed), (WIDTH, HEIGHT), BAND);
    let widest = common::widest_gap(&driven, &closed);
    assert!(
        widest > 20.0,
        "the moving cloud renders as the closed shutter does ({widest:.1} sigma)"
    );
}

/// A mesh skinned by a SkelAnimation animated inside the shutter (the
/// elbow of `make_skinned_cylinder.py` turning 0 to 45 degrees over frames
/// 1..2) is posed at every key: its first key is the frame's pose, its last
/// exactly what a still export of frame 2 poses; its blurred render (the
/// tube is a subdivision surface: every key refined at load) differs from
/// the still frame. The rigidly bound hand is keyed too, unwarned.
#[test]
fn a_skinned_mesh_is_posed_at_every_key_and_blurs() {
    let dir = common::scratch("motion_skinned");
    let usda = dir.join("skinned.usda");
    let script = common::python_script("make_skinned_cylinder.py");
    common::run_python(&common::venv_python(), &script, &[usda.to_str().unwrap()]);
    let export = |name: &str, flags: &[&str]| {
        let out = dir.join(name);
        let args = [
            "export",
            usda.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        let log = cirrus_ok(&[&args[..], flags].concat());
        (out, log)
    };
    let (blurred, log) = export("blurred", &["--frame", "1", "--shutter", "0,1"]);
    assert!(!log.contains("/World/Character/Hand"), "{log}");
    let (frame_2, _) = export("frame2", &["--frame", "2"]);
    let part = |scene: &Scene, path: &str| {
        let i = scene.manifest.meshes.iter().position(|m| m.path == path);
        scene.manifest.meshes[i.expect("the part is exported")].clone()
    };
    let tube = |scene: &Scene| part(scene, "/World/Character/Tube");
    let keyed = Scene::load_with(&blurred, Refinement::Cages).unwrap();
    let still = Scene::load_with(&frame_2, Refinement::Cages).unwrap();
    let hand = part(&keyed, "/World/Character/Hand");
    assert!(hand.motion.is_some(), "the rigid hand has no motion keys");
    let (mesh, posed) = (tube(&keyed), tube(&still));
    let motion = mesh
        .motion
        .as_ref()
        .expect("the skinned tube has no motion keys");
    assert_eq!(motion.times, [0.0, 1.0]);
    let keys = keyed.view(&motion.points);
    let n = keys.len() / 2;
    assert!(
        keys[..n] == *keyed.view(&mesh.points),
        "key 0 is not the frame's pose"
    );
    assert!(
        keys[n..] == *still.view(&posed.points),
        "key 1 is not frame 2's pose"
    );
    let (a, b) = (dir.join("blurred.exr"), dir.join("still.exr"));
    render(&blurred, &a, &["--spp", "4", "--seed", "3"]);
    render(
        &blurred,
        &b,
        &["--spp", "4", "--seed", "3", "--shutter", "0,0"],
    );
    assert!(
        common::channel_bits(&a) != common::channel_bits(&b),
        "the skinned tube did not blur"
    );
}

/// An emissive deforming mesh is not light-sampled while the shutter blurs
/// (a warning names it: its light is found by rays that hit it, with MIS
/// weight 1), and is light-sampled, unwarned, with the shutter closed.
#[test]
fn a_deforming_emitter_is_not_light_sampled_and_is_warned_about() {
    let dir = common::scratch("motion_deforming_emitter");
    let text = std::fs::read_to_string(stage("motion_deform")).unwrap();
    let grey = "color3f inputs:diffuseColor = (0.5, 0.5, 0.5)";
    assert!(text.contains(grey), "the test stage changed");
    let usda = dir.join("emitter.usda");
    std::fs::write(
        &usda,
        text.replace(grey, "color3f inputs:emissiveColor = (1, 1, 1)"),
    )
    .unwrap();
    let out = dir.join("emitter");
    cirrus_ok(&[
        "export",
        usda.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let said = "emissive mesh /World/Sheet moves or deforms over the shutter";
    for (shutter, warned) in [("0,1", true), ("0,0", false)] {
        let exr = dir.join(format!("emitter_{shutter}.exr"));
        let log = cirrus_ok(&[
            "render",
            out.to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--res",
            "16x8",
            "--spp",
            "1",
            "--shutter",
            shutter,
        ]);
        assert_eq!(log.contains(said), warned, "--shutter {shutter}:\n{log}");
    }
}

/// A mesh whose topology changes over the shutter (a point more at frame
/// 1) is exported as it is at the frame, with a warning naming it.
#[test]
fn a_mesh_changing_topology_is_warned_about_and_left_still() {
    exported_still_with_a_point_more(
        "motion_deform",
        ("1: [(-1, -1, 0), (3, -1, 0), (3, 1, 0), (-1, 1, 0)", "]"),
        "/World/Sheet: its topology changes over the shutter",
    );
}

/// A point cloud whose point count changes over the shutter (a point more
/// at frame 1) is exported as it is at the frame, with a warning naming it.
#[test]
fn a_point_cloud_changing_its_count_is_warned_about_and_left_still() {
    exported_still_with_a_point_more(
        "motion_points_sampled",
        (
            "1: [(-1, -1, 0), (1, 0, 0), (-1, 1, 0), (2, -0.5, 0), (0, 0.5, 0)",
            "]",
        ),
        "/World/Cloud: its point count changes over the shutter",
    );
}

/// Spheres that only grow or shrink (time-sampled `widths`, still points)
/// are keyed too: motion_points_sampled.usda with its points held at frame
/// 0 exports widths keys with the shutter open, nothing with it closed.
#[test]
fn points_whose_widths_alone_change_are_keyed() {
    let dir = common::scratch("motion_points_widths");
    let text = std::fs::read_to_string(stage("motion_points_sampled")).unwrap();
    let sampled = "        point3f[] points.timeSamples = {\n            0: [(-3, -1, 0), (-3, 0, 0), (-3, 1, 0), (-2, -0.5, 0), (-2, 0.5, 0)],\n            1: [(-1, -1, 0), (1, 0, 0), (-1, 1, 0), (2, -0.5, 0), (0, 0.5, 0)],\n        }\n";
    assert!(text.contains(sampled), "the test stage changed");
    let still = "        point3f[] points = [(-3, -1, 0), (-3, 0, 0), (-3, 1, 0), (-2, -0.5, 0), (-2, 0.5, 0)]\n";
    let usda = dir.join("widths.usda");
    std::fs::write(&usda, text.replace(sampled, still)).unwrap();
    let motion = |shutter: &str| {
        let out = dir.join(shutter.replace(',', "_"));
        let args = [
            "export",
            usda.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        cirrus_ok(&[&args[..], &["--shutter", shutter]].concat());
        let text = std::fs::read_to_string(out.join("scene.json")).unwrap();
        let manifest: serde_json::Value = serde_json::from_str(&text).unwrap();
        manifest["points"][0]["motion"].clone()
    };
    let open = motion("0,1");
    assert_eq!(open["times"], serde_json::json!([0.0, 0.5, 1.0]), "{open}");
    assert!(open["widths"].is_object(), "{open}");
    assert!(motion("0,0").is_null());
}

/// Exports `scenes/tests/NAME.usda` with a point `(0, 0, 0)` added to the
/// points sample `last` (its text before and after the place to add it):
/// the log says `warning` and the manifest holds no motion.
fn exported_still_with_a_point_more(name: &str, last: (&str, &str), warning: &str) {
    let dir = common::scratch(&format!("{name}_more"));
    let text = std::fs::read_to_string(stage(name)).unwrap();
    let before = format!("{}{}", last.0, last.1);
    assert!(text.contains(&before), "the test stage changed");
    let usda = dir.join("more.usda");
    let more = format!("{}, (0, 0, 0){}", last.0, last.1);
    std::fs::write(&usda, text.replace(&before, &more)).unwrap();
    let out = dir.join("more");
    let log = cirrus_ok(&[
        "export",
        usda.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(log.contains(warning), "{log}");
    let manifest = std::fs::read_to_string(out.join("scene.json")).unwrap();
    assert!(!manifest.contains("\"motion\""), "it still moves");
}

/// Exports `scenes/tests/motion_velocities.usda` with its `velocities`
/// line replaced by `velocities`: the warnings and the manifest's text.
fn export_velocities(dir: &Path, name: &str, velocities: &str) -> (String, String) {
    let text = std::fs::read_to_string(stage("motion_velocities")).unwrap();
    let line = "vector3f[] velocities = [(48, 0, 0), (96, 0, 0), (96, 0, 0), (48, 0, 0)]";
    assert!(text.contains(line), "the test stage changed");
    let usda = dir.join(format!("{name}.usda"));
    std::fs::write(&usda, text.replace(line, velocities)).unwrap();
    let out = dir.join(name);
    let log = cirrus_ok(&[
        "export",
        usda.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    (
        log,
        std::fs::read_to_string(out.join("scene.json")).unwrap(),
    )
}

/// Mesh velocities of the wrong length are ignored (the mesh stays still)
/// with a warning naming the prim; NaN velocities are zeroed, counted and
/// warned about, the others still move their points.
#[test]
fn bad_mesh_velocities_are_ignored_or_zeroed_with_a_warning() {
    let dir = common::scratch("motion_bad_velocities");
    let short = "vector3f[] velocities = [(48, 0, 0), (96, 0, 0), (96, 0, 0)]";
    let (log, manifest) = export_velocities(&dir, "short", short);
    assert!(
        log.contains("/World/Sheet: velocities has 3 values for 4 points; ignored"),
        "{log}"
    );
    assert!(
        !manifest.contains("\"motion\""),
        "short velocities moved it"
    );
    let nan = "vector3f[] velocities = [(nan, 0, 0), (96, 0, 0), (96, 0, 0), (48, 0, 0)]";
    let (log, manifest) = export_velocities(&dir, "nan", nan);
    assert!(
        log.contains("/World/Sheet: 1 velocities are NaN or infinite; zeroed"),
        "{log}"
    );
    assert!(
        manifest.contains("\"motion\""),
        "finite velocities did not move it"
    );
    let out = dir.join("nan.exr");
    render(&dir.join("nan"), &out, &["--spp", "2"]);
}

/// `--shutter 0,0` on a scene exported with motion renders exactly what the
/// same stage exported without motion (shutter closed) renders: every
/// channel, bit for bit.
#[test]
fn a_closed_shutter_renders_the_still_frame_bit_identically() {
    for name in [
        "motion_sphere",
        "motion_instance",
        "motion_camera",
        "motion_deform",
        "motion_points_sampled",
    ] {
        closed_shutter_renders_the_still_frame(name);
    }
}

/// `cirrus render STAGE.usda --shutter 0,1` on a stage whose camera has no
/// shutter exports the motion over that shutter: the same image, bit for
/// bit, as the stage whose camera authors it.
#[test]
fn a_render_time_shutter_reaches_the_exporter() {
    let dir = common::scratch("motion_forwarded");
    let text = std::fs::read_to_string(stage("motion_sphere")).unwrap();
    let usda = dir.join("no_shutter.usda");
    let without = text
        .replace("double shutter:open = 0\n", "")
        .replace("double shutter:close = 1\n", "");
    assert!(
        !without.contains("double shutter"),
        "the test stage changed"
    );
    std::fs::write(&usda, without).unwrap();
    let (a, b) = (dir.join("forwarded.exr"), dir.join("authored.exr"));
    let flags = ["--spp", "4", "--seed", "2"];
    let mut forwarded = render_command(&usda, &a, &[&flags[..], &["--shutter", "0,1"]].concat());
    forwarded.env("XDG_CACHE_HOME", dir.join("cache"));
    common::succeeds(forwarded);
    render(&exported("motion_sphere"), &b, &flags);
    assert!(
        common::channel_bits(&a) == common::channel_bits(&b),
        "--shutter 0,1 did not export the motion"
    );
    // `cirrus export --shutter` keys the same motion into a folder, and
    // `cirrus farm submit --shutter` exports its frames with it.
    let folder = dir.join("exported");
    let (usda, folder_s) = (usda.to_str().unwrap(), folder.to_str().unwrap());
    cirrus_ok(&["export", usda, "-o", folder_s, "--shutter", "0,1"]);
    let c = dir.join("exported.exr");
    render(&folder, &c, &flags);
    assert!(
        common::channel_bits(&c) == common::channel_bits(&b),
        "cirrus export --shutter 0,1 did not export the motion"
    );
    let jobs = dir.join("jobs");
    let out = dir.join("farm.exr");
    cirrus_ok(&[
        "farm",
        "submit",
        usda,
        "-o",
        out.to_str().unwrap(),
        "--shutter",
        "0,1",
        "--dry-run",
        "--job-dir",
        jobs.to_str().unwrap(),
    ]);
    let manifest = std::fs::read_to_string(jobs.join("scenes/default/scene.json")).unwrap();
    let exported_manifest = std::fs::read_to_string(folder.join("scene.json")).unwrap();
    assert_eq!(
        manifest, exported_manifest,
        "farm submit --shutter exported another scene than cirrus export --shutter"
    );
}

/// A blurring `--shutter` on an exported scene must be the shutter it was
/// exported with: its motion keys cover only that, and anything else would
/// render what moves as still without a word.
#[test]
fn a_shutter_the_export_did_not_key_is_refused() {
    let dir = common::scratch("motion_unkeyed");
    let still = dir.join("still");
    common::motion::export_frames(&stage("motion_sphere"), &still, "0,0", &["0".into()]);
    let frame = still.join("frame0");
    let out = dir.join("refused.exr");
    let refused = cirrus(&[
        "render",
        frame.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--shutter",
        "0,1",
    ]);
    let log = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success(),
        "an unkeyed shutter rendered:\n{log}"
    );
    assert!(
        log.contains("exported with shutter 0,0") && log.contains("cirrus export --shutter 0,1"),
        "the refusal does not say what to do:\n{log}"
    );
    assert!(!out.exists(), "a refused render wrote {}", out.display());
    // The shutter it was exported with, or a closed one, renders.
    let moving = exported("motion_sphere");
    let ok = dir.join("keyed.exr");
    render(&moving, &ok, &["--spp", "1", "--shutter", "0,1"]);
    render(&frame, &ok, &["--spp", "1", "--shutter", "0,0"]);
}

/// A shutter closing before it opens is refused, on the command line and
/// in the stage; a non-finite transform sample inside the shutter is
/// warned about naming the prim, which is exported without motion.
#[test]
fn bad_shutters_and_non_finite_samples_are_refused_or_warned_about() {
    let dir = common::scratch("motion_bad");
    let scene = exported("motion_sphere");
    let sphere = stage("motion_sphere");
    let out = dir.join("out.exr");
    for shutter in ["1,0", "nan,1", "0.5"] {
        let flag = format!("--shutter={shutter}");
        let result = cirrus(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            &flag,
        ]);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(!result.status.success(), "--shutter {shutter} was accepted");
        assert!(stderr.contains(shutter), "--shutter {shutter}: {stderr}");
    }
    let text = std::fs::read_to_string(&sphere).unwrap();
    let backwards = dir.join("backwards.usda");
    std::fs::write(
        &backwards,
        text.replace("shutter:close = 1", "shutter:close = -1"),
    )
    .unwrap();
    let result = cirrus(&[
        "export",
        backwards.to_str().unwrap(),
        "-o",
        dir.join("b").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success(), "a backwards shutter was exported");
    assert!(
        stderr.contains("camera /World/Camera") && stderr.contains("not before open"),
        "{stderr}"
    );
    let nan = dir.join("nan.usda");
    let sample = "0: (-1.5, 0, 0),\n            0.5: (nan, 0, 0),";
    std::fs::write(&nan, text.replace("0: (-1.5, 0, 0),", sample)).unwrap();
    let nan_scene = dir.join("nan");
    let result = cirrus(&[
        "export",
        nan.to_str().unwrap(),
        "-o",
        nan_scene.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(result.status.success(), "{stderr}");
    assert!(
        stderr.contains("/World/Ball: a transform over the shutter is not finite"),
        "{stderr}"
    );
    let manifest = std::fs::read_to_string(nan_scene.join("scene.json")).unwrap();
    assert!(
        !manifest.contains("\"motion\""),
        "the NaN instance still moves"
    );

    // PointInstancer velocities of the wrong length: usd-core ignores them,
    // and its warning names the prim.
    let points = std::fs::read_to_string(stage("motion_points")).unwrap();
    let short = dir.join("short_velocities.usda");
    let one = "0: [(24, 0, 0)],";
    std::fs::write(&short, points.replace("0: [(24, 0, 0), (0, 24, 0)],", one)).unwrap();
    let out = dir.join("short");
    let result = cirrus(&[
        "export",
        short.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(result.status.success(), "{stderr}");
    assert!(
        stderr.contains("/World/Points") && stderr.contains("velocities"),
        "{stderr}"
    );
}

/// `cirrus render` of the exported blurred sphere to `out` at `spp` (all
/// AOVs, seed 5) with `extra` flags, piped.
fn blurred_command(scene: &Path, out: &Path, spp: u32, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    c.arg("render").arg(scene).arg("-o").arg(out);
    c.args(["--res", "96x48", "--aovs", "all", "--seed", "5"])
        .args(["--spp", &spp.to_string()])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Time is one of each sample's dimensions: a blurred frame (whose EXR
/// header states its shutter) split into tiles merges bit-identically to
/// the whole, and a blurred
/// render stopped by SIGTERM and resumed equals the uninterrupted one.
#[test]
fn blurred_farm_parts_and_resumed_renders_are_bit_identical() {
    let dir = common::scratch("motion_farm");
    let scene = exported("motion_sphere");
    let whole = dir.join("whole.exr");
    common::succeeds(blurred_command(&scene, &whole, 16, &["--threads", "2"]));
    let whole_bits = common::channel_bits(&whole);
    let meta = exr::meta::MetaData::read_from_file(&whole, false).unwrap();
    let shutter = meta.headers[0]
        .own_attributes
        .other
        .get(&exr::prelude::Text::from("cirrus/shutter"));
    assert!(
        matches!(shutter, Some(exr::meta::attribute::AttributeValue::Text(t)) if t.eq("0,1")),
        "the header's cirrus/shutter is {shutter:?}"
    );
    let mut parts = Vec::new();
    for (i, flags) in [["--tile", "0/2"], ["--tile", "1/2"]].iter().enumerate() {
        let part = dir.join(format!("tile{i}.film"));
        common::succeeds(blurred_command(
            &scene,
            &part,
            16,
            &[&flags[..], &["--threads", "1"]].concat(),
        ));
        parts.push(part);
    }
    let merged = dir.join("merged.exr");
    let mut args = vec!["merge"];
    args.extend(parts.iter().map(|p| p.to_str().unwrap()));
    args.extend(["-o", merged.to_str().unwrap()]);
    cirrus_ok(&args);
    assert!(
        common::channel_bits(&merged) == whole_bits,
        "merged tiles differ"
    );

    let spp = 1024;
    let whole = dir.join("long.exr");
    common::succeeds(blurred_command(&scene, &whole, spp, &["--threads", "2"]));
    let exr = dir.join("resumed.exr");
    let checkpoint = dir.join("resumed.checkpoint");
    let flags = ["--threads", "1", "--checkpoint-every", "0.2"];
    let render = blurred_command(&scene, &exr, spp, &flags);
    common::interrupted_after_checkpoint(render, &checkpoint, "TERM");
    common::succeeds(blurred_command(
        &scene,
        &exr,
        spp,
        &["--threads", "2", "--resume"],
    ));
    assert!(
        common::channel_bits(&exr) == common::channel_bits(&whole),
        "the resumed blurred render differs"
    );
}

/// Motion the export carries is not warned about, with the shutter open or
/// closed: a turning distant light ("Lamp"), deforming curves (time-sampled
/// "Waving", "Drifting" by velocities) and moving points ("Cloud").
#[test]
fn motion_the_export_carries_is_not_warned_about() {
    let dir = common::scratch("motion_carried");
    let usda = stage("motion_carried");
    let export = |name: &str, shutter: &str| {
        let out = dir.join(name);
        let args = [
            "export",
            usda.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        let log = cirrus_ok(&[&args[..], &["--frame", "0", "--shutter", shutter]].concat());
        log.lines()
            .filter(|l| l.starts_with("warning:"))
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    let open = export("open", "0,1");
    assert!(open.is_empty(), "unexpected warnings: {open:#?}");
    let closed = export("closed", "0,0");
    assert!(closed.is_empty(), "a closed shutter warned: {closed:#?}");
}

/// Moving UsdLux lights (a rect light turning as it translates, lighting
/// the floor by light sampling and by the rays that hit it; a sphere light
/// the camera sees) light the floor as the average of still frames.
#[test]
fn moving_lights_light_the_floor_as_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_light");
}
