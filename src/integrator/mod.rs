//! The integrator: turns a [`RenderState`] into a [`Film`] by tracing camera
//! paths in parallel over image tiles (rayon).
//!
//! Determinism: each pixel sample draws from a sampler keyed by (pixel,
//! sample index, seed) only, each tile sums its pixels in sample order, and
//! tiles merge into the film in a fixed order; so for a given `--seed` and
//! sample count the image is bit-identical whatever the thread count.
//! (`--time` budgets stop after a number of passes that depends on speed.)

mod gathered;
mod media;
mod path;

use std::time::{Duration, Instant};

use glam::{UVec2, Vec2};
use rayon::prelude::*;

use crate::output::aov::AovSet;
use crate::output::film::{Film, NonFiniteSamples, TileFilm};
use crate::output::filter::{FilterKind, PixelFilter};
use crate::render_state::RenderState;
use crate::sampling::{Pcg32, Sampler, SamplerKind};
use crate::volumes::{TrackingStats, TransmittanceEstimator};

/// Tile edge in pixels: enough tiles for load balance on many cores, big
/// enough that per-tile overhead vanishes.
const TILE_SIZE: u32 = 16;

/// Longest pass in samples per pixel under a time budget. Passes are 1, 1,
/// 2, 4, 8, 16, 16, ... samples, so the total doubles (1, 2, 4 .. 32) and then
/// grows by this much (48, 64, ...): Sobol points are best balanced at powers
/// of two and multiples of this; the budget is checked between passes.
const MAX_PASS_SAMPLES: u32 = 16;

/// How light is found, for comparing the estimators (`--strategy`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Strategy {
    /// Light sampling and BSDF sampling combined by the power heuristic (the default).
    #[default]
    Mis,
    /// BSDF sampling only: emission counts only when a path hits it
    /// (point-like lights are never found).
    Bsdf,
    /// Light sampling only (next-event estimation): emission found by BSDF
    /// sampling counts only after the camera or a Dirac lobe.
    Nee,
}

/// Path-tracing parameters.
#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    /// Estimator combination.
    pub strategy: Strategy,
    /// Most bounces a path takes (0 = emission seen directly only).
    pub max_depth: u32,
    /// Largest value of any RGB component of one sample, W/(m^2 sr); `None`
    /// (the default) keeps the estimator unbiased.
    pub clamp: Option<f32>,
    /// How paths through media are estimated (`--volume-estimator`).
    pub volume_estimator: VolumeEstimator,
    /// Equiangular sampling of sphere and point lights from media, MIS-
    /// combined with distance sampling (null-scattering MIS only; on by
    /// default, `--no-equiangular` for comparisons).
    pub equiangular: bool,
}

/// The volume estimators compared in the charts (`--volume-estimator`).
/// Every one samples free flights by delta tracking; they differ in how
/// shadow rays estimate transmittance and how light and phase sampling are
/// weighted against each other.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum VolumeEstimator {
    /// Null-scattering path MIS (Miller, Georgiev & Jarosz 2019; pbrt-v4's
    /// `VolPathIntegrator`): ratio tracking on shadow rays, and MIS weights
    /// that include each strategy's probability of the null collisions
    /// along the way, so dense media favour light sampling (the default).
    #[default]
    NullScatteringMis,
    /// Ratio tracking on shadow rays (Novák et al. 2014, §3), MIS on
    /// directions only.
    Ratio,
    /// Residual ratio tracking on shadow rays, control = each majorant
    /// cell's minimum (Novák et al. 2014, §4), MIS on directions only.
    ResidualRatio,
    /// Track-length (delta tracking) transmittance on shadow rays (Novák et
    /// al. 2018, §4.1), MIS on directions only.
    TrackLength,
}

impl VolumeEstimator {
    /// The shadow-ray transmittance estimator this uses.
    pub fn transmittance(self) -> TransmittanceEstimator {
        match self {
            Self::NullScatteringMis | Self::Ratio => TransmittanceEstimator::Ratio,
            Self::ResidualRatio => TransmittanceEstimator::ResidualRatio,
            Self::TrackLength => TransmittanceEstimator::TrackLength,
        }
    }
}

/// When to stop sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Exactly this many samples per pixel (deterministic).
    Samples(u32),
    /// As many whole passes as fit in this wall-clock time (at least one sample).
    Time(Duration),
}

/// Everything that chooses how to render, beside the scene.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Samples or time.
    pub budget: Budget,
    /// Seeds every sampler.
    pub seed: u64,
    /// Sobol or independent random numbers.
    pub sampler: SamplerKind,
    /// Pixel reconstruction filter.
    pub filter: FilterKind,
    /// The path tracer's own settings.
    pub path: PathSettings,
    /// The AOVs accumulated beside the beauty.
    pub aovs: AovSet,
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays.
    pub camera: u64,
    /// Closest-hit rays, camera rays included.
    pub closest: u64,
    /// Shadow (occlusion) rays.
    pub shadow: u64,
}

