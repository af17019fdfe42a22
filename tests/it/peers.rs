//! Agreement with the peer renderers: `scenes/peers/compare.py`
//! renders a scene with Cirrus and with a peer (`scenes/peers/render_peer.py`:
//! Mitsuba 3 `scalar_rgb` or `llvm_ad_rgb` through `to_mitsuba.py`, Blender
//! 5.0 Cycles (or Debian's 3.4) through `to_cycles.py`, each converting the
//! exported scene) and
//! fails when a channel's mean ratio is off by more than 2% or the relMSE
//! after 4x4 box downsampling reaches 1e-2.
//!
//! `scenes/peers/install` puts Mitsuba in the project `.venv` and Debian's
//! libllvm19 on the machine; `scenes/peers/install --cycles` adds Blender
//! 5.0's `bpy` wheel in `.venv-cycles`. Without a peer its tests print a
//! skip line and pass, unless it is required: Mitsuba (both variants) by
//! `CIRRUS_REQUIRE_PEERS=1`, Cycles 5 by `CIRRUS_REQUIRE_CYCLES=1` (CI sets
//! both). Cycles 3.4 (`cycles-3.4`, Debian's blender) is never required: it
//! runs where installed.
//! Each comparison's means, ratios and relMSE are written to stderr
//! (uncaptured), so the test log shows the agreement.
//!
//! Textures (`textured_quads`) are held to tighter bounds than the default ones,
//! [`TEXTURES`]: on Lambert quads each pixel is its texel, so a flipped t
//! axis (relMSE 2.2 with Mitsuba) or a lost texture fails at once.

use crate::common;
use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::sync::Mutex;

/// One comparison at a time: each renderer already uses both cores.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Whether `peer` can run here (`render_peer.py --available`); without it,
/// panics when the peer is required (see the module doc) and otherwise says
/// the test is skipped.
fn peer_installed(test: &str, peer: &str) -> bool {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new(root.join(".venv/bin/python"))
        .arg(root.join("scenes/peers/render_peer.py"))
        .args(["--available", peer])
        .output();
    if out.as_ref().is_ok_and(|out| out.status.success()) {
        return true;
    }
    let reason = out.map_or_else(
        |e| format!("cannot run .venv/bin/python: {e}"),
        |out| String::from_utf8_lossy(&out.stderr).trim().to_owned(),
    );
    let required_by = match peer {
        "cycles" => Some("CIRRUS_REQUIRE_CYCLES"),
        "cycles-3.4" => None,
        _ => Some("CIRRUS_REQUIRE_PEERS"),
    };
    if let Some(var) = required_by {
        assert!(
            std::env::var(var).as_deref() != Ok("1"),
            "{test}: {reason}, and {var}=1"
        );
    }
    log(&format!("{test}: skipped: {reason}"));
    false
}

/// Writes a line to stderr directly, past the test harness' capture.
fn log(line: &str) {
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// Agreement bounds handed to compare.py.
struct Limits {
    /// Largest |mean ratio - 1| of any channel.
    ratio: &'static str,
    /// The relMSE after 4x4 downsampling must stay below this.
    relmse: &'static str,
    /// Largest |mean ratio - 1| of any channel per vertical band, one band
    /// per object left to right (compare.py --bands); empty: no bands.
    bands: &'static [&'static str],
}

/// The default bounds (compare.py's defaults).
const DEFAULT_LIMITS: Limits = Limits {
    ratio: "0.02",
    relmse: "1e-2",
    bands: &[],
};

/// Textures on Lambert quads: measured 0.5% and 6e-4 with Mitsuba, 0.2% and
/// 1.3e-4 with Cycles (128x128, 64 spp, 2026-11-24); Cycles' own sRGB
/// filtering (before decoding) was 1.4% off on one quad and is below these.
const TEXTURES: Limits = Limits {
    ratio: "0.01",
    relmse: "2e-3",
    bands: &[],
};

