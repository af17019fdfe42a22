//! Moving distant and dome lights end to end (docs/rendering.md, "Motion
//! blur"): a distant light turning over the shutter above a sphere on a
//! floor, and a textured dome turning about the vertical that the camera
//! sees and that lights a sphere on a floor, each render with the shutter
//! open equal to the average of still renders at stratified frames within
//! 4 sigma per band of columns, differ clearly from frame 0, and render the
//! still frame 0 bit for bit with `--shutter 0,0`.

use crate::common;
use std::path::Path;

use crate::common::motion::{
    assert_blur_is_average, export_frames, render_with_bits, still_frames, BLURRED_SPP, K,
    STILL_SPP,
};

/// Exports `usda` at frame 0 with the shutter open over the frame, and at
/// the midpoints of the shutter's [`K`] parts and at frame 0 with it
/// closed; then: the blurred render agrees with the average of the K still
/// renders band by band within 4 sigma and differs clearly from frame 0,
/// and the blurred export rendered with `--shutter 0,0` is the still frame
/// 0, bit for bit.
fn blurred_equals_average_of_stills(name: &str, usda: &Path, dir: &Path) {
    let blurred_dir = dir.join("blurred");
    export_frames(usda, &blurred_dir, "0,1", &["0".into()]);
    let stills_dir = dir.join("stills");
    export_frames(usda, &stills_dir, "0,0", &still_frames());
    let moving = blurred_dir.join("frame0");
    let render = |scene: &Path, out: &str, spp: &str, seed: usize, extra: &[&str]| {
        let seed = seed.to_string();
        let mut flags = vec!["--spp", spp, "--seed", &seed];
        flags.extend(extra);
        render_with_bits(scene, &dir.join(out), &flags)
    };
    let (blurred, _) = render(&moving, "blurred.exr", BLURRED_SPP, 1, &[]);
    let stills: Vec<_> = (0..K)
        .map(|k| {
            let scene = stills_dir.join(format!("frame{k}"));
            render(&scene, &format!("still{k}.exr"), STILL_SPP, 100 + k, &[]).0
        })
        .collect();
    let frame_0 = stills_dir.join(format!("frame{K}"));
    let (frame_0, frame_0_bits) = render(&frame_0, "frame0.exr", STILL_SPP, 7, &[]);
    let (_, closed_bits) = render(&moving, "closed.exr", STILL_SPP, 7, &["--shutter", "0,0"]);
    assert!(
        closed_bits == frame_0_bits,
        "{name}: --shutter 0,0 differs from the still export"
    );
    assert_blur_is_average(name, &blurred, &stills, &frame_0);
}

/// A distant light turning 100 degrees over the shutter lights the sphere
/// and the floor, by light sampling and by bounce rays that escape into its
/// cone, as the average of still frames.
#[test]
fn a_turning_distant_light_blurs_to_the_average_of_still_frames() {
    let dir = common::scratch("motion_lights_distant");
    let usda = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/motion_distant.usda");
    blurred_equals_average_of_stills("motion_distant", &usda, &dir);
}

/// A textured dome turning 60 degrees about the vertical, seen by the
/// camera (its lookup turned at the ray's time) and lighting a sphere on a
/// floor (its samples turned), as the average of still frames.
#[test]
fn a_turning_textured_dome_blurs_to_the_average_of_still_frames() {
    let dir = common::scratch("motion_lights_dome");
    let stage = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/motion_dome.usda");
    let usda = dir.join("motion_dome.usda");
    std::fs::copy(stage, &usda).unwrap();
    // Lat-long: column u is longitude, row v latitude from the pole down;
    // brighter on one side (sin 2 pi u) and towards the pole, smooth
    // everywhere (the seam included) so still frames sample it finely.
    let (w, h) = (64usize, 32usize);
    exr::prelude::write_rgb_file(dir.join("motion_dome_sky.exr"), w, h, |x, y| {
        let (u, v) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
        let side = 0.6 + 0.5 * (2.0 * std::f32::consts::PI * u).sin();
        let pole = 0.6 + 0.4 * (std::f32::consts::PI * v).cos();
        (side * pole, 0.8 * side * pole, 0.5 * pole)
    })
    .unwrap();
    blurred_equals_average_of_stills("motion_dome", &usda, &dir);
}

