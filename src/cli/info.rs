//! `cirrus info FILE`: a readable summary of a file's contents: counts for a
//! scene (exported folder, its scene.json, or a USD file exported through the
//! cache), the grid table for anything else (OpenVDB says when it is not a VDB).

use std::path::Path;

use anyhow::Result;

use cirrus::scene;
use cirrus::volumes::grid::{grid_table, VdbFile};

/// Prints `file`'s summary: a scene's counts, else a VDB's grid table.
pub fn run(file: &Path) -> Result<()> {
    if scene::is_scene(file) {
        let scene = cirrus::job::open(file, &Default::default(), None)?;
        print!("{}", scene::summary(&scene));
        print!("{}", cirrus::lights::shaped_lights(&scene));
    } else {
        print!("{}", grid_table(&VdbFile::open(file)?));
    }
    Ok(())
}
