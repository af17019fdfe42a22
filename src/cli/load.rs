//! Loading the scene a command names: a USD file, exported through the
//! cache first, or an exported scene folder (or its scene.json).

use std::path::Path;

use anyhow::Result;

use cirrus::scene::Scene;

/// USD file extensions: such inputs are exported (through the cache) first.
const USD_EXTENSIONS: &[&str] = &["usd", "usda", "usdc", "usdz"];

/// Whether `path` names a USD file by its extension.
pub(crate) fn is_usd(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| USD_EXTENSIONS.contains(&e))
}

/// A scene from a USD file (exported through the cache at `frame`; the
/// export's warnings are printed again when the cache already held it) or
/// from an exported folder or its scene.json.
pub(crate) fn load_scene(path: &Path, frame: Option<f64>) -> Result<Scene> {
    if is_usd(path) {
        let export = cirrus::scene::export_cached(path, frame)?;
        let scene = Scene::load(&export.dir)?;
        if export.reused {
            // The exporter printed these when it ran; a user must see them every time.
            for warning in &scene.manifest.warnings {
                eprintln!("warning: {warning}");
            }
        }
        Ok(scene)
    } else {
        if frame.is_some() {
            anyhow::bail!(
                "--frame applies to USD input only; {} is an exported scene",
                path.display()
            );
        }
        Ok(Scene::load(path)?)
    }
}
