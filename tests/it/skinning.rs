//! UsdSkel posing in the exporter (`exporter/cirrus_export/skinning.py`) on the skinned
//! cylinder of `tests/python/make_skinned_cylinder.py`: the exported world-space points
//! and normals against usd-core's own `UsdSkel.BakeSkinning`
//! (`tests/python/skinned_points.py`) at every animated frame, the rest pose without an
//! animation, native instances sharing a pose only when they are animated alike, the
//! image following the frame, and one warning naming prim and attribute for each rig
//! that cannot be posed (rendered in its bind pose then).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common::aovs::Exr;
use crate::common::{cirrus_ok, python_script, run_python, scratch, venv_python};
use cirrus::scene::{Refinement, Scene, Transform};
use glam::{DMat3, DVec3};

/// World size of the cylinder: 4 units long, scaled by 1.5 by /World.
const CYLINDER_SIZE: f64 = 6.0;

/// Largest point difference allowed, relative to [`CYLINDER_SIZE`].
const RELATIVE_TOLERANCE: f64 = 1e-5;

/// Largest difference allowed between unit normals.
const NORMAL_TOLERANCE: f64 = 1e-5;

/// The frames the fixture animates (the elbow at 0, 45 and 90 degrees).
const FRAMES: [&str; 3] = ["1", "2", "3"];

/// The stage `make_skinned_cylinder.py` writes for `mode`, in `dir`.
fn stage(dir: &Path, mode: &str) -> PathBuf {
    let usda = dir.join(format!("{mode}.usda"));
    let script = python_script("make_skinned_cylinder.py");
    run_python(&venv_python(), &script, &[usda.to_str().unwrap(), mode]);
    usda
}

/// `cirrus export` of `usda` at `frame` into its own folder beside it, loaded back.
fn export(usda: &Path, frame: &str) -> Scene {
    let stem = usda.file_stem().unwrap().to_string_lossy();
    let out = usda.with_file_name(format!("{stem}-frame{frame}"));
    cirrus_ok(&[
        "export".as_ref(),
        usda.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--frame".as_ref(),
        frame.as_ref(),
    ]);
    // The exported (posed) cages, not their refined surfaces: UsdSkel poses points.
    Scene::load_with(&out, Refinement::Cages).unwrap()
}

/// Points (or normals) per stage path of a mesh copy.
type Arrays = BTreeMap<String, Vec<[f64; 3]>>;

/// What usd-core computes for every skinnable mesh (see `skinned_points.py`).
#[derive(serde::Deserialize)]
struct Reference {
    /// World points after `UsdSkel.BakeSkinning`.
    posed: Arrays,
    /// World unit normals after `UsdSkel.BakeSkinning`.
    normals: Arrays,
    /// World points as authored: the bind pose.
    authored: Arrays,
}

/// usd-core's answer for `usda` at `frame`.
fn reference(usda: &Path, frame: &str) -> Reference {
    let script = python_script("skinned_points.py");
    let json = run_python(&venv_python(), &script, &[usda.to_str().unwrap(), frame]);
    serde_json::from_str(&json).unwrap()
}

/// A 3x4 `[R | t]` transform in double precision.
fn matrix(m: &Transform) -> (DMat3, DVec3) {
    let m = m.map(f64::from);
    let rows = DMat3::from_cols_array(&[m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]]);
    (rows.transpose(), DVec3::new(m[3], m[7], m[11]))
}

/// One exported copy of a mesh in world space.
struct MeshCopy {
    /// Which mesh of the manifest.
    mesh: usize,
    points: Vec<[f64; 3]>,
    /// Unit normals, when the mesh has them.
    normals: Option<Vec<[f64; 3]>>,
}

/// Every exported copy of every mesh, by the stage path of the copy (its instance
/// source, joined with the mesh's name when the source is an instance).
fn world_copies(scene: &Scene) -> BTreeMap<String, MeshCopy> {
    let m = &scene.manifest;
    let instances = &m.instances;
    let transforms = scene.view(&instances.transform);
    let sources = scene.view(&instances.source);
    let mut copies = BTreeMap::new();
    for (i, &prototype) in scene.view(&instances.prototype).iter().enumerate() {
        let (r_instance, t_instance) = matrix(&transforms[i]);
        let source = &instances.instance_sources[sources[i] as usize];
        for part in &m.prototypes[prototype as usize].meshes {
            let mesh = &m.meshes[part.mesh as usize];
            let (r_part, t_part) = matrix(&part.transform);
            let (r, t) = (r_instance * r_part, r_instance * t_part + t_instance);
            let name = mesh.path.rsplit('/').next().unwrap();
            let key = if source.ends_with(&format!("/{name}")) {
                source.clone()
            } else {
                format!("{source}/{name}")
            };
            let points = scene
                .view(&mesh.points)
                .iter()
                .map(|p| (r * DVec3::from(p.map(f64::from)) + t).to_array());
            let normal_matrix = r.inverse().transpose();
            let normals = mesh.normals.as_ref().map(|n| {
                let unit =
                    |n: &[f32; 3]| (normal_matrix * DVec3::from(n.map(f64::from))).normalize();
                scene.view(n).iter().map(|n| unit(n).to_array()).collect()
            });
            let copy = MeshCopy {
                mesh: part.mesh as usize,
                points: points.collect(),
                normals,
            };
            assert!(
                copies.insert(key.clone(), copy).is_none(),
                "{key} exported twice"
            );
        }
    }
    copies
}

