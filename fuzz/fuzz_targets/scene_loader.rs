//! Fuzzes `Scene::load`, the intermediate-format loader, on arbitrary
//! `scene.json` + `scene.bin` pairs. An input is the manifest text, one NUL
//! byte, then the blob (the seeds in `seeds/scene_loader/` are exported scenes
//! packed so); without a NUL the whole input is the manifest and the blob is
//! empty. Loading must return `Ok` or `Err`, never panic, and an accepted
//! scene must be safe to view: every array in range, every index valid.

#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use cirrus::scene::{Scene, BLOB_FILE, MANIFEST_FILE, NO_MATERIAL};
use libfuzzer_sys::fuzz_target;

/// One scratch scene folder per fuzzing process (`-jobs`/`-fork` run several).
fn scratch() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("cirrus-fuzz-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

fuzz_target!(|input: &[u8]| {
    let (manifest, blob) = match input.iter().position(|&b| b == 0) {
        Some(nul) => (&input[..nul], &input[nul + 1..]),
        None => (input, &[][..]),
    };
    let dir = scratch();
    std::fs::write(dir.join(MANIFEST_FILE), manifest).unwrap();
    std::fs::write(dir.join(BLOB_FILE), blob).unwrap();
    let Ok(scene) = Scene::load(dir) else {
        return;
    };
    let m = &scene.manifest;
    scene.array_bytes();
    for mesh in &m.meshes {
        let points = scene.view(&mesh.points).len();
        let triangles = scene.view(&mesh.triangles);
        assert!(triangles.iter().flatten().all(|&i| (i as usize) < points));
        if let Some(normals) = &mesh.normals {
            assert_eq!(scene.view(normals).len(), points);
        }
        if let Some(uvs) = &mesh.uvs {
            assert_eq!(scene.view(uvs).len(), points);
        }
        let materials = scene.view(&mesh.triangle_materials);
        assert_eq!(materials.len(), triangles.len());
        assert!(materials
            .iter()
            .all(|&i| i == NO_MATERIAL || (i as usize) < m.materials.len()));
    }
    let n = m.instances.count as usize;
    let prototypes = scene.view(&m.instances.prototype);
    assert!(
        prototypes.len() == n
            && prototypes
                .iter()
                .all(|&p| (p as usize) < m.prototypes.len())
    );
    assert_eq!(scene.view(&m.instances.transform).len(), n);
    assert_eq!(scene.view(&m.instances.source_index).len(), n);
});
