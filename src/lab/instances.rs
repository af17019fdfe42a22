//! `cirrus bench instances`: what instancing costs to ingest. A
//! stage of N PointInstancer instances of one T-triangle sphere
//! (`scenes/make_instancing_stress.py`) is exported, loaded and built into
//! the two-level BVH (memory: with the Cryptomatte names a render keeps,
//! `InstanceNames`, 8 bytes per instance); the same prototype with one instance is the baseline,
//! so what N instances cost beyond the prototype is measured, not estimated.
//!
//! `Geometry::build` builds both BVH levels in one call, so the BLAS time is
//! the baseline's build (one mesh BVH and a one-leaf TLAS) and the TLAS time
//! is the difference of the two builds' medians.

use std::hint::black_box;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use super::machine::machine_line;
use super::stats::median;
use super::{LabError, Result};
use crate::geometry::Geometry;
use crate::scene::{InstanceNames, Scene};

/// The target for load plus TLAS build at 1M instances, in seconds.
const TARGET_SECONDS: f64 = 3.0;
/// The target for peak memory beyond the prototype, in bytes (250 MB).
const TARGET_BYTES: f64 = 250e6;

/// What to measure.
pub struct InstancesBench {
    /// PointInstancer instances in the measured stage (at least one).
    pub instances: usize,
    /// Approximate triangles of the prototype sphere (at least 8).
    pub triangles: usize,
    /// Timed repeats of load and build (at least one); the table shows medians.
    pub repeats: usize,
}

/// What one stage cost: medians of the timed repeats and one memory pass.
struct Costs {
    export_s: f64,
    load_s: f64,
    build_s: f64,
    /// Resident bytes added by the loaded scene (above the RSS before loading).
    after_load: f64,
    /// Resident bytes added by the scene and its BVHs together.
    after_build: f64,
    /// Peak resident bytes above the RSS before loading, over load and build.
    peak: f64,
}

/// Runs the benchmark and prints its table: `instances` instances of a
/// sphere of about `triangles` triangles, load and build timed `repeats`
/// times each. Stages and exports go to a fresh folder under the system
/// temporary folder, removed at the end.
pub fn run(bench: &InstancesBench) -> Result<()> {
    let instances = bench.instances.max(1);
    let triangles = bench.triangles.max(8);
    let repeats = bench.repeats.max(1);
    // The 1, 5 and 15 minute load averages: other jobs on the machine skew times.
    let load_average = || {
        let text = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
        text.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    };
    let load_average_start = load_average();
    let dir = std::env::temp_dir().join(format!("cirrus-bench-instances-{}", std::process::id()));
    let dir = dir.as_path();
    std::fs::create_dir_all(dir).map_err(|e| LabError::system(dir.display().to_string(), e))?;
    // The baseline first: it also starts the thread pool the timed builds use.
    let base = measure(dir, 1, triangles, repeats)?;
    let big = measure(dir, instances, triangles, repeats)?;
    std::fs::remove_dir_all(dir).map_err(|e| LabError::system(dir.display().to_string(), e))?;

    let ms = |s: f64| s * 1e3;
    let mb = |b: f64| b / 1e6;
    println!("{}\n", machine_line());
    println!(
        "Prototype: sphere of about {triangles} triangles; medians of {repeats} repeats \
         (export once); memory is resident (VmRSS/VmHWM) above the RSS before loading, \
         in a fresh process per stage; MB = 10^6 bytes.\n"
    );
    println!("| stage | export (s) | load (ms) | build, BLAS + TLAS (ms) | RSS after load (MB) | RSS after build (MB) | peak RSS (MB) |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (name, c) in [
        ("1 instance (baseline)", &base),
        (&*format!("{instances} instances"), &big),
    ] {
        println!(
            "| {name} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            c.export_s,
            ms(c.load_s),
            ms(c.build_s),
            mb(c.after_load),
            mb(c.after_build),
            mb(c.peak)
        );
    }
    println!(
        "| difference (beyond the prototype) | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |\n",
        big.export_s - base.export_s,
        ms(big.load_s - base.load_s),
        ms(big.build_s - base.build_s),
        mb(big.after_load - base.after_load),
        mb(big.after_build - base.after_build),
        mb(big.peak - base.peak)
    );
    let tlas_s = big.build_s - base.build_s;
    let seconds = big.load_s + tlas_s;
    let beyond = big.peak - base.peak;
    let verdict = |met: bool| if met { "met" } else { "NOT met" };
    println!(
        "BLAS (the baseline's build): {:.1} ms; TLAS over {instances} instances (build difference): {:.1} ms.",
        ms(base.build_s),
        ms(tlas_s)
    );
    println!(
        "Targets: load + TLAS build < {TARGET_SECONDS} s: {seconds:.2} s, {}; \
         peak memory beyond the prototype < {} MB: {:.1} MB, {}.",
        verdict(seconds < TARGET_SECONDS),
        mb(TARGET_BYTES),
        mb(beyond),
        verdict(beyond < TARGET_BYTES)
    );
    println!(
        "Load average (1, 5, 15 min) at start: {}; at end: {}.",
        load_average_start
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" "),
        load_average()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    Ok(())
}