/// OpenPBR spheres against Cycles 5's Principled BSDF, one band per sphere
/// (docs/peers/materials.md; measured at 192x32, 256 spp each, 2026-12-02,
/// worst channel of Cirrus / Cycles). The whole image is held loosely only
/// because of band 4; the bands are the check.
const OPEN_PBR: Limits = Limits {
    // Band 4 alone moves the whole image's mean by 10% (blue) and its relMSE
    // to 1.7e-2; with it at 1 the image reads 0.993-1.006.
    ratio: "0.13",
    relmse: "3e-2",
    bands: &[
        // Rough plastic (GGX over Lambert, exact Fresnel in both): 1.0021.
        "0.01",
        // The same with base_diffuse_roughness 0.8: 1.0255 red, 1.0124
        // blue. Both are EON (Fujii's Oren-Nayar, the same E_avg), but
        // Cycles multiplies the multiple-scattering term by the albedo once
        // more than the EON paper and Cirrus: equal in a white furnace,
        // Cirrus 2.7% brighter on the diffuse at albedo 0.8 and 0.2 (as
        // predicted by integrating both forms), diluted here by the
        // specular layer.
        "0.04", // Coloured metal with an F82 tint: 1.0025 (the same F82-tint model).
        "0.015",
        // Clear coat over a blue dielectric, coat_darkening 0, the base's
        // IOR taken relative to the coat as OpenPBR does: 0.9888.
        // Cycles absorbs the coat tint along the view only (white here).
        "0.02",
        // The same with OpenPBR's default coat_darkening 1, which Cycles does
        // not model: 0.564 0.533 0.705, the darkening (1 - K)/(1 - E_b K)
        // of the base's own albedo (stronger where it is dark). Held within
        // 0.5 so a coat that loses the base entirely still fails.
        "0.5",
        // standard_surface with sheen, through the exporter's translation
        // graph (sheen -> fuzz): 0.9931 (Zeltner's sheen in both; Cycles
        // layers it by albedo as OpenPBR does).
        "0.015",
    ],
};

/// A sphere translating over an asymmetric shutter: measured 0.02% and
/// relMSE 3.8e-5 with Cycles 5 at 128 spp (2026-12-02). relMSE is the
/// check: a shutter centred on the frame (0.19 units off) reads 3.4e-3, no
/// blur 2.0e-2, while the means move by 0.01% only.
const MOTION: Limits = Limits {
    ratio: "0.01",
    relmse: "1e-3",
    bands: &[],
};

