//! Primvar RenderVars (issue 25): a `primvars:*` var (or `sourceType`
//! `primvar`) writes the primvar of the camera ray's first surface hit,
//! averaged like `N`: a vertex color3f primvar interpolates to its affine
//! values, a uniform float is its face's value, and 0 where nothing is hit
//! or no prim has the primvar (one warning names the var and primvar).
//! Scene: scenes/tests/primvar_aovs.usda, read back with the `exr` crate.

use crate::common;
use std::path::Path;
use std::process::Command;

use crate::common::aovs::Exr;

/// Image width and height (the render settings') and samples per pixel.
const WIDTH: usize = 16;
const HEIGHT: usize = 8;
const SPP: u32 = 64;

/// The centre of pixel (i, j) in scene units (see the scene's doc).
fn centre(i: usize, j: usize) -> (f32, f32) {
    (
        -2.0 + 0.25 * (i as f32 + 0.5),
        1.0 - 0.25 * (j as f32 + 0.5),
    )
}

#[test]
fn primvar_vars_write_the_hit_surfaces_primvars() {
    let dir = common::scratch("primvar_aovs");
    let stage = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/primvar_aovs.usda");
    let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .current_dir(&dir)
        .args(["render".as_ref(), stage.as_os_str()])
        .args(["--spp", &SPP.to_string()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "cirrus render:\n{stderr}");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("absent")).collect();
    assert_eq!(warnings.len(), 1, "one warning for absent:\n{stderr}");
    assert!(warnings[0].contains("/Render/Vars/absent") && warnings[0].contains("primvar absent"));
    let exr = Exr::read(&dir.join("primvars.exr"));
    assert_eq!((exr.width, exr.height), (WIDTH, HEIGHT));
    let tint = ["tint.R", "tint.G", "tint.B"].map(|c| exr.plane(c));
    let (mask, absent) = (exr.plane("mask"), exr.plane("absent"));
    // The pixel filter reaches 1.5 pixels: pixels whose footprint lies in one
    // face are columns 3..=6 (left) and 9..=12 (right), rows 3 and 4.
    // Their samples' mean offset from the centre has a standard deviation
    // under 0.5 / sqrt(SPP) pixels per axis; tint changes by 1/16 per pixel
    // along x and 1/8 along y, so 4 sigma of either is under the bound.
    let bound = 4.0 * 0.5 / (SPP as f32).sqrt() * (1.0 / 16.0 + 1.0 / 8.0);
    let mut checked = 0;
    for j in [3, 4] {
        for i in (3..=6).chain(9..=12) {
            let p = j * WIDTH + i;
            let (x, y) = centre(i, j);
            let want = [0.5 + x / 4.0, 0.5 + y / 2.0, 0.25];
            for (c, w) in tint.iter().zip(want) {
                assert!(
                    (c[p] - w).abs() < bound,
                    "tint at ({i}, {j}): {} vs {w}",
                    c[p]
                );
            }
            let face = if x < 0.0 { 0.25 } else { 0.75 };
            assert!(
                (mask[p] - face).abs() < 1e-6,
                "mask at ({i}, {j}): {}",
                mask[p]
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 16);
    // Nothing is hit in the corners: the film's 0 there.
    for p in [0, WIDTH - 1, (HEIGHT - 1) * WIDTH, HEIGHT * WIDTH - 1] {
        assert_eq!([tint[0][p], tint[1][p], tint[2][p], mask[p]], [0.0; 4]);
    }
    assert!(absent.iter().all(|&v| v == 0.0), "absent is 0 everywhere");
}
