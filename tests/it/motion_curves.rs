//! Motion blur of deforming curves and rigidly skinned meshes, end to end:
//! a blurred render equals the average of still renders at stratified
//! times over the shutter within 4 sigma per band of columns (a linear and
//! a cubic curve deforming, their widths keyed; a quad rigidly skinned to
//! an animated joint, and one whose SkelRoot moves); curve velocities
//! render as their time-sampled equivalent; a closed shutter renders the
//! still frame bit for bit; a curve whose vertex count changes over the
//! shutter is warned about and left still.

use crate::common;
use crate::common::motion::{
    blurred_equals_average_of_stills, closed_shutter_renders_the_still_frame, stage,
    velocities_blur_as_their_time_sampled_equivalent,
};
use std::process::Command;

#[test]
fn deforming_curves_blur_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_curves");
}

#[test]
fn a_rigidly_skinned_mesh_blurs_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_rigid_skin");
}

/// A skinned mesh is placed by its skeleton: a SkelRoot moving by its
/// transform (the joint still) moves it over the shutter.
#[test]
fn a_skinned_mesh_moved_by_its_skel_root_blurs_to_the_average_of_still_frames() {
    blurred_equals_average_of_stills("motion_skel_root");
}

/// Curves moved by `velocities` (a linear and a cubic curve) render as the
/// curves whose time-sampled points make the same motion.
#[test]
fn curve_velocities_blur_as_their_time_sampled_equivalent() {
    velocities_blur_as_their_time_sampled_equivalent("motion_curves", "motion_curves_velocities");
}

#[test]
fn a_closed_shutter_renders_still_curves_and_skins_bit_identically() {
    for name in ["motion_curves", "motion_rigid_skin"] {
        closed_shutter_renders_the_still_frame(name);
    }
}

/// motion_curves.usda with a vertex more in the Strand's frame-1 sample
/// (and its curveVertexCounts left as they are): the Strand is warned
/// about by prim and exported without keys; the Wave keeps its keys.
#[test]
fn a_curve_changing_its_vertex_count_is_warned_about_and_left_still() {
    let dir = common::scratch("motion_curves_more");
    let text = std::fs::read_to_string(stage("motion_curves")).unwrap();
    let last = "1: [(-1, -1.5, 0), (0.5, 0, 0), (-1, 1.5, 0)";
    assert!(text.contains(last), "the test stage changed");
    let usda = dir.join("more.usda");
    std::fs::write(&usda, text.replace(last, &format!("{last}, (0, 0, 0)"))).unwrap();
    let out = dir.join("more");
    let mut export = Command::new(env!("CARGO_BIN_EXE_cirrus"));
    export.arg("export").arg(&usda).arg("-o").arg(&out);
    let log = String::from_utf8_lossy(&common::succeeds(export).stderr).into_owned();
    let said = "/World/Strand: its vertex count changes over the shutter";
    assert_eq!(log.matches(said).count(), 1, "{log}");
    let text = std::fs::read_to_string(out.join("scene.json")).unwrap();
    let manifest: serde_json::Value = serde_json::from_str(&text).unwrap();
    let motion = |i: usize| &manifest["curves"][i]["motion"];
    assert_eq!(manifest["curves"][0]["path"], "/World/Strand");
    assert!(motion(0).is_null(), "the Strand still moves: {}", motion(0));
    assert!(motion(1).is_object(), "the Wave lost its keys");
}
