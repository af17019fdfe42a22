//! `cirrus info FILE`: a readable summary of a file's contents: counts for a
//! scene (exported folder, its scene.json, or a USD file exported through the
//! cache), the grid table for anything else (OpenVDB says when it is not a VDB).

use std::path::Path;

use anyhow::Result;

use cirrus::scene;
use cirrus::volumes::grid::{grid_table, VdbFile};

pub fn run(file: &Path) -> Result<()> {
    let is_scene = file.is_dir() || file.file_name().is_some_and(|n| n == scene::MANIFEST_FILE);
    if is_scene || scene::is_usd(file) {
        print!(
            "{}",
            scene::summary(&cirrus::job::open(file, &Default::default(), None)?)
        );
    } else {
        let vdb = VdbFile::open(file)?;
        print!("{}", grid_table(&vdb));
    }
    Ok(())
}
