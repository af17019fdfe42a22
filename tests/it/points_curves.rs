//! Points (analytic spheres) and curves (linear round tubes) end to end:
//! USD stages through the exporter's `points`/`curves` records, the loader
//! and the geometry. Coverage of parallel rays (random, fixed seed) against
//! the analytic projected area within 4 sigma, directly and through a
//! PointInstancer; the bad inputs of issue 22 (a warning each, naming prim
//! and attribute, never a crash); a tiny render with finite pixels.

use crate::common;
use std::path::{Path, PathBuf};

use cirrus::geometry::{Geometry, Ray};
use cirrus::sampling::Pcg32;
use cirrus::scene::Scene;
use glam::{Vec3, Vec3A};

use crate::common::{assert_within_4_sigma, cirrus_ok, estimate, scratch};

/// `body` (prims under a Y-up, metre stage) as a stage in `dir`, exported.
fn export_stage(dir: &Path, body: &str) -> PathBuf {
    let header = "#usda 1.0\n(\n    upAxis = \"Y\"\n    metersPerUnit = 1\n)\n";
    common::export_usda(dir, &format!("{header}{body}\n"))
}

/// Rays down -z from uniformly random points of the window
/// [x0, x1] x [y0, y1] (fixed seed): the estimate of the covered fraction,
/// and every hit checked by `check`.
fn coverage(
    geometry: &Geometry,
    [x0, x1, y0, y1]: [f32; 4],
    n: usize,
    mut check: impl FnMut(Vec3, Vec3),
) -> common::Estimate {
    let mut rng = Pcg32::new(22, 3);
    let hits = (0..n).map(|_| {
        let x = x0 + (x1 - x0) * rng.next_f32();
        let y = y0 + (y1 - y0) * rng.next_f32();
        let ray = Ray::new(Vec3A::new(x, y, 50.0), Vec3A::NEG_Z, 0.0, f32::INFINITY);
        match geometry.intersect(&ray, 0.0) {
            Some(hit) => {
                let sp = geometry.surface_point(&hit);
                check(sp.p, sp.ng);
                1.0
            }
            None => 0.0,
        }
    });
    estimate(hits.collect::<Vec<f64>>())
}

/// Twelve spheres of three diameters (per-point widths) on a grid, apart:
/// the fraction of the window they cover is the sum of their discs' areas
/// over the window's; every hit lies on its sphere with an outward normal.
#[test]
fn spheres_cover_their_projected_area() {
    let dir = scratch("points_area");
    let (mut points, mut widths, mut centres) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..12 {
        let (x, y, w) = (
            (k % 4) as f32 * 2.0,
            (k / 4) as f32 * 2.0,
            [0.5, 1.0, 1.5][k % 3],
        );
        points.push(format!("({x}, {y}, 0)"));
        widths.push(w.to_string());
        centres.push((Vec3::new(x, y, 0.0), 0.5 * w));
    }
    let out = export_stage(
        &dir,
        &format!(
            "def Points \"Dots\"\n{{\n point3f[] points = [{}]\n float[] widths = [{}] (interpolation = \"vertex\")\n}}",
            points.join(", "),
            widths.join(", ")
        ),
    );
    let scene = Scene::load(&out).unwrap();
    let geometry = Geometry::build(&scene, false);
    let window = [-1.0, 7.0, -1.0, 5.0];
    let area: f64 = centres
        .iter()
        .map(|(_, r)| std::f64::consts::PI * f64::from(r * r))
        .sum();
    let measured = coverage(&geometry, window, 40_000, |p, ng| {
        let (c, r) = centres
            .iter()
            .min_by(|a, b| (a.0 - p).length().total_cmp(&(b.0 - p).length()))
            .unwrap();
        assert!(
            ((p - *c).length() - r).abs() < 1e-4 * r.max(1.0),
            "{p} off its sphere"
        );
        assert!(
            ng.dot(p - *c) > 0.0 && ng.z > 0.0,
            "{ng} not outward at {p}"
        );
    });
    assert_within_4_sigma("sphere coverage", measured, area / 48.0, 1e-4);
}