/// The largest distance between matching entries of `got` and `want`.
fn max_error(got: &[[f64; 3]], want: &[[f64; 3]], what: &str) -> f64 {
    assert_eq!(got.len(), want.len(), "{what}: point counts");
    got.iter()
        .zip(want)
        .map(|(a, b)| DVec3::from(*a).distance(DVec3::from(*b)))
        .fold(0.0, f64::max)
}

/// Asserts every mesh copy of `scene` sits where `want` (a reference's points by
/// path) says, within the tolerance, and its normals as `normals` says; returns
/// the largest point error.
fn assert_points(scene: &Scene, want: &Arrays, normals: Option<&Arrays>, what: &str) -> f64 {
    let copies = world_copies(scene);
    assert!(
        copies.keys().eq(want.keys()),
        "{what}: meshes {:?}",
        copies.keys()
    );
    let mut worst: f64 = 0.0;
    for (path, copy) in &copies {
        let error = max_error(&copy.points, &want[path], path);
        eprintln!("{what}: {path}: max point error {error:.3e}");
        assert!(
            error <= RELATIVE_TOLERANCE * CYLINDER_SIZE,
            "{what}: {path}: points off by {error:.3e}"
        );
        worst = worst.max(error);
        if let (Some(got), Some(want)) = (&copy.normals, normals.and_then(|n| n.get(path))) {
            let error = max_error(got, want, path);
            assert!(
                error <= NORMAL_TOLERANCE,
                "{what}: {path}: normals off by {error:.3e}"
            );
        }
    }
    worst
}

/// Exports `usda` at `frame`, asserts that it gave no warning and that every
/// mesh copy has usd-core's posed points and normals for `reference_usda` (the
/// same stage, or one that poses the same copies without instancing); returns
/// the scene, the reference and the largest point error.
fn assert_posed(usda: &Path, reference_usda: &Path, frame: &str) -> (Scene, Reference, f64) {
    let scene = export(usda, frame);
    let warnings = &scene.manifest.warnings;
    assert!(warnings.is_empty(), "{warnings:?}");
    let want = reference(reference_usda, frame);
    let what = format!("{} at frame {frame}", usda.display());
    let error = assert_points(&scene, &want.posed, Some(&want.normals), &what);
    (scene, want, error)
}

#[test]
fn posed_points_match_usd_core_at_every_frame() {
    let dir = scratch("skinning_posed");
    let usda = stage(&dir, "posed");
    let mut worst: f64 = 0.0;
    let mut tube_at = Vec::new();
    for frame in FRAMES {
        let (_, want, error) = assert_posed(&usda, &usda, frame);
        assert!(want.normals.contains_key("/World/Character/Tube"));
        worst = worst.max(error);
        tube_at.push(want.posed["/World/Character/Tube"].clone());
    }
    eprintln!("max point error over frames {FRAMES:?}: {worst:.3e}");
    // Not vacuous: the pose moves the tube's tip by units between frames.
    let moved = max_error(&tube_at[0], &tube_at[2], "frames 1 and 3");
    assert!(moved > 1.0, "the tube moved only {moved} between frames");
}

/// Per-corner (faceVarying) normals skin with their point's influences, and
/// jointIndices that refer to the mesh's own `skel:joints` order are mapped to
/// the skeleton's.
#[test]
fn corner_normals_and_a_mesh_joint_order_follow_the_pose() {
    let usda = stage(&scratch("skinning_corners"), "corners");
    let (_, want, _) = assert_posed(&usda, &usda, "3");
    assert_eq!(want.normals["/World/Character/Tube"].len(), 7 * 12 * 4);
}

#[test]
fn without_animation_the_rest_pose_is_rendered_without_warning() {
    let usda = stage(&scratch("skinning_rest"), "rest");
    assert_posed(&usda, &usda, "2");
}

