//! The renders every study shares: the settings they start from, and each
//! scene's long reference render, kept on disk by the scene's contents,
//! resolution and spp so that later runs read it back.

use std::path::{Path, PathBuf};

use glam::UVec2;

use super::Result;
use crate::file_error::FileError;
use crate::film::AovSet;
use crate::film::FilterKind;
use crate::image::read_image;
use crate::integrator::{
    self, Budget, PathSettings, RenderSettings, RenderStats, Strategy, VolumeEstimator,
    DEFAULT_MAX_DEPTH,
};
use crate::output::{write_beauty, ExrHeader};
use crate::render_state::RenderState;
use crate::sampling::SamplerKind;
use crate::scene::Scene;

/// Seed of every reference render, apart from the seeds of the measured ones
/// (0, 1, 2, ...).
pub(crate) const REFERENCE_SEED: u64 = 1 << 20;

/// Settings of every benchmark and convergence render unless the measured
/// method changes them: `cirrus render`'s defaults (MIS, Sobol, max depth
/// [`DEFAULT_MAX_DEPTH`], null-scattering MIS with equiangular sampling, no clamp)
/// but a box filter, so each sample lands in its own pixel only, and the
/// beauty alone.
pub(crate) fn base_settings(budget: Budget, seed: u64) -> RenderSettings {
    RenderSettings {
        budget,
        seed,
        sampler: SamplerKind::Sobol,
        filter: FilterKind::Box,
        path: PathSettings {
            strategy: Strategy::Mis,
            max_depth: DEFAULT_MAX_DEPTH,
            clamp: None,
            volume_estimator: VolumeEstimator::NullScatteringMis,
            equiangular: true,
            camera_ray_transmittance: false,
        },
        aovs: AovSet::beauty_only(),
        adaptive: None,
    }
}

/// Renders `state` with `settings`; the film's RGB and the statistics.
pub(crate) fn render(state: &RenderState, settings: &RenderSettings) -> (Vec<f32>, RenderStats) {
    let (film, stats) = integrator::render(state, settings, &|_| {});
    (film.rgb(), stats)
}

/// The name under which references of `scene` (called `name`) are kept:
/// the name and a CRC-32 of the exported scene (`scene.json` and
/// `scene.bin`), so a reference rendered before the scene changed is never
/// read back (a stale smoke reference, from before its ground lost its
/// specular lobe, once made every method look stuck at relMSE 0.13).
pub(crate) fn reference_key(scene: &Scene, name: &str) -> Result<String> {
    let crc = scene
        .content_crc()
        .map_err(|e| FileError::new("read the scene in", &scene.dir, e))?;
    Ok(format!("{name}-{crc:08x}"))
}

/// The reference of the scene whose [`reference_key`] is `key`:
/// [`base_settings`] at `spp` with [`REFERENCE_SEED`], kept in `out` by
/// [`reference`] at [`reference_path`].
pub(crate) fn cached_reference(
    state: &RenderState,
    out: &Path,
    key: &str,
    spp: u32,
) -> Result<Vec<f32>> {
    let path = reference_path(out, key, state.resolution, spp);
    let settings = base_settings(Budget::Samples(spp), REFERENCE_SEED);
    reference(state, &settings, &path)
}

/// Where the reference of the scene keyed `key` ([`reference_key`]) at this
/// resolution and spp is kept: `<out>/<key>-<w>x<h>-ref<spp>.exr`. The key
/// holds neither the settings, nor the renderer's version, nor the VDB
/// files' contents: delete the file after changing any of them.
pub(crate) fn reference_path(out: &Path, key: &str, resolution: UVec2, spp: u32) -> PathBuf {
    out.join(format!(
        "{key}-{}x{}-ref{spp}.exr",
        resolution.x, resolution.y
    ))
}

/// The reference image at `path`, read back when it exists with the right
/// size, else rendered with `settings` (a sample budget) and written there.
pub(crate) fn reference(
    state: &RenderState,
    settings: &RenderSettings,
    path: &Path,
) -> Result<Vec<f32>> {
    if let Some(rgb) = read_rgb(path, state.resolution) {
        return Ok(rgb);
    }
    let (rgb, stats) = render(state, settings);
    eprintln!(
        "reference {}: {:.1} s",
        path.display(),
        stats.elapsed.as_secs_f64()
    );
    let header = ExrHeader::new(state, settings);
    write_beauty(path, state.resolution, &rgb, &header, &stats)?;
    Ok(rgb)
}

/// The RGB pixels of the EXR at `path` when it exists, holds 3 channels and
/// has this `resolution`; None otherwise.
pub(crate) fn read_rgb(path: &Path, resolution: UVec2) -> Option<Vec<f32>> {
    let image = read_image(path, crate::scene::ColorSpace::Raw).ok()?;
    (image.channels == 3 && UVec2::new(image.width, image.height) == resolution)
        .then_some(image.pixels)
}
