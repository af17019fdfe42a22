//! The sample gallery (`scenes/gallery.py`) at a tiny size: every shared scene
//! of `scenes/shared_scenes.txt` still exports and renders, each gets its PNG and
//! its README row with its warnings, and a scene that cannot render fails the
//! script by name.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::{scratch, shared_scenes, venv_python, SharedScene};

/// Width of the test renders in pixels (1 spp): enough to prove a scene renders.
const TEST_WIDTH: u32 = 64;

/// Runs the gallery script on `list` into `out` at `TEST_WIDTH` px wide, 1 spp.
fn gallery(list: &Path, out: &Path) -> Output {
    Command::new(venv_python())
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gallery.py"))
        .arg("--out")
        .arg(out)
        .args(["--res", &TEST_WIDTH.to_string(), "--spp", "1"])
        .arg("--cirrus")
        .arg(env!("CARGO_BIN_EXE_cirrus"))
        .arg("--list")
        .arg(list)
        .output()
        .unwrap()
}

/// The gallery's README row of a scene, found by its label (`ASSET` or `ASSET (frame F)`).
fn row<'a>(readme: &'a str, scene: &SharedScene) -> &'a str {
    let label = match scene.frame.as_str() {
        "" => scene.asset.clone(),
        frame => format!("{} (frame {frame})", scene.asset),
    };
    readme
        .lines()
        .find(|line| line.contains(&format!("| `{label}` |")))
        .unwrap_or_else(|| panic!("no README row for {label}:\n{readme}"))
}

/// The PNG a README row shows (`![NAME](NAME.png)`), under `dir`.
fn thumbnail(dir: &Path, row: &str) -> PathBuf {
    let start = row.find("](").map(|i| i + 2);
    let end = row.find(".png)").map(|i| i + 4);
    match (start, end) {
        (Some(start), Some(end)) => dir.join(&row[start..end]),
        _ => panic!("no thumbnail in row: {row}"),
    }
}

/// Width of a PNG from its IHDR chunk (bytes 16..20, big-endian).
fn png_width(png: &[u8]) -> u32 {
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    u32::from_be_bytes(png[16..20].try_into().unwrap())
}

#[test]
fn every_shared_scene_renders_into_the_gallery() {
    needs_shared!();
    let dir = scratch("gallery_all");
    let list = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/shared_scenes.txt");
    let result = gallery(&list, &dir);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(result.status.success(), "gallery failed:\n{stderr}");
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap();
    let scenes = shared_scenes();
    let mut pngs = std::collections::BTreeSet::new();
    for scene in &scenes {
        let png = thumbnail(&dir, row(&readme, scene));
        let bytes = std::fs::read(&png)
            .unwrap_or_else(|e| panic!("{} for {}: {e}", png.display(), scene.asset));
        assert_eq!(png_width(&bytes), TEST_WIDTH, "{}", png.display());
        pngs.insert(png);
    }
    assert_eq!(pngs.len(), scenes.len(), "two scenes share a PNG name");
    let exrs = std::fs::read_dir(&dir).unwrap().filter(|e| {
        e.as_ref()
            .unwrap()
            .path()
            .extension()
            .is_some_and(|x| x == "exr")
    });
    assert_eq!(exrs.count(), 0, "EXRs left in the gallery");
    // The exporter's and the renderer's warnings both reach the rows; a
    // missing image is reported once, by the exporter.
    let row_of = |asset: &str| {
        row(
            &readme,
            &SharedScene {
                asset: asset.into(),
                frame: String::new(),
            },
        )
    };
    let ball = row_of("usd-wg/full_assets/StandardShaderBall/standard_shader_ball_scene.usda");
    assert!(
        ball.contains(
            "`warning: material /standard_shader_ball_scene/materials/ground: image file"
        ) && !ball.contains("[WARN  cirrus::materials::texture]"),
        "{ball}"
    );
    let teapot = row_of("usd-wg/full_assets/Teapot/Teapot.usd");
    assert!(
        teapot.contains("`[WARN  cirrus::lights] the scene has no lights"),
        "{teapot}"
    );
}

#[test]
fn a_scene_that_cannot_render_fails_the_gallery_by_name() {
    needs_shared!();
    let dir = scratch("gallery_failure");
    let list = dir.join("list.txt");
    std::fs::write(&list, "# one missing scene\nno/such/scene.usda 3\n").unwrap();
    let result = gallery(&list, &dir.join("out"));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(1), "{stderr}");
    let last = stderr.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("error: 1 scene(s) failed")
            && last.contains("no/such/scene.usda (frame 3)"),
        "{stderr}"
    );
    let readme = std::fs::read_to_string(dir.join("out/README.md")).unwrap();
    let missing = SharedScene {
        asset: "no/such/scene.usda".into(),
        frame: "3".into(),
    };
    let failed = row(&readme, &missing);
    assert!(
        failed.contains("**failed**") && failed.contains("no such file"),
        "{failed}"
    );
}