/// A straight linear curve of width w and length L seen side on covers a
/// capsule's silhouette: L w + pi (w/2)^2.
#[test]
fn linear_curve_covers_its_analytic_area() {
    let dir = scratch("curves_area");
    let out = export_stage(
        &dir,
        "def BasisCurves \"Strand\"\n{\n uniform token type = \"linear\"\n int[] curveVertexCounts = [3]\n point3f[] points = [(0, 0, 0), (1.5, 0, 0), (3, 0, 0)]\n float[] widths = [0.4] (interpolation = \"constant\")\n}",
    );
    let scene = Scene::load(&out).unwrap();
    let warnings = scene.manifest.warnings.join("\n");
    assert!(
        warnings.contains("/Strand has no bound material") && warnings.contains("hair"),
        "{warnings}"
    );
    let geometry = Geometry::build(&scene, false);
    let (length, w) = (3.0f64, 0.4f64);
    let area = length * w + std::f64::consts::PI * (w / 2.0).powi(2);
    let measured = coverage(&geometry, [-0.5, 3.5, -0.5, 0.5], 40_000, |p, ng| {
        let axis = Vec3::new(p.x.clamp(0.0, 3.0), 0.0, 0.0);
        assert!(((p - axis).length() - 0.2).abs() < 1e-4, "{p} off the tube");
        assert!(ng.dot(p - axis) > 0.0, "{ng} not outward at {p}");
    });
    assert_within_4_sigma("curve coverage", measured, area / 4.0, 1e-4);
}

/// A PointInstancer places a prototype of spheres and a straight curve
/// twice, once as authored and once scaled by 2 elsewhere: the coverage is
/// (1 + 4) times the prototype's own.
#[test]
fn points_and_curves_through_instances() {
    let dir = scratch("points_curves_instanced");
    let out = export_stage(
        &dir,
        r#"def PointInstancer "Scatter"
{
    rel prototypes = [</Scatter/Protos/Tuft>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (6, 0, 0)]
    float3[] scales = [(1, 1, 1), (2, 2, 2)]
    def Scope "Protos"
    {
        def Xform "Tuft"
        {
            def Points "Dots"
            {
                point3f[] points = [(0, 0, 0), (1, 0, 0)]
                float[] widths = [0.6] (interpolation = "constant")
            }
            def BasisCurves "Strand"
            {
                uniform token type = "linear"
                int[] curveVertexCounts = [2]
                point3f[] points = [(0, 1, 0), (1, 1, 0)]
                float[] widths = [0.2] (interpolation = "constant")
            }
        }
    }
}"#,
    );
    let scene = Scene::load(&out).unwrap();
    assert_eq!(scene.manifest.instances.count, 2);
    let geometry = Geometry::build(&scene, false);
    let pi = std::f64::consts::PI;
    let tuft = 2.0 * pi * 0.09 + (1.0 * 0.2 + pi * 0.01);
    let window = [-1.0, 9.0, -1.0, 3.0];
    let measured = coverage(&geometry, window, 40_000, |_, _| {});
    assert_within_4_sigma("instanced coverage", measured, 5.0 * tuft / 40.0, 1e-4);
}

/// Bad input is named, counted and skipped, never a crash: points whose
/// width is negative or NaN; curves whose curveVertexCounts do not match
/// their points; points and curves with no widths drawn at USD's
/// (Hydra's) default diameter 1; a periodic cubic curve of two vertices
/// (it crashed the exporter) is a closed loop.
#[test]
fn bad_points_and_curves_are_named() {
    let dir = scratch("points_curves_bad");
    let out = export_stage(
        &dir,
        r#"def Points "Dots"
{
    point3f[] points = [(0, 0, 0), (2, 0, 0), (4, 0, 0), (6, 0, 0)]
    float[] widths = [1, -1, 0.5, nan] (interpolation = "vertex")
}
def BasisCurves "Miscounted"
{
    uniform token type = "linear"
    int[] curveVertexCounts = [3]
    point3f[] points = [(0, 0, 0), (1, 1, 0)]
}
def Points "Unsized"
{
    point3f[] points = [(0, 5, 0)]
}
def BasisCurves "Thin"
{
    uniform token type = "cubic"
    uniform token basis = "catmullRom"
    int[] curveVertexCounts = [4]
    point3f[] points = [(0, 8, 0), (1, 9, 0), (2, 8, 0), (3, 9, 0)]
}
def BasisCurves "Loop"
{
    uniform token type = "cubic"
    uniform token basis = "bspline"
    uniform token wrap = "periodic"
    int[] curveVertexCounts = [2]
    point3f[] points = [(0, 12, 0), (3, 12, 0)]
    float[] widths = [0.1] (interpolation = "constant")
}"#,
    );
    let scene = Scene::load(&out).unwrap();
    let warnings = scene.manifest.warnings.join("\n");
    for what in [
        "Points /Dots: 2 of 4 points skipped: widths negative or not finite",
        "BasisCurves /Miscounted skipped: curveVertexCounts sums to 3 but points has 2 values",
        "Points /Unsized has no widths; drawn with USD's (Hydra's) default diameter 1",
        "BasisCurves /Thin has no widths",
    ] {
        assert!(warnings.contains(what), "no '{what}' in:\n{warnings}");
    }
    let m = &scene.manifest;
    assert_eq!(m.points.len(), 2);
    assert_eq!(m.curves.len(), 2);
    let closed = scene.view(&m.curves[1].points);
    assert!(
        closed.len() > 2 && closed.first() == closed.last(),
        "{closed:?}"
    );
    assert_eq!(scene.view(&m.points[0].widths), [1.0, 0.5]);
    assert_eq!(scene.view(&m.points[1].widths), [1.0]);
    assert!(scene.view(&m.curves[0].widths).iter().all(|&w| w == 1.0));
    // The catmullRom segment runs from the second to the third point.
    let vertices = scene.view(&m.curves[0].points);
    assert_eq!(vertices.first(), Some(&[1.0, 9.0, 0.0]));
    assert_eq!(vertices.last(), Some(&[2.0, 8.0, 0.0]));
}

