//! The scenes a study renders: the command line's, else the study's
//! defaults, which come from the repository's `scenes/` folder only; their
//! names in tables and file names.

use std::path::{Path, PathBuf};

/// `scenes` when any are given, else `defaults`: paths relative to the
/// `scenes/` folder of the checkout ([`repo_root`]).
pub(crate) fn scenes_or_default(scenes: Vec<PathBuf>, defaults: &[&str]) -> Vec<PathBuf> {
    if scenes.is_empty() {
        let folder = repo_root().join("scenes");
        defaults.iter().map(|d| folder.join(d)).collect()
    } else {
        scenes
    }
}

/// The Cirrus checkout whose `scenes/` and `.venv` the studies use:
/// `$CIRRUS_HOME`, else the source folder this binary was built from.
pub(crate) fn repo_root() -> PathBuf {
    std::env::var_os("CIRRUS_HOME")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
}

/// A scene's name in tables, charts and file names: its file stem.
pub(crate) fn scene_name(path: &Path) -> String {
    path.file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
}