/// The memory estimate (`--memory-limit`) counts motion keys: a cloud of
/// 1,000 points, a linear curve of 50 vertices and a 20 x 20 quad grid
/// whose points are time-sampled at 2 and then at 5 frames over the
/// shutter; the 3 keys more add exactly their arrays (12 bytes per point,
/// curve vertex and normal) and what geometry builds from them (16 per
/// sphere or curve vertex, 12 per vertex point or normal, 96 per triangle)
/// to the estimate.
#[test]
fn the_memory_estimate_grows_with_the_number_of_keys() {
    let n = 1_000;
    let curve = 50; // vertices
    let grid = 21; // vertices per side
    let stage = |keys: usize| {
        let frames = (0..keys).map(|k| k as f64 / (keys - 1) as f64);
        let sampled = |points: &dyn Fn(f64) -> Vec<String>| {
            let samples: Vec<String> = frames
                .clone()
                .map(|t| format!("{t}: [{}]", points(t).join(", ")))
                .collect();
            samples.join(",\n")
        };
        let cloud = sampled(&|t| (0..n).map(|i| format!("({i}, {t}, 0)")).collect());
        let hair = sampled(&|t| (0..curve).map(|i| format!("({t}, {i}, 1)")).collect());
        let sheet = sampled(&|t| {
            let vertex = |i: usize| format!("({}, {}, {t})", i % grid, i / grid);
            (0..grid * grid).map(vertex).collect()
        });
        let quads = (grid - 1) * (grid - 1);
        let indices: Vec<String> = (0..quads)
            .flat_map(|q| {
                let corner = q / (grid - 1) * grid + q % (grid - 1);
                [corner, corner + 1, corner + grid + 1, corner + grid]
            })
            .map(|i| i.to_string())
            .collect();
        format!(
            "#usda 1.0\n(\n    defaultPrim = \"World\"\n    startTimeCode = 0\n)\n\
             def Xform \"World\"\n{{\n\
             def Camera \"Camera\"\n{{\n double shutter:open = 0\n double shutter:close = 1\n}}\n\
             def DistantLight \"Sun\"\n{{\n}}\n\
             def Points \"Cloud\"\n{{\n float[] widths = [0.1]\n point3f[] points.timeSamples = {{\n{cloud}\n}}\n}}\n\
             def BasisCurves \"Hair\"\n{{\n uniform token type = \"linear\"\n\
             int[] curveVertexCounts = [{curve}]\n float[] widths = [0.1] (interpolation = \"constant\")\n\
             point3f[] points.timeSamples = {{\n{hair}\n}}\n}}\n\
             def Mesh \"Sheet\"\n{{\n uniform token subdivisionScheme = \"none\"\n\
             int[] faceVertexCounts = [{}]\n int[] faceVertexIndices = [{}]\n\
             point3f[] points.timeSamples = {{\n{sheet}\n}}\n}}\n}}\n",
            vec!["4"; quads].join(", "),
            indices.join(", ")
        )
    };
    let estimate = |keys: usize| {
        let dir = common::scratch(&format!("motion_lights_memory_{keys}"));
        let out = common::export_usda(&dir, &stage(keys));
        let scene = cirrus::scene::Scene::open(&out, &Default::default()).unwrap();
        let m = &scene.manifest;
        let keyed = |times: Option<usize>| times == Some(keys);
        assert!(keyed(m.points[0].motion.as_ref().map(|k| k.times.len())));
        assert!(keyed(m.meshes[0].motion.as_ref().map(|k| k.times.len())));
        assert!(keyed(m.curves[0].motion.as_ref().map(|k| k.times.len())));
        let mesh = &m.meshes[0];
        // Vertex values keyed: points, and normals where the mesh has them.
        let normals = mesh.motion.as_ref().unwrap().normals.is_some();
        let vertices = mesh.points.count * if normals { 2 } else { 1 };
        let triangles = mesh.triangles.count;
        let aovs = "beauty".parse().unwrap();
        let e = cirrus::memory::estimate(&scene, glam::UVec2::ONE, &aovs).unwrap();
        (e.scene, e.geometry, vertices, triangles)
    };
    let (scene_2, geometry_2, vertices, triangles) = estimate(2);
    let (scene_5, geometry_5, ..) = estimate(5);
    let more = 3;
    let spheres = (n + curve) as u64;
    assert_eq!(scene_5 - scene_2, more * 12 * (spheres + vertices));
    let built = more * (16 * spheres + 12 * vertices + 96 * triangles);
    assert_eq!(geometry_5 - geometry_2, built);
}
