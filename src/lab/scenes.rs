//! The scenes a study renders: the command line's, else the study's
//! defaults, which come from the repository's `scenes/` folder only; their
//! names in tables and file names.

use std::path::{Path, PathBuf};

/// `scenes` when any are given, else `defaults`: paths relative to the
/// `scenes/` folder of the checkout ([`crate::scene::repo_root`]).
pub(crate) fn scenes_or_default(scenes: Vec<PathBuf>, defaults: &[&str]) -> Vec<PathBuf> {
    if scenes.is_empty() {
        let folder = crate::scene::repo_root().join("scenes");
        defaults.iter().map(|d| folder.join(d)).collect()
    } else {
        scenes
    }
}

/// A scene's name in tables, charts and file names: its file stem.
pub(crate) fn scene_name(path: &Path) -> String {
    path.file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
}
