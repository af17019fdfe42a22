//! `cirrus bench motion`: what motion blur costs. A stage of N instanceable
//! spheres, each translating half a unit and turning 30 degrees about +Y
//! over the shutter (camera shutter 0..1; the exporter halves the key
//! spacing until no turn exceeds 5 degrees: 9 keys), under a dome, is exported once, then built and
//! rendered with the shutter closed (`--shutter 0,0`: every instance still,
//! in the world-space BVH where placed once) and open: top-level BVH build
//! time (medians), the transform tracks' memory, and samples per second at
//! equal spp. With `--volume FILE.vdb`, also a fireball advected by its
//! `vel` grid (docs/volumes.md, "Motion blur"): media build time (the
//! velocity grid read and the majorants dilated) and samples per second
//! with the shutter closed (velocity not read) and open over half a frame.
//! A third table: one deforming mesh (a 100 x 100 grid of quads whose
//! time-sampled points ripple and slide 0.5 units, 2.5 cells, over the
//! shutter), its BVH built over each triangle's union of key boxes:
//! build time and samples per second with the shutter closed and open.
//! A fourth: one moving point cloud (a 200 x 200 grid of spheres whose
//! time-sampled centres ripple and slide 0.5 units over the shutter), its
//! sphere BVH built over each sphere's union of key boxes: build time, the
//! keyed spheres' memory and samples per second, closed and open.

use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Instant;

use super::machine::machine_line;
use super::reference::{base_settings, render};
use super::stats::median;
use super::{LabError, Result};
use crate::geometry::Geometry;
use crate::integrator::Budget;
use crate::motion::Shutter;
use crate::render_state::{RenderState, StateOptions};
use crate::scene::Scene;

/// What to measure.
pub struct MotionBench {
    /// Moving instances (at least one), on a square grid.
    pub instances: usize,
    /// Image size in pixels.
    pub resolution: glam::UVec2,
    /// Samples per pixel of each timed render.
    pub spp: u32,
    /// Timed repeats of the BVH build and the render; the table shows medians.
    pub repeats: usize,
    /// A VDB with `density`, `temperature` and `vel` grids to advect.
    pub volume: Option<std::path::PathBuf>,
}

/// Bytes a moving placement's track holds per key: an `Affine3A` (48) and
/// its time (4).
const TRACK_BYTES_PER_KEY: usize = 48 + 4;

/// Runs the benchmark and prints its table; the stage and its export go to
/// a fresh folder under the system temporary folder, removed at the end.
pub fn run(bench: &MotionBench) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("cirrus-bench-motion-{}", std::process::id()));
    let system = |e| LabError::system(dir.display().to_string(), e);
    std::fs::create_dir_all(&dir).map_err(system)?;
    let usda = dir.join("motion.usda");
    std::fs::write(&usda, stage(bench.instances.max(1))).map_err(system)?;
    let start = Instant::now();
    crate::scene::export(&usda, &dir.join("scene"), &Default::default())?;
    let export_s = start.elapsed().as_secs_f64();
    let scene = Scene::load(&dir.join("scene"))?;
    let (moving, keys) = scene
        .manifest
        .instances
        .motion
        .as_ref()
        .map_or((0, 0), |m| (m.instance.count as usize, m.times.len()));
    println!("{}\n", machine_line());
    println!(
        "{} instanceable spheres ({moving} moving, {keys} keys each), exported in {export_s:.1} s; \
         {}x{} pixels, {} spp, {} threads; medians of {} repeats.\n",
        bench.instances,
        bench.resolution.x,
        bench.resolution.y,
        bench.spp,
        rayon::current_num_threads(),
        bench.repeats.max(1)
    );
    println!("| shutter | BVH build (ms) | transform tracks (MB) | samples/s (M) | render (s) |");
    println!("|---|---:|---:|---:|---:|");
    for (name, shutter, tracks) in [
        ("0,0 (still)", Shutter::CLOSED, 0),
        ("0,1 (blurred)", OPEN, moving * keys),
    ] {
        let (build, rate, seconds) = timed(bench, &scene, shutter)?;
        println!(
            "| {name} | {:.1} | {:.3} | {rate:.3} | {seconds:.2} |",
            build * 1e3,
            (tracks * TRACK_BYTES_PER_KEY) as f64 / 1e6,
        );
    }
    deforming_mesh(bench, &dir)?;
    moving_points(bench, &dir)?;
    if let Some(vdb) = &bench.volume {
        advected_volume(bench, vdb, &dir)?;
    }
    std::fs::remove_dir_all(&dir).map_err(system)?;
    Ok(())
}

