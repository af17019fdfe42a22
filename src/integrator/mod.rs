//! The integrator: turns a [`RenderState`] into a [`Film`] by tracing camera
//! paths in parallel over image tiles (rayon).
//!
//! Determinism: each pixel sample draws from a sampler keyed by (pixel,
//! sample index, seed) only, each tile sums its pixels in sample order within
//! fixed passes, and tiles cover disjoint pixels; so for a given `--seed` and
//! sample count the image is bit-identical whatever the thread count, and
//! whether or not the render was stopped and resumed (see `progress.rs`).
//! (`--time` budgets stop after a number of passes that depends on speed.)
//! Adaptive sampling keeps that: which pixels sample in a pass is decided
//! over the whole film when the pass starts, from the sums every tile has
//! then, and kept in the film (and its checkpoints) until the pass ends.

mod gathered;
mod light_lobes;
mod media;
mod path;
mod progress;
mod shadow;
mod summary;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use glam::{UVec2, Vec2};
use rayon::prelude::*;

use crate::film::{ActivePixels, AdaptiveSampling, AovSet};
use crate::film::{Film, NonFiniteSamples, Tile, TileFilm};
use crate::film::{FilterKind, PixelFilter};
use crate::render_state::RenderState;
use crate::sampling::{Pcg32, Sampler, SamplerKind};
use crate::volumes::estimators::{TrackingStats, TransmittanceEstimator};
use progress::{next_pass_end, TILE_SIZE};
pub use progress::{Periodic, RenderControl, RenderProgress, Snapshot};

/// How light is found, for comparing the estimators (`--strategy`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Strategy {
    /// Light sampling and BSDF sampling combined by the power heuristic (the default).
    #[default]
    Mis,
    /// BSDF sampling only: emission counts only when a path hits it
    /// (point-like lights are never found).
    Bsdf,
    /// Light sampling only (next-event estimation): emission found by BSDF
    /// sampling counts only after the camera or a Dirac lobe, or where light
    /// sampling never looks (a constant dome, left to BSDF and phase
    /// sampling: `lights/select.rs`).
    Nee,
}

crate::choice::choice!(Strategy {
    Mis => "mis",
    Bsdf => "bsdf",
    Nee => "nee",
});

/// The default `--max-depth`: a safety cap far beyond what Russian roulette
/// lets paths reach (survival at most 0.95 per bounce from the third: one
/// path in 10^22 passes it in a white furnace), so the default renders
/// multiple scattering in full; lower caps darken dense media (biased).
pub const DEFAULT_MAX_DEPTH: u32 = 1024;

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
    /// Camera rays reach what lies behind the media with ratio tracking's
    /// transmittance estimate, real scattering still sampled by delta
    /// tracking (`--camera-ray-transmittance`; docs/volumes.md, "Camera
    /// rays"); off (the default): delta tracking's 0-or-1 survival.
    pub camera_ray_transmittance: bool,
}

/// The volume estimators compared in the charts (`--volume-estimator`).
/// Every one samples free flights by delta tracking; they differ in how
/// shadow rays estimate transmittance and how light and phase sampling are
/// weighted against each other.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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
    /// Unbiased ray-marching transmittance on shadow rays (Kettunen et al.
    /// 2021), MIS on directions only: its lookups are not tentative
    /// collisions, so it has no null-collision density to weigh by.
    RayMarching,
}

crate::choice::choice!(VolumeEstimator {
    NullScatteringMis => "null-scattering-mis",
    Ratio => "ratio",
    ResidualRatio => "residual-ratio",
    TrackLength => "track-length",
    RayMarching => "ray-marching",
});

