//! `cirrus bench subdivision`: what refining subdivision surfaces at load
//! costs. Per scene: the cages and their triangles, refinement time (wall
//! clock, parallel over meshes) and the mesh arrays it adds, then camera-path
//! samples per second rendering the cages (before subdivision existed) and
//! the refined surfaces.

use std::path::PathBuf;

use glam::UVec2;

use super::aovs::settings;
use super::machine::{machine_line, with_threads};
use super::scenes::scene_name;
use super::Result;
use crate::film::AovSet;
use crate::integrator;
use crate::render_state::{RenderState, StateOptions};
use crate::scene::{OpenOptions, Refinement, Scene};

/// Image size of the sample-rate renders.
const RESOLUTION: UVec2 = UVec2::new(160, 120);
/// Samples per pixel of the sample-rate renders.
const SPP: u32 = 4;
/// Worker threads.
const THREADS: usize = 2;

/// Measures `scenes` (USD or exported) at subdivision `level` (meshes' own
/// primvar levels still win) and prints the table.
pub fn run(scenes: &[PathBuf], level: u32) -> Result<()> {
    with_threads(THREADS, || {
        println!("{}\n", machine_line());
        println!(
            "Level {level}; samples/s at {}x{}, {SPP} spp, {THREADS} threads, cages (before) and refined (after).\n",
            RESOLUTION.x, RESOLUTION.y
        );
        println!("| scene | cages | cage triangles | triangles | refine s | added MiB | samples/s before | samples/s after |");
        println!("|---|---:|---:|---:|---:|---:|---:|---:|");
        for path in scenes {
            let open = |refinement| {
                Scene::open(
                    path,
                    &OpenOptions {
                        refinement,
                        ..Default::default()
                    },
                )
            };
            let cages = open(Refinement::Cages)?;
            let refined = open(Refinement::Level(level))?;
            let s = &refined.subdivision;
            let added = refined.array_bytes().meshes - cages.array_bytes().meshes;
            let before = samples_per_second(&cages)?;
            drop(cages);
            let after = samples_per_second(&refined)?;
            println!(
                "| {} | {} | {} | {} | {:.2} | {:.1} | {before:.3e} | {after:.3e} |",
                scene_name(path),
                s.cages,
                s.cage_triangles,
                s.triangles,
                s.seconds,
                added as f64 / (1u64 << 20) as f64
            );
        }
        Ok(())
    })
}

/// Camera-path samples per second of one render of `scene` (render state
/// built first, not timed).
fn samples_per_second(scene: &Scene) -> Result<f64> {
    let state = RenderState::build(scene, Some(RESOLUTION), StateOptions::default())?;
    let settings = settings(SPP, AovSet::beauty_only());
    let (_, stats) = integrator::render(&state, &settings, &|_| {});
    let samples = f64::from(RESOLUTION.x * RESOLUTION.y) * f64::from(SPP);
    Ok(samples / stats.elapsed.as_secs_f64())
}
