//! The PNG preview beside every EXR: the only tone-mapped output (the EXR
//! stays linear scene-referred radiance, docs/conventions.md, "Output").

use std::path::{Path, PathBuf};

use crate::film::Film;
use crate::image::{write_exr, Channel, Compression, ExrImage, ImageError, PixelType};

/// Writes `rgb` (linear Rec.709, row-major from the top, interleaved) as an
/// 8-bit sRGB PNG through OpenImageIO, tone-mapped with Khronos PBR Neutral
/// (2024): linear below 0.76, a smooth shoulder above, hues kept, so a
/// look-dev preview shows its albedos undistorted.
pub fn write_preview(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<(), ImageError> {
    let pixels: Vec<f32> = rgb
        .chunks_exact(3)
        .flat_map(|c| pbr_neutral([c[0], c[1], c[2]]).map(srgb_encode))
        .collect();
    let channel = |name: &str| Channel {
        name: name.into(),
        pixel_type: PixelType::Half,
    };
    write_exr(
        path,
        &ExrImage {
            width,
            height,
            channels: vec![channel("R"), channel("G"), channel("B")],
            pixels: &pixels,
            compression: Compression::default(),
            strings: Vec::new(),
            matrices: Vec::new(),
        },
    )
}

/// The PNG preview written beside the image `exr`: `OUT.png` for `OUT.exr`.
pub fn preview_path(exr: &Path) -> PathBuf {
    exr.with_extension("png")
}

/// Writes the preview of `film` (its window's pixels) to `path`.
pub fn write_film_preview(path: &Path, film: &Film) -> Result<(), ImageError> {
    let size = film.window.size;
    write_preview(path, size.x, size.y, &film.rgb())
}

/// Khronos PBR Neutral tone mapping of a linear colour (non-finite and
/// negative values read as black); output in [0, 1].
pub(super) fn pbr_neutral(c: [f32; 3]) -> [f32; 3] {
    const START: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let c = c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
    let x = c[0].min(c[1]).min(c[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    let c = c.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START {
        return c;
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    let c = c.map(|v| v * new_peak / peak);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| v * (1.0 - g) + new_peak * g)
}

/// The sRGB opto-electronic transfer function (IEC 61966-2-1), clamped to [0, 1].
fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_map_is_linear_in_the_darks_and_bounded() {
        let mid = pbr_neutral([0.18, 0.18, 0.18]);
        assert!((mid[0] - (0.18 - 0.04)).abs() < 1e-6);
        for v in [1.0, 10.0, 1e6, f32::INFINITY, f32::NAN, -1.0] {
            let out = pbr_neutral([v, 0.5 * v, 0.1]);
            assert!(out.iter().all(|c| (0.0..=1.0).contains(c)), "{v}: {out:?}");
        }
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4613).abs() < 1e-3);
    }
}