/// The shutter open over the frame.
const OPEN: Shutter = Shutter {
    open: 0.0,
    close: 1.0,
};

/// Median seconds of [`Geometry::build`] under `shutter`, then samples per
/// second (millions) and median seconds of the render at `bench.spp`.
fn timed(bench: &MotionBench, scene: &Scene, shutter: Shutter) -> Result<(f64, f64, f64)> {
    let repeats = 0..bench.repeats.max(1);
    let build = median(
        repeats
            .clone()
            .map(|_| {
                let start = Instant::now();
                black_box(Geometry::build(scene, shutter.blurs()));
                start.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let options = StateOptions {
        shutter: Some(shutter),
        ..StateOptions::default()
    };
    let state = RenderState::build(scene, Some(bench.resolution), options)?;
    let seconds = median(
        repeats
            .map(|seed| {
                let settings = base_settings(Budget::Samples(bench.spp), seed as u64);
                render(&state, &settings).1.elapsed.as_secs_f64()
            })
            .collect(),
    );
    let samples = f64::from(bench.resolution.x * bench.resolution.y * bench.spp);
    Ok((build, samples / seconds / 1e6, seconds))
}

/// Quads per side of the deforming grid.
const GRID: usize = 100;

/// The third table: the deforming grid, shutter closed and open.
fn deforming_mesh(bench: &MotionBench, dir: &std::path::Path) -> Result<()> {
    let scene = exported(dir, "deforming", &grid_stage())?;
    let keys = scene.manifest.meshes[0]
        .motion
        .as_ref()
        .map_or(0, |m| m.times.len());
    println!(
        "\nOne deforming mesh: {GRID}x{GRID} quads ({} triangles, {keys} keys); {}x{} pixels, {} spp.\n",
        2 * GRID * GRID,
        bench.resolution.x,
        bench.resolution.y,
        bench.spp
    );
    println!("| shutter | BVH build (ms) | samples/s (M) | render (s) |");
    println!("|---|---:|---:|---:|");
    for (name, shutter) in [("0,0 (still)", Shutter::CLOSED), ("0,1 (deforming)", OPEN)] {
        let (build, rate, seconds) = timed(bench, &scene, shutter)?;
        println!("| {name} | {:.1} | {rate:.3} | {seconds:.2} |", build * 1e3);
    }
    Ok(())
}

/// `usda` written to `dir/NAME.usda`, exported to `dir/NAME` and loaded.
fn exported(dir: &std::path::Path, name: &str, usda: &str) -> Result<Scene> {
    let path = dir.join(format!("{name}.usda"));
    let system = |e| LabError::system(path.display().to_string(), e);
    std::fs::write(&path, usda).map_err(system)?;
    crate::scene::export(&path, &dir.join(name), &Default::default())?;
    Ok(Scene::load(&dir.join(name))?)
}

/// Spheres per side of the moving cloud.
const CLOUD: usize = 200;

/// The fourth table: the moving point cloud, shutter closed and open.
fn moving_points(bench: &MotionBench, dir: &std::path::Path) -> Result<()> {
    let scene = exported(dir, "points", &cloud_stage())?;
    let keys = scene.manifest.points[0]
        .motion
        .as_ref()
        .map_or(0, |m| m.times.len());
    let spheres = CLOUD * CLOUD;
    println!(
        "\nOne moving point cloud: {spheres} spheres ({keys} keys); {}x{} pixels, {} spp.\n",
        bench.resolution.x, bench.resolution.y, bench.spp
    );
    println!("| shutter | BVH build (ms) | keyed spheres (MB) | samples/s (M) | render (s) |");
    println!("|---|---:|---:|---:|---:|");
    for (name, shutter, keyed) in [
        ("0,0 (still)", Shutter::CLOSED, 0),
        ("0,1 (moving)", OPEN, spheres * keys),
    ] {
        let (build, rate, seconds) = timed(bench, &scene, shutter)?;
        let bytes = Geometry::keyed_bytes_for(0, 0, keyed as u64);
        println!(
            "| {name} | {:.1} | {:.3} | {rate:.3} | {seconds:.2} |",
            build * 1e3,
            bytes as f64 / 1e6
        );
    }
    Ok(())
}

/// A [`CLOUD`]-square grid of spheres 0.08 wide, 0.1 apart, in the y = 0
/// plane at frame 0; at frame 1 slid 0.5 along +X and rippled up to 0.5 in
/// y (as [`grid_stage`]'s mesh); seen from above at 45 degrees with the
/// shutter open, under a dome.
fn cloud_stage() -> String {
    let point = |i: usize, frame: f64| {
        let (x, z) = (
            0.1 * (i % CLOUD) as f64 - 10.0,
            0.1 * (i / CLOUD) as f64 - 10.0,
        );
        let y = frame * 0.5 * (x * 0.7).sin() * (z * 0.5).cos();
        format!("({}, {y}, {z})", x + 0.5 * frame)
    };
    let points = |frame: f64| {
        (0..CLOUD * CLOUD)
            .map(|i| point(i, frame))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n    \
         startTimeCode = 0\n    endTimeCode = 1\n)\n\ndef Xform \"World\"\n{{\n    def Points \"Cloud\"\n    {{\n        \
         float[] widths = [0.08] (interpolation = \"constant\")\n        \
         point3f[] points.timeSamples = {{ 0: [{}], 1: [{}] }}\n    }}\n\n    \
         def DomeLight \"Dome\"\n    {{\n    }}\n\n    def Camera \"Camera\"\n    {{\n        \
         double3 xformOp:translate = (0, 14, 14)\n        float xformOp:rotateX = -45\n        \
         uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateX\"]\n        \
         float focalLength = 18\n        double shutter:open = 0\n        double shutter:close = 1\n    }}\n}}\n",
        points(0.0),
        points(1.0),
    )
}

/// A [`GRID`]-square grid mesh 20 units wide in the y = 0 plane at frame 0;
/// at frame 1 its points have slid 0.5 along +X and rippled up to 0.5 in
/// y; seen from above at 45 degrees with the shutter open, under a dome.
fn grid_stage() -> String {
    let n = GRID + 1;
    let cell = 20.0 / GRID as f64;
    let point = |i: usize, frame: f64| {
        let (x, z) = (cell * (i % n) as f64 - 10.0, cell * (i / n) as f64 - 10.0);
        let y = frame * 0.5 * (x * 0.7).sin() * (z * 0.5).cos();
        format!("({}, {y}, {z})", x + 0.5 * frame)
    };
    let points = |frame: f64| {
        (0..n * n)
            .map(|i| point(i, frame))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let quads: Vec<String> = (0..GRID * GRID)
        .map(|q| {
            let i = q / GRID * n + q % GRID;
            format!("{}, {}, {}, {}", i, i + n, i + n + 1, i + 1)
        })
        .collect();
    format!(
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n    \
         startTimeCode = 0\n    endTimeCode = 1\n)\n\ndef Xform \"World\"\n{{\n    def Mesh \"Grid\"\n    {{\n        \
         uniform token subdivisionScheme = \"none\"\n        int[] faceVertexCounts = [{}]\n        \
         int[] faceVertexIndices = [{}]\n        point3f[] points.timeSamples = {{ 0: [{}], 1: [{}] }}\n    }}\n\n    \
         def DomeLight \"Dome\"\n    {{\n    }}\n\n    def Camera \"Camera\"\n    {{\n        \
         double3 xformOp:translate = (0, 14, 14)\n        float xformOp:rotateX = -45\n        \
         uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateX\"]\n        \
         float focalLength = 18\n        double shutter:open = 0\n        double shutter:close = 1\n    }}\n}}\n",
        vec!["4"; GRID * GRID].join(", "),
        quads.join(", "),
        points(0.0),
        points(1.0),
    )
}

/// The second table: the fireball of `vdb` (density, temperature, `vel`)
/// over a ground under a dim sky, with the shutter closed and open.
fn advected_volume(
    bench: &MotionBench,
    vdb: &std::path::Path,
    dir: &std::path::Path,
) -> Result<()> {
    let scene = exported(dir, "volume", &volume_stage(vdb))?;
    println!(
        "\nThe fireball of {} advected by its `vel` grid; {}x{} pixels, {} spp.\n",
        vdb.display(),
        bench.resolution.x,
        bench.resolution.y,
        bench.spp
    );
    println!(
        "| shutter | media build (ms) | samples/s (M) | density lookups per sample | render (s) |"
    );
    println!("|---|---:|---:|---:|---:|");
    let repeats = bench.repeats.max(1);
    for (name, shutter) in [
        ("0,0 (still)", Shutter::CLOSED),
        ("0,0.5 (advected)", Shutter::new(0.0, 0.5).expect("valid")),
    ] {
        let options = StateOptions {
            shutter: Some(shutter),
            ..StateOptions::default()
        };
        let mut builds = Vec::new();
        let mut state = None;
        for _ in 0..repeats {
            let start = Instant::now();
            state = Some(RenderState::build(&scene, Some(bench.resolution), options)?);
            builds.push(start.elapsed().as_secs_f64());
        }
        let state = state.expect("at least one repeat");
        let (mut seconds, mut lookups) = (Vec::new(), 0);
        for seed in 0..repeats {
            let settings = base_settings(Budget::Samples(bench.spp), seed as u64);
            let stats = render(&state, &settings).1;
            seconds.push(stats.elapsed.as_secs_f64());
            lookups = stats.tracking.density_lookups;
        }
        let seconds = median(seconds);
        let samples = f64::from(bench.resolution.x * bench.resolution.y * bench.spp);
        println!(
            "| {name} | {:.0} | {:.3} | {:.2} | {seconds:.2} |",
            median(builds) * 1e3,
            samples / seconds / 1e6,
            lookups as f64 / samples
        );
    }
    Ok(())
}

/// scenes/demo/explosion.usda's fireball reading `vdb`, with its velocity
/// field, seen by a camera whose shutter is open over half a frame.
fn volume_stage(vdb: &std::path::Path) -> String {
    let asset = |name: &str, grid: &str| {
        format!(
            "        def OpenVDBAsset \"{name}\"\n        {{\n            asset filePath = @{}@\n            \
             token fieldName = \"{grid}\"\n        }}\n",
            vdb.display()
        )
    };
    format!(
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n    \
         startTimeCode = 0\n    endTimeCode = 0\n)\n\n\
         def Xform \"World\"\n{{\n    def Volume \"Explosion\"\n    {{\n        \
         rel field:density = </World/Explosion/density>\n        \
         rel field:temperature = </World/Explosion/temperature>\n        \
         rel field:velocity = </World/Explosion/velocity>\n        float primvars:densityScale = 12\n        \
         color3f primvars:albedo = (0.3, 0.3, 0.3)\n        float primvars:anisotropy = 0.3\n        \
         float primvars:heatScale = 0.01\n        float primvars:temperatureOffset = 0\n        \
         float primvars:temperatureScale = 1\n        double3 xformOp:translate = (0, 1, 0)\n        \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n{}{}{}    }}\n\n    \
         def Mesh \"Ground\"\n    {{\n        int[] faceVertexCounts = [4]\n        \
         int[] faceVertexIndices = [0, 1, 2, 3]\n        \
         point3f[] points = [(-20, 0, 20), (20, 0, 20), (20, 0, -20), (-20, 0, -20)]\n    }}\n\n    \
         def DomeLight \"Sky\"\n    {{\n        color3f inputs:color = (0.4, 0.5, 0.7)\n        \
         float inputs:intensity = 0.15\n    }}\n\n    def Camera \"Camera\"\n    {{\n        \
         double3 xformOp:translate = (0, 1.2, 5.5)\n        uniform token[] xformOpOrder = [\"xformOp:translate\"]\n        \
         float focalLength = 35\n        double shutter:open = 0\n        double shutter:close = 0.5\n    }}\n}}\n",
        asset("density", "density"),
        asset("temperature", "temperature"),
        asset("velocity", "vel"),
    )
}

/// The stage: `n` instanceable unit spheres on a square grid 3 units apart
/// in the y = 0 plane, each sliding 0.5 along +X and turning 30 degrees
/// over frames 0..1, seen from above at 45 degrees with the shutter open
/// over the frame, under a white dome.
fn stage(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let extent = 3.0 * side as f64;
    let mut usda = format!(
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n    \
         startTimeCode = 0\n    endTimeCode = 1\n)\n\nclass Xform \"_Ball\"\n{{\n    def Sphere \"Geo\"\n    \
         {{\n        double radius = 1\n    }}\n}}\n\ndef Xform \"World\"\n{{\n    def Camera \"Camera\"\n    \
         {{\n        double3 xformOp:translate = ({c}, {h}, {d})\n        float xformOp:rotateX = -45\n        \
         uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateX\"]\n        \
         float focalLength = 18\n        double shutter:open = 0\n        double shutter:close = 1\n    }}\n\n    \
         def DomeLight \"Dome\"\n    {{\n    }}\n",
        c = extent / 2.0,
        h = extent * 0.8,
        d = extent * 1.3,
    );
    for i in 0..n {
        let (x, z) = (3.0 * (i % side) as f64, 3.0 * (i / side) as f64);
        let _ = write!(
            usda,
            "\n    def Xform \"B{i}\" (\n        instanceable = true\n        prepend references = </_Ball>\n    )\n    \
             {{\n        double3 xformOp:translate.timeSamples = {{ 0: ({x}, 0, {z}), 1: ({}, 0, {z}) }}\n        \
             float xformOp:rotateY.timeSamples = {{ 0: 0, 1: 30 }}\n        \
             uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateY\"]\n    }}\n",
            x + 0.5
        );
    }
    usda.push_str("}\n");
    usda
}