/// Generates and exports the stage of `instances` instances in `dir`, then
/// measures memory over one load and build in a fresh process, and times
/// `repeats` of each here.
fn measure(dir: &Path, instances: usize, triangles: usize, repeats: usize) -> Result<Costs> {
    let stage = dir.join(format!("stress_{instances}.usdc"));
    let args = [
        "--instances".to_owned(),
        instances.to_string(),
        "--triangles".to_owned(),
        triangles.to_string(),
    ];
    run_venv_script("scenes/make_instancing_stress.py", &stage, &args)?;
    let scene_dir = dir.join(format!("stress_{instances}"));
    let start = Instant::now();
    crate::scene::export(&stage, &scene_dir, &Default::default())?;
    let export_s = start.elapsed().as_secs_f64();

    let [after_load, after_build, peak] = memory_in_child(&scene_dir)?;
    let (load_s, scene) = load_timed(&scene_dir, repeats)?;
    let count = scene.manifest.instances.count;
    if count != instances as u64 {
        return Err(LabError::Failed(format!(
            "{}: {count} instances exported, {instances} generated",
            scene_dir.display()
        )));
    }
    let build_s = median(
        (0..repeats)
            .map(|_| timed(|| Geometry::build(&scene, true)).0)
            .collect(),
    );
    Ok(Costs {
        export_s,
        load_s,
        build_s,
        after_load,
        after_build,
        peak,
    })
}

/// The median seconds of `repeats` loads of `scene_dir`, and the scene.
pub(super) fn load_timed(scene_dir: &Path, repeats: usize) -> Result<(f64, Scene)> {
    let seconds = (0..repeats.max(1)).map(|_| {
        let (seconds, scene) = timed(|| Scene::load(scene_dir));
        scene.map(|_| seconds)
    });
    let seconds = median(seconds.collect::<Result<_, _>>()?);
    Ok((seconds, Scene::load(scene_dir)?))
}

/// Seconds `f` took, and its result (dropped by the caller, off the clock).
pub(super) fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let value = black_box(f());
    (start.elapsed().as_secs_f64(), value)
}

/// Runs a stage generator (`script`, relative to the checkout) writing
/// `stage` with `args`, under the `.venv` of the checkout named by
/// `$CIRRUS_HOME` (else the one this binary was built from).
pub(super) fn run_venv_script(script: &str, stage: &Path, args: &[String]) -> Result<()> {
    let root = super::scenes::repo_root();
    let script = root.join(script);
    let out = Command::new(root.join(".venv/bin/python"))
        .arg(&script)
        .arg(stage)
        .args(args)
        .output()
        .map_err(|e| LabError::system(format!("running {}", script.display()), e))?;
    if !out.status.success() {
        return Err(LabError::Failed(format!(
            "{} failed: {}",
            script.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(())
}

/// Runs [`print_memory`] on `scene_dir` in a fresh `cirrus` process and
/// returns its three numbers. A fresh process per stage keeps memory freed by
/// an earlier stage, and kept by the allocator, out of the next one's count.
pub(super) fn memory_in_child(scene_dir: &Path) -> Result<[f64; 3]> {
    numbers_in_child(&["bench", "instances-memory"], scene_dir)
}

/// Runs `cirrus ARGS SCENE_DIR` in a fresh process and returns the `N`
/// numbers it prints; an error with its output when it fails or prints
/// another count.
pub(super) fn numbers_in_child<const N: usize>(
    args: &[&str],
    scene_dir: &Path,
) -> Result<[f64; N]> {
    let exe = std::env::current_exe()
        .map_err(|e| LabError::system("finding the cirrus executable", e))?;
    let out = Command::new(&exe)
        .args(args)
        .arg(scene_dir)
        .output()
        .map_err(|e| LabError::system(format!("running {}", exe.display()), e))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let numbers: Vec<f64> = stdout
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    match (out.status.success(), <[f64; N]>::try_from(numbers)) {
        (true, Ok(numbers)) => Ok(numbers),
        _ => Err(LabError::Failed(format!(
            "cirrus {} {}: {}{}",
            args.join(" "),
            scene_dir.display(),
            stdout.trim(),
            String::from_utf8_lossy(&out.stderr).trim()
        ))),
    }
}

/// Loads `scene_dir` and builds its BVHs and its Cryptomatte names (what a
/// render keeps per instance beside the BVHs), then prints the resident
/// bytes this added after the load, after the build, and at the peak (VmRSS, VmRSS and
/// VmHWM, each minus the VmRSS before loading), space-separated on one line.
/// Meant for a process that has done nothing else (see [`memory_in_child`]).
pub fn print_memory(scene_dir: &Path) -> Result<()> {
    let before = memory("VmRSS")?;
    // Writing 5 resets VmHWM to the current RSS (proc(5), Linux >= 4.0), so
    // start-up's own peak is not counted.
    std::fs::write("/proc/self/clear_refs", "5")
        .map_err(|e| LabError::system("resetting the peak RSS", e))?;
    let scene = Scene::load(scene_dir)?;
    let after_load = memory("VmRSS")? - before;
    let geometry = Geometry::build(&scene, true);
    let names = InstanceNames::new(&scene);
    let after_build = memory("VmRSS")? - before;
    let peak = memory("VmHWM")? - before;
    black_box((&geometry, &names));
    println!("{after_load} {after_build} {peak}");
    Ok(())
}

/// A `/proc/self/status` memory field (`VmRSS`, `VmHWM`), in bytes.
pub(super) fn memory(field: &str) -> Result<f64> {
    let status = std::fs::read_to_string("/proc/self/status")
        .map_err(|e| LabError::system("/proc/self/status", e))?;
    status
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().strip_suffix("kB")?.trim().parse::<f64>().ok())
        .map(|kb| kb * 1024.0)
        .ok_or_else(|| LabError::Failed(format!("no {field} in /proc/self/status")))
}