/// Four native instances of one character: C1 and C2 play one animation and
/// share their posed meshes, C3 (another animation) and C4 (none: rest pose)
/// get their own. Every copy sits where usd-core puts it (the reference is the
/// same crowd without instancing, which `BakeSkinning` can write into).
#[test]
fn instances_share_a_pose_only_when_animated_alike() {
    let dir = scratch("skinning_crowd");
    let flat = stage(&dir, "crowd_flat");
    let (scene, want, _) = assert_posed(&stage(&dir, "crowd"), &flat, "2");
    assert_eq!(want.posed.len(), 8);
    let m = &scene.manifest;
    let copies = world_copies(&scene);
    let mesh_of = |path: &str| copies[path].mesh;
    assert_eq!(
        mesh_of("/World/Crowd/C1/Tube"),
        mesh_of("/World/Crowd/C2/Tube")
    );
    assert_ne!(
        mesh_of("/World/Crowd/C1/Tube"),
        mesh_of("/World/Crowd/C3/Tube")
    );
    assert_ne!(
        mesh_of("/World/Crowd/C3/Tube"),
        mesh_of("/World/Crowd/C4/Tube")
    );
    assert_eq!(m.meshes.len(), 6, "Tube and Hand for C1+C2, C3 and C4");
    assert_eq!(export(&flat, "2").manifest.meshes.len(), 8);
}

/// Fraction of the image the character covers (mean beauty alpha) and the
/// alpha plane, from a small fixed-seed render of `scene` at `frame`.
fn coverage(usda: &Path, frame: &str) -> (f64, Vec<f32>) {
    let scene = export(usda, frame);
    let out = usda.with_file_name(format!("frame{frame}.exr"));
    cirrus_ok(&[
        "render".as_ref(),
        scene.dir.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--res".as_ref(),
        "48x36".as_ref(),
        "--spp".as_ref(),
        "4".as_ref(),
        "--seed".as_ref(),
        "7".as_ref(),
        "--aovs".as_ref(),
        "beauty".as_ref(),
    ]);
    let alpha = Exr::read(&out).plane("A").to_vec();
    let mean = alpha.iter().map(|&a| f64::from(a)).sum::<f64>() / alpha.len() as f64;
    (mean, alpha)
}

#[test]
fn the_render_follows_the_frame() {
    let dir = scratch("skinning_render");
    let usda = stage(&dir, "posed");
    let (first, alpha_first) = coverage(&usda, "1");
    let (last, alpha_last) = coverage(&usda, "3");
    eprintln!("alpha coverage: frame 1 {first:.4}, frame 3 {last:.4}");
    assert!(first > 0.02 && last > 0.02, "{first} {last}");
    let changed = alpha_first
        .iter()
        .zip(&alpha_last)
        .filter(|(a, b)| (*a - *b).abs() > 0.5)
        .count();
    eprintln!("{changed} of {} pixels changed coverage", alpha_first.len());
    assert!(changed >= 20, "only {changed} pixels changed coverage");
}

/// Each broken rig: one warning, naming the prim and the attribute at fault,
/// and the prims it names in their bind pose (as authored) while the rest is
/// posed; `cirrus info` counts that one warning.
#[test]
fn rigs_that_cannot_be_posed_warn_once_by_name() {
    let dir = scratch("skinning_bad");
    let tube = "/World/Character/Tube";
    let hand = "/World/Character/Hand";
    let cases: [(&str, &[&str], &[&str]); 3] = [
        (
            "bad_indices",
            &[tube, "primvars:skel:jointIndices", "192"],
            &[tube],
        ),
        (
            "bad_anim",
            &["/World/Character/Skel", "/World/Character/Anim", "joints"],
            &[tube, hand],
        ),
        (
            "no_joints",
            &["/World/Character/Skel", "'joints'", "bindTransforms"],
            &[tube, hand],
        ),
    ];
    for (mode, needles, unposed) in cases {
        let usda = stage(&dir, mode);
        let scene = export(&usda, "2");
        let warnings = &scene.manifest.warnings;
        assert_eq!(warnings.len(), 1, "{mode}: {warnings:?}");
        for needle in needles {
            assert!(
                warnings[0].contains(needle),
                "{mode}: no '{needle}' in {warnings:?}"
            );
        }
        assert!(warnings[0].contains("bind pose"), "{mode}: {warnings:?}");
        let want = reference(&usda, "2");
        let expected: Arrays = want
            .posed
            .iter()
            .map(|(path, posed)| {
                let as_authored = unposed.contains(&path.as_str());
                let points = if as_authored {
                    &want.authored[path]
                } else {
                    posed
                };
                (path.clone(), points.clone())
            })
            .collect();
        assert_points(&scene, &expected, None, mode);
        let info = cirrus_ok(&["info".as_ref(), scene.dir.as_os_str()]);
        assert!(info.contains("warnings     1\n"), "{mode}: {info}");
    }
}