/// Runs compare.py on `scenes/peers/SCENE.usda` against `peer` at `res` and
/// `spp` within `limits`; logs its summary and fails with its whole output
/// when the renderers disagree (or a step fails).
fn compare(scene: &str, peer: &str, res: &str, spp: &str, limits: &Limits) {
    let test = format!("{scene} against {peer}");
    if !peer_installed(&test, peer) {
        return;
    }
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let work = common::scratch(&format!("peers_{scene}_{peer}"));
    let out = Command::new(common::venv_python())
        .arg(root.join("scenes/peers/compare.py"))
        .arg(root.join(format!("scenes/peers/{scene}.usda")))
        .args(["--peer", peer, "--res", res, "--spp", spp])
        .args(["--seed", "1", "--threads", "2"])
        .args(["--max-ratio-error", limits.ratio])
        .args(["--max-relmse", limits.relmse])
        .args(["--bands", &limits.bands.len().to_string()])
        .args(limits.bands.iter().flat_map(|b| ["--max-band-error", b]))
        .arg("--cirrus")
        .arg(env!("CARGO_BIN_EXE_cirrus"))
        .arg("--workdir")
        .arg(&work)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let summary: Vec<&str> = stdout
        .lines()
        .skip_while(|l| !l.starts_with("scene "))
        .collect();
    log(&summary.join("\n"));
    assert!(
        out.status.success() && summary.iter().any(|l| l.starts_with("AGREE")),
        "cirrus and {peer} disagree on {scene}:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Lambert surfaces, instanced boxes, a sphere light, a normalized rect light
/// and a dome through a perspective camera.
#[test]
fn surfaces_agree_with_mitsuba() {
    compare(
        "surface_lights",
        "mitsuba-scalar",
        "96x64",
        "64",
        &DEFAULT_LIMITS,
    );
}

/// The teapot cloud, transformed, coloured and forward-scattering, under a
/// sun and a dome.
#[test]
fn volume_agrees_with_mitsuba() {
    needs_shared!();
    compare(
        "volume_teapot",
        "mitsuba-scalar",
        "96x64",
        "64",
        &DEFAULT_LIMITS,
    );
}

/// Sub-voxel placement of VDB values: a window of about 21 voxels on the
/// teapot cloud's edge (half a voxel off fails both thresholds).
#[test]
fn voxel_placement_agrees_with_mitsuba() {
    needs_shared!();
    compare(
        "volume_voxels",
        "mitsuba-scalar",
        "64x64",
        "64",
        &DEFAULT_LIMITS,
    );
}

/// Textures as `bitmap`s: orientation, sRGB decoding, st transform, wrap,
/// channel, scale/bias and a tangent-space normal map.
#[test]
fn textures_agree_with_mitsuba() {
    needs_shared!();
    compare(
        "textured_quads",
        "mitsuba-scalar",
        "128x128",
        "64",
        &TEXTURES,
    );
}

/// The four scenes with Mitsuba's LLVM variant (`llvm_ad_rgb`, on
/// Debian's libllvm19): the same converter, another backend.
#[test]
fn scenes_agree_with_mitsuba_llvm() {
    needs_shared!();
    compare(
        "surface_lights",
        "mitsuba-llvm",
        "96x64",
        "64",
        &DEFAULT_LIMITS,
    );
    compare(
        "volume_teapot",
        "mitsuba-llvm",
        "96x64",
        "64",
        &DEFAULT_LIMITS,
    );
    compare(
        "volume_voxels",
        "mitsuba-llvm",
        "64x64",
        "64",
        &DEFAULT_LIMITS,
    );
    compare("textured_quads", "mitsuba-llvm", "128x128", "64", &TEXTURES);
}

/// Surfaces and lights with Cycles 5: Blender's light units (watts, sun
/// irradiance, world radiance) converted from UsdLux; 5.0's area lights
/// radiate P / (pi A), 3.4's P / (4 A) (with 3.4's factor the rect light
/// alone reads 27% bright in 5.0 and this fails at 5.2%).
#[test]
fn surfaces_agree_with_cycles() {
    compare("surface_lights", "cycles", "96x64", "64", &DEFAULT_LIMITS);
}

/// The transformed teapot cloud with Cycles 5 (unbiased null scattering):
/// density per world unit (Blender's default, object space, is 4% off here
/// and fails). Measured 0.05% and relMSE 4.8e-4 (2026-12-02).
#[test]
fn volume_agrees_with_cycles() {
    needs_shared!();
    compare("volume_teapot", "cycles", "96x64", "64", &DEFAULT_LIMITS);
}

/// VDB placement with Cycles 5, which puts values at their index points as
/// we do: 0.4%, relMSE 1.7e-3 (2026-12-02); 3.4's half-voxel shift applied
/// to 5.0 reads 3.2% dark (relMSE 2.4e-2) and fails.
#[test]
fn voxel_placement_agrees_with_cycles() {
    needs_shared!();
    compare("volume_voxels", "cycles", "64x64", "64", &DEFAULT_LIMITS);
}

/// Textures as Image Texture node chains on the "st" UV layer, 8-bit sRGB
/// images decoded before filtering, and a Normal Map node: 0.9% and
/// 4.9e-4 with Cycles 5 (2026-12-02; the normal-mapped quad alone reads
/// 2.5% brighter in Cirrus than in 5.0; with 3.4 the whole was 0.2% off).
#[test]
fn textures_agree_with_cycles() {
    needs_shared!();
    compare("textured_quads", "cycles", "128x128", "64", &TEXTURES);
}

/// Constant OpenPBR Surface and standard_surface materials (MaterialX
/// networks in USD) as Cycles 5's Principled BSDF (cycles_openpbr.py): six
/// spheres, each band held to its measured model difference ([`OPEN_PBR`]).
#[test]
fn open_pbr_agrees_with_cycles() {
    compare("openpbr_spheres", "cycles", "192x32", "128", &OPEN_PBR);
}

/// Transform motion blur: the sphere's keys and the camera's shutter as
/// Cycles 5's object keyframes and centred shutter ([`MOTION`]). Mitsuba 3
/// has no motion blur in its scalar and LLVM variants: not compared there.
#[test]
fn motion_blur_agrees_with_cycles() {
    compare("motion_sphere", "cycles", "96x48", "64", &MOTION);
}

/// The four scenes with Debian's Blender 3.4 Cycles where it is installed
/// (the converter's 3.4 conventions: half-voxel shift, area lights P = 4 A
/// L); never required.
#[test]
fn scenes_agree_with_cycles_3_4() {
    needs_shared!();
    compare(
        "surface_lights",
        "cycles-3.4",
        "96x64",
        "64",
        &DEFAULT_LIMITS,
    );
    compare(
        "volume_teapot",
        "cycles-3.4",
        "96x64",
        "64",
        &DEFAULT_LIMITS,
    );
    compare(
        "volume_voxels",
        "cycles-3.4",
        "64x64",
        "64",
        &DEFAULT_LIMITS,
    );
    compare("textured_quads", "cycles-3.4", "128x128", "64", &TEXTURES);
}
