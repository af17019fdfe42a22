//! `cirrus bench points-curves`: what points and curves cost. A stage of
//! N points and C cubic bspline hairs (`scenes/make_points_curves.py`) is
//! exported once; each prim alone is loaded and built into its BVHs (times
//! are medians of repeats), its resident memory measured in a fresh process
//! next to the memory estimate, and random rays through its bounds give
//! closest-hit and occlusion rates on all worker threads.

use std::path::Path;

use glam::{UVec2, Vec3A};
use rayon::prelude::*;

use super::instances::{load_timed, memory_in_child, run_venv_script, timed};
use super::machine::machine_line;
use super::stats::median;
use super::{LabError, Result};
use crate::film::AovSet;
use crate::geometry::{Geometry, Ray};
use crate::sampling::Pcg32;
use crate::scene::Scene;

/// What to measure.
pub struct PointsCurvesBench {
    /// Points of the points stage.
    pub points: usize,
    /// Hairs of the curves stage.
    pub curves: usize,
    /// Random rays per throughput measurement.
    pub rays: usize,
    /// Timed repeats of load, build and rays; the table shows medians.
    pub repeats: usize,
}

/// One stage's measurements.
struct Row {
    name: String,
    elements: u64,
    export_s: f64,
    load_s: f64,
    build_s: f64,
    /// Resident bytes after the build, and at the peak, above the RSS before loading.
    after_build: f64,
    peak: f64,
    /// `memory::estimate`'s scene plus geometry parts, bytes.
    estimate: f64,
    closest_rays_s: f64,
    shadow_rays_s: f64,
    hit_fraction: f64,
}

/// Runs the benchmark and prints its table. Stages go to a fresh folder
/// under the system temporary folder, removed at the end.
pub fn run(bench: &PointsCurvesBench) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("cirrus-bench-points-{}", std::process::id()));
    let dir = dir.as_path();
    let system = |e| LabError::system(dir.display().to_string(), e);
    std::fs::create_dir_all(dir).map_err(system)?;
    let stages = [
        (format!("{} points", bench.points), bench.points, 0),
        (format!("{} cubic hairs", bench.curves), 0, bench.curves),
    ];
    let mut rows = Vec::new();
    for (i, (name, points, curves)) in stages.into_iter().enumerate() {
        rows.push(measure(dir, i, name, [points, curves], bench)?);
    }
    std::fs::remove_dir_all(dir).map_err(system)?;
    let mb = |b: f64| b / 1e6;
    println!("{}\n", machine_line());
    println!(
        "Medians of {} repeats; {} random rays into each stage's bounds per rate, all worker \
         threads; memory is resident (VmRSS/VmHWM) above the RSS before loading, in a fresh \
         process; the estimate is `memory::estimate`'s scene + geometry; MB = 10^6 bytes.\n",
        bench.repeats.max(1),
        bench.rays
    );
    println!("| stage | spheres or tube pieces | export (s) | load (ms) | BVH build (ms) | RSS after build (MB) | peak RSS (MB) | estimate (MB) | closest-hit (Mrays/s) | occlusion (Mrays/s) | rays hitting |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        println!(
            "| {} | {} | {:.1} | {:.0} | {:.0} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {:.0}% |",
            r.name,
            r.elements,
            r.export_s,
            r.load_s * 1e3,
            r.build_s * 1e3,
            mb(r.after_build),
            mb(r.peak),
            mb(r.estimate),
            r.closest_rays_s / 1e6,
            r.shadow_rays_s / 1e6,
            100.0 * r.hit_fraction
        );
    }
    Ok(())
}

/// Generates, exports and measures one stage.
fn measure(
    dir: &Path,
    i: usize,
    name: String,
    [points, curves]: [usize; 2],
    bench: &PointsCurvesBench,
) -> Result<Row> {
    let stage = dir.join(format!("stage_{i}.usdc"));
    let args = [
        "--points".to_owned(),
        points.to_string(),
        "--curves".to_owned(),
        curves.to_string(),
    ];
    run_venv_script("scenes/make_points_curves.py", &stage, &args)?;
    let scene_dir = dir.join(format!("stage_{i}"));
    let (export_s, exported) =
        timed(|| crate::scene::export(&stage, &scene_dir, &Default::default()));
    exported?;
    let [_, after_build, peak] = memory_in_child(&scene_dir)?;
    let repeats = bench.repeats.max(1);
    let (load_s, scene) = load_timed(&scene_dir, repeats)?;
    let m = &scene.manifest;
    let elements = m.points.iter().map(|p| p.points.count).sum::<u64>()
        + m.curves
            .iter()
            .map(|c| c.points.count - c.vertex_counts.count)
            .sum::<u64>();
    let estimate = crate::memory::estimate(&scene, UVec2::ONE, &AovSet::beauty_only())
        .map_err(|e| LabError::Failed(e.to_string()))?;
    let build_s = median(
        (0..repeats)
            .map(|_| timed(|| Geometry::build(&scene, false)).0)
            .collect(),
    );
    let geometry = Geometry::build(&scene, false);
    let rays = random_rays(&scene, bench.rays);
    let rate = |occlusion: bool| {
        let seconds = median(
            (0..repeats)
                .map(|_| {
                    timed(|| {
                        rays.par_iter()
                            .filter(|ray| match occlusion {
                                true => geometry.occluded(ray, 0.0),
                                false => geometry.intersect(ray, 0.0).is_some(),
                            })
                            .count()
                    })
                    .0
                })
                .collect(),
        );
        rays.len() as f64 / seconds
    };
    let hits = rays
        .par_iter()
        .filter(|r| geometry.intersect(r, 0.0).is_some())
        .count();
    Ok(Row {
        name,
        elements,
        export_s,
        load_s,
        build_s,
        after_build,
        peak,
        estimate: (estimate.scene + estimate.geometry) as f64,
        closest_rays_s: rate(false),
        shadow_rays_s: rate(true),
        hit_fraction: hits as f64 / rays.len().max(1) as f64,
    })
}

/// `n` rays (fixed seed) from random points on the sphere around the
/// scene's bounds to random points inside them.
fn random_rays(scene: &Scene, n: usize) -> Vec<Ray> {
    let b = &scene.manifest.bounds;
    let (lo, hi) = (Vec3A::from_array(b.min), Vec3A::from_array(b.max));
    let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length());
    let mut rng = Pcg32::new(22, 7);
    (0..n)
        .map(|_| {
            let mut u = || rng.next_f32();
            let z = 2.0 * u() - 1.0;
            let phi = std::f32::consts::TAU * u();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let origin = centre + radius * Vec3A::new(r * phi.cos(), r * phi.sin(), z);
            let target = lo + (hi - lo) * Vec3A::new(u(), u(), u());
            Ray::new(origin, target - origin, 0.0, f32::INFINITY)
        })
        .collect()
}