impl RayCounts {
    fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.closest += other.closest;
        self.shadow += other.shadow;
    }
}

/// What a render did, beside its image.
#[derive(Clone, Copy, Debug)]
pub struct RenderStats {
    /// Samples per pixel taken.
    pub samples_per_pixel: u32,
    /// Wall-clock time of the sampling (not of loading or writing).
    pub elapsed: Duration,
    /// Rays traced.
    pub rays: RayCounts,
    /// Samples dropped for being NaN or infinite.
    pub non_finite: NonFiniteSamples,
    /// Density lookups and collisions in media.
    pub tracking: TrackingStats,
}

/// Renders `state` into a film. `progress` is called after every tile with
/// the fraction done (of the samples, or of the time budget).
pub fn render(
    state: &RenderState,
    settings: &RenderSettings,
    progress: &(dyn Fn(f64) + Sync),
) -> (Film, RenderStats) {
    let mut film = Film::new(state.resolution, settings.aovs.clone());
    let tiles = film.tiles(TILE_SIZE);
    let filter = PixelFilter::new(settings.filter);
    let start = Instant::now();
    let mut rays = RayCounts::default();
    let mut tracking = TrackingStats::default();
    let mut done = 0u32;
    let mut pass = 1u32;
    loop {
        let count = match settings.budget {
            Budget::Samples(n) => n - done,
            Budget::Time(_) => pass,
        };
        let tiles_done = std::sync::atomic::AtomicUsize::new(0);
        let results: Vec<(TileFilm, RayCounts, TrackingStats)> = tiles
            .par_iter()
            .map(|tile| {
                let mut out = TileFilm::new(*tile, &settings.aovs);
                let mut counts = RayCounts::default();
                let mut media = TrackingStats::default();
                let samples = done..done + count;
                render_tile(
                    state,
                    settings,
                    &filter,
                    samples,
                    &mut out,
                    (&mut counts, &mut media),
                );
                let n = tiles_done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(match settings.budget {
                    Budget::Samples(total) => {
                        (f64::from(done) + f64::from(count) * n as f64 / tiles.len() as f64)
                            / f64::from(total)
                    }
                    Budget::Time(limit) => start.elapsed().as_secs_f64() / limit.as_secs_f64(),
                });
                (out, counts, media)
            })
            .collect();
        for (tile, counts, media) in &results {
            film.merge(tile);
            rays.add(counts);
            tracking.merge(media);
        }
        done += count;
        match settings.budget {
            Budget::Samples(_) => break,
            Budget::Time(limit) => {
                // Stop when the next pass would overrun.
                let elapsed = start.elapsed();
                let next = done.min(MAX_PASS_SAMPLES);
                let per_sample = elapsed.as_secs_f64() / f64::from(done);
                if elapsed.as_secs_f64() + per_sample * f64::from(next) > limit.as_secs_f64() {
                    break;
                }
                pass = next;
            }
        }
    }
    let stats = RenderStats {
        samples_per_pixel: done,
        elapsed: start.elapsed(),
        rays,
        non_finite: film.non_finite,
        tracking,
    };
    (film, stats)
}

/// Samples `samples` of every pixel of one tile into `out`.
fn render_tile(
    state: &RenderState,
    settings: &RenderSettings,
    filter: &PixelFilter,
    samples: std::ops::Range<u32>,
    out: &mut TileFilm,
    (rays, tracking): (&mut RayCounts, &mut TrackingStats),
) {
    let mut sampler = Sampler::new(settings.sampler, settings.seed);
    let tile = out.tile;
    for y in tile.origin.y..tile.origin.y + tile.size.y {
        for x in tile.origin.x..tile.origin.x + tile.size.x {
            let pixel = UVec2::new(x, y);
            for index in samples.clone() {
                sampler.start_pixel_sample(pixel, index);
                let film = pixel.as_vec2() + Vec2::splat(0.5) + filter.sample(sampler.next_2d());
                let camera = state.camera.generate_ray(film, sampler.next_2d());
                let ray = obvhs::ray::Ray::new(
                    camera.origin.into(),
                    camera.direction.into(),
                    camera.t_min,
                    camera.t_max,
                );
                rays.camera += 1;
                let mut rng = Pcg32::new(sample_key(settings.seed, pixel, index), 0);
                let random = path::PathRandom {
                    sampler: &mut sampler,
                    tracking: &mut rng,
                };
                let counts = path::PathCounts {
                    rays: &mut *rays,
                    tracking: &mut *tracking,
                };
                let (radiance, aovs) = path::radiance(state, ray, random, &settings.path, counts);
                out.add(pixel, index, radiance, &aovs);
            }
        }
    }
}

/// A 64-bit key of one pixel sample (splitmix64 of seed, pixel and index):
/// seeds the tracking generator so media sampling is as deterministic as
/// the sampler.
fn sample_key(seed: u64, pixel: UVec2, index: u32) -> u64 {
    let mut z = seed
        ^ (u64::from(pixel.x) << 40)
        ^ (u64::from(pixel.y) << 20)
        ^ u64::from(index).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