impl VolumeEstimator {
    /// The shadow-ray transmittance estimator this uses.
    pub fn transmittance(self) -> TransmittanceEstimator {
        match self {
            Self::NullScatteringMis | Self::Ratio => TransmittanceEstimator::Ratio,
            Self::ResidualRatio => TransmittanceEstimator::ResidualRatio,
            Self::TrackLength => TransmittanceEstimator::TrackLength,
            Self::RayMarching => TransmittanceEstimator::RayMarching,
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

impl Budget {
    /// The sample index a render stops at, or `None` for a time budget.
    pub fn target(self) -> Option<u32> {
        match self {
            Self::Samples(n) => Some(n),
            Self::Time(_) => None,
        }
    }
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
    /// Stop each pixel once its noise estimate is under a threshold
    /// (`--noise-threshold`; slightly biased, off by default).
    pub adaptive: Option<AdaptiveSampling>,
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RayCounts {
    /// Camera rays.
    pub camera: u64,
    /// Closest-hit rays, camera rays included.
    pub closest: u64,
    /// Shadow (occlusion) rays.
    pub shadow: u64,
}

impl RayCounts {
    /// Adds another count (of a tile, or of a part of a split frame).
    pub fn add(&mut self, other: &RayCounts) {
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
    /// The budget was spent (false when the render was stopped early).
    pub complete: bool,
}

/// Renders `state` into a film from scratch to the end of the budget.
/// `progress` is called after every tile with the fraction done (of the
/// samples, or of the time budget).
pub fn render(
    state: &RenderState,
    settings: &RenderSettings,
    progress: &(dyn Fn(f64) + Sync),
) -> (Film, RenderStats) {
    let start = Snapshot::new(Film::new(state.resolution, settings.aovs.clone()), 0);
    let control = RenderControl {
        progress,
        stop: &|| false,
        periodic: &[],
    };
    let (end, stats) = render_from(state, settings, start, &control);
    (end.film, stats)
}

/// Continues a render from `start` (an empty [`Snapshot`] or a
/// checkpoint's) until the budget is spent or `control.stop` asks to stop,
/// then returns the state reached. Every tile takes its samples in the same
/// passes whether or not the render is stopped and resumed in between, so a
/// resumed render is bit-identical to an uninterrupted one.
pub fn render_from(
    state: &RenderState,
    settings: &RenderSettings,
    start: Snapshot,
    control: &RenderControl,
) -> (Snapshot, RenderStats) {
    let tiles = start.film.tiles(TILE_SIZE);
    let filter = PixelFilter::new(settings.filter);
    let clock = Instant::now();
    let earlier = start.progress.seconds;
    let seconds = || earlier + clock.elapsed().as_secs_f64();
    let target = settings.budget.target();
    let pixels = |t: &Tile| u64::from(t.size.x) * u64::from(t.size.y);
    let first = start.progress.first_sample;
    // Pixel samples taken so far, counted up as tiles finish.
    let taken = AtomicU64::new(
        tiles
            .iter()
            .zip(&start.progress.tile_samples)
            .map(|(t, &s)| pixels(t) * u64::from(s - first))
            .sum(),
    );
    let window = start.film.window.size;
    let pixels_total = f64::from(window.x) * f64::from(window.y);
    let fraction = || match settings.budget {
        Budget::Samples(n) => {
            taken.load(Ordering::Relaxed) as f64 / (pixels_total * f64::from(n - first))
        }
        Budget::Time(limit) => seconds() / limit.as_secs_f64(),
    };
    let mut start = start;
    if settings.adaptive.is_some() {
        start.film.keep_halves();
    }
    let shared = Mutex::new(start);
    let last_saves = Mutex::new(vec![Instant::now(); control.periodic.len()]);
    loop {
        let done = lock(&shared).progress.next_sample();
        let end = next_pass_end(done, target);
        if end == done || (control.stop)() {
            break;
        }
        if let Budget::Time(limit) = settings.budget {
            // Stop when the next pass would overrun (after at least one sample).
            let per_sample = seconds() / f64::from(done.max(1));
            if done > 0 && seconds() + per_sample * f64::from(end - done) > limit.as_secs_f64() {
                break;
            }
        }
        let pending: Vec<usize> = lock(&shared)
            .progress
            .tile_samples
            .iter()
            .enumerate()
            .filter(|&(_, &s)| s == done)
            .map(|(i, _)| i)
            .collect();
        let active = settings.adaptive.and_then(|adaptive| {
            let mut now = lock(&shared);
            if pending.len() == tiles.len() && done - first >= adaptive.min_samples {
                // A new pass (not one resumed half-way): decide it.
                now.film.decide_active(adaptive.threshold);
            }
            now.film.active_pixels()
        });
        if active.as_ref().is_some_and(|a| a.count() == 0) {
            break; // Every pixel has converged.
        }
        pending.par_iter().for_each(|&i| {
            if (control.stop)() {
                return;
            }
            let mut out = lock(&shared).film.tile_film(tiles[i]);
            let mut rays = RayCounts::default();
            let mut tracking = TrackingStats::default();
            let counts = (&mut rays, &mut tracking);
            let pass = Pass {
                samples: done..end,
                active: active.as_ref(),
            };
            render_tile(state, settings, &filter, pass, &mut out, counts);
            let mut now = lock(&shared);
            now.film.merge(&out);
            now.progress.tile_samples[i] = end;
            now.progress.rays.add(&rays);
            now.progress.tracking.merge(&tracking);
            taken.fetch_add(pixels(&tiles[i]) * u64::from(end - done), Ordering::Relaxed);
            (control.progress)(fraction());
            let mut last_saves = lock(&last_saves);
            for (periodic, last) in control.periodic.iter().zip(last_saves.iter_mut()) {
                if last.elapsed() >= periodic.every {
                    now.progress.seconds = seconds();
                    (periodic.save)(&now);
                    *last = Instant::now();
                }
            }
        });
    }
    let mut end = shared.into_inner().unwrap_or_else(|e| e.into_inner());
    end.progress.seconds = seconds();
    let p = &end.progress;
    let samples_per_pixel = p.samples_per_pixel();
    let stats = RenderStats {
        samples_per_pixel,
        elapsed: Duration::from_secs_f64(p.seconds),
        rays: p.rays,
        non_finite: end.film.non_finite,
        tracking: p.tracking,
        complete: !(control.stop)() || target.is_some_and(|n| p.next_sample() >= n),
    };
    (end, stats)
}

/// Locks `m`; a panicked worker's poison is ignored (its panic propagates).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The samples one pass takes.
struct Pass<'a> {
    /// Sample indices.
    samples: std::ops::Range<u32>,
    /// The pixels that take them (all when `None`).
    active: Option<&'a ActivePixels>,
}

/// Samples `pass` of every pixel of one tile that it names into `out`.
fn render_tile(
    state: &RenderState,
    settings: &RenderSettings,
    filter: &PixelFilter,
    pass: Pass,
    out: &mut TileFilm,
    (rays, tracking): (&mut RayCounts, &mut TrackingStats),
) {
    let mut sampler = Sampler::new(settings.sampler, settings.seed);
    let hit_aovs = state.hit_aovs(&settings.aovs);
    let tile = out.tile;
    for y in tile.origin.y..tile.origin.y + tile.size.y {
        for x in tile.origin.x..tile.origin.x + tile.size.x {
            let pixel = UVec2::new(x, y);
            if pass.active.is_some_and(|a| !a.contains(pixel)) {
                continue;
            }
            for index in pass.samples.clone() {
                sampler.start_pixel_sample(pixel, index);
                let film = pixel.as_vec2() + Vec2::splat(0.5) + filter.sample(sampler.next_2d());
                let u_lens = sampler.next_2d();
                // The time has its own dimension, stratified over the pixel's
                // samples; a closed shutter draws none, so unblurred renders
                // keep their sample sequences.
                let shutter = state.camera.shutter();
                let time = if shutter.is_open() {
                    shutter.time(sampler.next_1d())
                } else {
                    shutter.open
                };
                let camera = state.camera.generate_ray(film, u_lens, time);
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
                let counts = shadow::PathCounts {
                    rays: &mut *rays,
                    tracking: &mut *tracking,
                };
                let path_settings = (&settings.path, &hit_aovs);
                let (radiance, aovs) =
                    path::radiance(state, (ray, time), random, path_settings, counts);
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
