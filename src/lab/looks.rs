//! `cirrus bench looks`: what the material work costs. The chess set
//! (textured UsdPreviewSurface and MaterialX looks) first, in a fresh
//! process so that its peak memory is its own: export seconds (usd-core,
//! once), then load and render-state build seconds (scene.bin, BVHs, the
//! textures decoded) as medians of repeats, its materials by model and its
//! textures, and the resident memory after the build and at its peak
//! (VmRSS/VmHWM above the RSS before loading). Then the shader ball:
//! camera-path samples per second, median of repeats, for comparison with
//! a binary from before OpenPBR (issue 21's budget: at most 15% slower on
//! PreviewSurface-only scenes; the StandardShaderBall's MaterialX looks are
//! now read as OpenPBR, so that comparison needs a PreviewSurface scene).

use std::path::{Path, PathBuf};

use glam::UVec2;

use super::aovs::settings;
use super::instances::{memory, numbers_in_child, timed};
use super::machine::{machine_line, with_threads};
use super::scenes::scene_name;
use super::stats::median;
use super::{LabError, Result};
use crate::film::AovSet;
use crate::integrator;
use crate::render_state::{RenderState, StateOptions};
use crate::scene::Scene;

/// What to measure.
pub struct LooksBench {
    /// The StandardShaderBall stage (or a PreviewSurface-only scene).
    pub shader_ball: PathBuf,
    /// The OpenChessSet stage (or another textured scene).
    pub chess_set: PathBuf,
    /// Image size of the shader ball renders.
    pub resolution: UVec2,
    /// Samples per pixel of each shader ball render.
    pub spp: u32,
    /// Timed repeats; the table shows medians.
    pub repeats: usize,
    /// Worker threads of the renders and builds.
    pub threads: usize,
}

/// Runs the benchmark and prints its tables.
pub fn run(bench: &LooksBench) -> Result<()> {
    println!("{}\n", machine_line());
    let dir = std::env::temp_dir().join(format!("cirrus-bench-looks-{}", std::process::id()));
    let exported = dir.join(scene_name(&bench.chess_set));
    let (export_s, result) =
        timed(|| crate::scene::export(&bench.chess_set, &exported, &Default::default()));
    result?;
    let [rss, peak] = memory_in_child(&exported, bench.threads)?;
    let (load_s, build_s, scene) = with_threads_value(bench.threads, || {
        load_and_build_timed(&exported, bench.repeats)
    })?;
    let _ = std::fs::remove_dir_all(&dir);
    let models: Vec<&str> = scene.manifest.material_models().collect();
    let count = |model| models.iter().filter(|m| **m == model).count();
    println!(
        "Chess set ({}): export once, load and build medians of {}; memory in a fresh process, \
         above its RSS before loading.\n",
        bench.chess_set.display(),
        bench.repeats
    );
    println!("| scene | materials (preview / open_pbr) | textures | export s | load s | build s | RSS after build (MB) | peak RSS (MB) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "| {} | {} / {} | {} | {export_s:.2} | {load_s:.3} | {build_s:.3} | {:.0} | {:.0} |\n",
        scene_name(&bench.chess_set),
        count("preview_surface"),
        count("open_pbr"),
        scene.manifest.textures.len(),
        rss / 1e6,
        peak / 1e6
    );
    drop(scene);
    let rate = with_threads_value(bench.threads, || {
        samples_per_second(&bench.shader_ball, bench)
    })?;
    println!(
        "Shader ball ({}): {}x{}, {} spp, {} threads, median of {}.\n",
        bench.shader_ball.display(),
        bench.resolution.x,
        bench.resolution.y,
        bench.spp,
        bench.threads,
        bench.repeats
    );
    println!("| scene | samples/s |\n|---|---:|");
    println!("| {} | {rate:.4e} |", scene_name(&bench.shader_ball));
    Ok(())
}

/// `f`'s value, run on a pool of `threads` workers.
fn with_threads_value<T: Send>(threads: usize, f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    let mut value = None;
    with_threads(threads, || {
        value = Some(f()?);
        Ok(())
    })?;
    value.ok_or_else(|| LabError::Failed("no value".into()))
}

/// Median seconds of `repeats` loads and render-state builds (textures
/// included) of `scene_dir`, and the scene.
fn load_and_build_timed(scene_dir: &Path, repeats: usize) -> Result<(f64, f64, Scene)> {
    let (mut loads, mut builds) = (Vec::new(), Vec::new());
    for _ in 0..repeats.max(1) {
        let (load_s, scene) = timed(|| Scene::load(scene_dir));
        let scene = scene?;
        let (build_s, state) = timed(|| RenderState::build(&scene, None, StateOptions::default()));
        drop(state?);
        loads.push(load_s);
        builds.push(build_s);
    }
    Ok((median(loads), median(builds), Scene::load(scene_dir)?))
}

/// Camera-path samples per second of the shader ball, median of repeats
/// (render state built once, not timed).
fn samples_per_second(path: &Path, bench: &LooksBench) -> Result<f64> {
    let scene = Scene::open(path, &Default::default())?;
    let state = RenderState::build(&scene, Some(bench.resolution), StateOptions::default())?;
    let settings = settings(bench.spp, AovSet::beauty_only());
    let samples = f64::from(bench.resolution.x * bench.resolution.y) * f64::from(bench.spp);
    let rates = (0..bench.repeats.max(1)).map(|_| {
        let (_, stats) = integrator::render(&state, &settings, &|_| {});
        samples / stats.elapsed.as_secs_f64()
    });
    Ok(median(rates.collect()))
}

/// Runs [`print_memory`] on `scene_dir` in a fresh `cirrus` process: its
/// resident bytes after the render-state build and at their peak.
fn memory_in_child(scene_dir: &Path, threads: usize) -> Result<[f64; 2]> {
    let threads = threads.to_string();
    numbers_in_child(&["bench", "looks-memory", "--threads", &threads], scene_dir)
}

/// Internal to `bench looks`: loads `scene_dir` and builds its render state
/// (textures included) on `threads` workers, then prints the resident bytes
/// added after the build and at the peak.
pub fn print_memory(scene_dir: &Path, threads: usize) -> Result<()> {
    with_threads(threads, || {
        let before = memory("VmRSS")?;
        // Writing 5 resets VmHWM to the current RSS (proc(5), Linux >= 4.0).
        std::fs::write("/proc/self/clear_refs", "5")
            .map_err(|e| LabError::system("resetting the peak RSS", e))?;
        let scene = Scene::load(scene_dir)?;
        let state = RenderState::build(&scene, None, StateOptions::default())?;
        let after = memory("VmRSS")? - before;
        let peak = memory("VmHWM")? - before;
        std::hint::black_box(&state);
        println!("{after} {peak}");
        Ok(())
    })
}