/// A render of points with per-point displayColor and a cubic curve under a
/// dome: every pixel finite, the points' colours where they are.
#[test]
fn points_and_curves_render() {
    let dir = scratch("points_curves_render");
    let out = export_stage(
        &dir,
        r#"def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def DomeLight "Dome"
{
    float inputs:intensity = 1
}
def Points "Dots"
{
    point3f[] points = [(-1.5, 0, 0), (1.5, 0, 0)]
    float[] widths = [2] (interpolation = "constant")
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "vertex")
}
def BasisCurves "Hair"
{
    uniform token type = "cubic"
    uniform token basis = "bspline"
    uniform token wrap = "pinned"
    int[] curveVertexCounts = [4]
    point3f[] points = [(-2, 2, 0), (-1, 3, 0), (1, 2, 0), (2, 3, 0)]
    float[] widths = [0.2, 0.2, 0.1, 0.05] (interpolation = "vertex")
}"#,
    );
    let exr = dir.join("out.exr");
    cirrus_ok(&[
        "render".as_ref(),
        out.as_os_str(),
        "-o".as_ref(),
        exr.as_os_str(),
        "--res".as_ref(),
        "32x32".as_ref(),
        "--spp".as_ref(),
        "4".as_ref(),
        "--aovs".as_ref(),
        "beauty".as_ref(),
    ]);
    let image = common::aovs::Exr::read(&exr);
    let (r, b) = (image.plane("R"), image.plane("B"));
    assert!(r.iter().chain(b).all(|v| v.is_finite()));
    // Row 16, a quarter in from either side: the red and the blue sphere.
    let at = |x: usize| 16 * 32 + x;
    assert!(r[at(9)] > 2.0 * b[at(9)], "left sphere not red");
    assert!(b[at(22)] > 2.0 * r[at(22)], "right sphere not blue");
}

/// A points prim on a moving plain prim (translated 4 units along x over
/// the shutter) goes under the top level like a moving mesh: a ray at time
/// t meets the sphere where the instance is at t, and nowhere else.
#[test]
fn points_move_with_their_instance() {
    let dir = scratch("points_motion");
    let out = common::export_usda(
        &dir,
        r#"#usda 1.0
(
    metersPerUnit = 1
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 1
)
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    double shutter:open = 0
    double shutter:close = 1
}
def Xform "Mover"
{
    double3 xformOp:translate.timeSamples = {0: (0, 0, 0), 1: (4, 0, 0)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Points "Dot"
    {
        point3f[] points = [(0, 0, 0)]
        float[] widths = [1]
    }
}
"#,
    );
    let scene = Scene::load(&out).unwrap();
    let geometry = Geometry::build(&scene, true);
    let hit_at = |x: f32, time: f32| {
        let ray = Ray::new(Vec3A::new(x, 0.0, 5.0), Vec3A::NEG_Z, 0.0, f32::INFINITY);
        geometry
            .intersect(&ray, time)
            .map(|hit| geometry.surface_point(&hit).p)
    };
    for (x, time) in [(0.0, 0.0), (2.0, 0.5), (4.0, 1.0)] {
        let p = hit_at(x, time).unwrap_or_else(|| panic!("no hit at x {x}, time {time}"));
        assert!(
            (p - Vec3::new(x, 0.0, 0.5)).length() < 1e-4,
            "{p} at time {time}"
        );
    }
    assert!(hit_at(4.0, 0.0).is_none() && hit_at(0.0, 1.0).is_none());
}
