//! How every command opens a scene: the subdivision cages first, refined
//! only when the memory preflight says the refined scene fits; and how
//! `cirrus export` checks what it wrote.

use std::path::Path;

use super::JobError;
use crate::memory;
use crate::scene::{self, ExportOptions, OpenError, OpenOptions, Refinement, Scene};

/// Opens the scene at `path` as `options` say, first checking that its
/// subdivision surfaces, refined as `options.refinement` asks, fit in
/// `limit` bytes (`--memory-limit`; without one, what the machine has): the
/// cages are loaded and counted, and refined only when the estimate fits
/// ([`memory::check_refinement`]).
pub fn open(path: &Path, options: &OpenOptions, limit: Option<u64>) -> Result<Scene, JobError> {
    let cages = OpenOptions {
        refinement: Refinement::Cages,
        ..*options
    };
    let mut scene = Scene::open(path, &cages)?;
    memory::check_refinement(&scene, options.refinement, limit)?;
    scene.refine(options.refinement)?;
    Ok(scene)
}

/// Exports the USD file `input` to the scene folder `output` (replaced if
/// it exists), then [`open`]s the result, so that a scene the renderer
/// would refuse is reported now rather than at render time.
pub fn export(input: &Path, output: &Path, options: &ExportOptions) -> Result<Scene, JobError> {
    scene::export(input, output, options).map_err(OpenError::from)?;
    open(output, &OpenOptions::default(), None)
}
