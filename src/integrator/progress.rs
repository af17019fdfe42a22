//! How far a render has got, and the hooks that watch it: the state a
//! checkpoint saves and a resumed render continues from.
//!
//! Every tile takes its samples in fixed passes (sample index ranges 0..1,
//! 1..2, 2..4, 4..8, 8..16, 16..32, then 16 more each), summed into the film
//! pass by pass. A render stopped between tiles and resumed later therefore
//! adds exactly the same partial sums in the same order as one that was never
//! stopped: the image is bit-identical.

use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::{RayCounts, RenderSettings};
use crate::film::Film;
use crate::volumes::estimators::TrackingStats;

/// Tile edge in pixels: enough tiles for load balance on many cores, big
/// enough that per-tile overhead vanishes.
pub(super) const TILE_SIZE: u32 = 16;

/// Longest pass in samples per pixel: passes are 1, 1, 2, 4, 8, 16, 16, ...
/// samples, so the total doubles (1, 2, 4 .. 32) and then grows by this much
/// (48, 64, ...). Sobol points are best balanced at powers of two and
/// multiples of this; time budgets are checked between passes.
const MAX_PASS_SAMPLES: u32 = 16;

/// Samples taken per tile and what the render has spent so far.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderProgress {
    /// The first sample index this render takes (0, or the start of a
    /// `--sample-range` part).
    pub first_sample: u32,
    /// The next sample index of each tile of [`TILE_SIZE`] pixels, in
    /// [`Film::tiles`] order; always a pass boundary.
    pub tile_samples: Vec<u32>,
    /// Wall-clock seconds of sampling, over every run of the render.
    pub seconds: f64,
    /// Rays traced, over every run.
    pub rays: RayCounts,
    /// Media counters, over every run.
    pub tracking: TrackingStats,
}

impl RenderProgress {
    /// The sample index every tile has reached.
    pub fn next_sample(&self) -> u32 {
        self.tile_samples
            .iter()
            .copied()
            .min()
            .unwrap_or(self.first_sample)
    }

    /// Samples per pixel that every tile has taken.
    pub fn samples_per_pixel(&self) -> u32 {
        self.next_sample() - self.first_sample
    }

    /// Whether no tile has taken a sample yet.
    pub fn is_empty(&self) -> bool {
        self.tile_samples.iter().all(|&s| s == self.first_sample)
    }
}

/// A render's film and progress at a pass boundary: what a checkpoint or a
/// farm part saves, and what a resumed render continues from.
#[derive(Clone, Debug)]
pub struct Snapshot {
    /// The sums so far.
    pub film: Film,
    /// How far each tile has got.
    pub progress: RenderProgress,
}

impl Snapshot {
    /// A state with no samples yet, for the empty `film` (of the whole
    /// image or a window of it), whose samples start at `first_sample`.
    pub fn new(film: Film, first_sample: u32) -> Self {
        let tiles = film.tiles(TILE_SIZE).len();
        Self {
            film,
            progress: RenderProgress {
                first_sample,
                tile_samples: vec![first_sample; tiles],
                seconds: 0.0,
                rays: RayCounts::default(),
                tracking: TrackingStats::default(),
            },
        }
    }

    /// Checks that a saved state can continue the render that `fresh` (its
    /// empty state) starts, with `settings`: same image size, window, first
    /// sample and AOVs, one entry per tile, each a pass boundary within the
    /// budget. The error says what differs.
    pub fn check(&self, fresh: &Snapshot, settings: &RenderSettings) -> Result<(), String> {
        let (film, expected) = (&self.film, &fresh.film);
        if (film.resolution, film.window) != (expected.resolution, expected.window) {
            return Err(format!(
                "it holds {:?} of {}, this render {:?} of {}",
                film.window, film.resolution, expected.window, expected.resolution
            ));
        }
        let first = self.progress.first_sample;
        if first != fresh.progress.first_sample {
            return Err(format!(
                "it starts at sample {first}, this render at {}",
                fresh.progress.first_sample
            ));
        }
        if film.aov_set() != &settings.aovs {
            return Err(format!(
                "it holds AOVs {}, this render asks for {}",
                film.aov_set(),
                settings.aovs
            ));
        }
        if film.keeps_halves() != settings.adaptive.is_some() {
            let with = |on: bool| if on { "with" } else { "without" };
            return Err(format!(
                "it was rendered {} adaptive sampling, this render is {} it",
                with(film.keeps_halves()),
                with(settings.adaptive.is_some())
            ));
        }
        let tiles = film.tiles(TILE_SIZE).len();
        let p = &self.progress;
        if p.tile_samples.len() != tiles {
            return Err(format!(
                "it records {} tiles, the image has {tiles}",
                p.tile_samples.len()
            ));
        }
        let target = settings.budget.target();
        match p
            .tile_samples
            .iter()
            .find(|&&s| !is_pass_end(s, first, target))
        {
            Some(s) => Err(format!(
                "a tile records {s} samples, not a pass boundary of this budget"
            )),
            None => Ok(()),
        }
    }
}

/// What a running render reports to and asks of its caller.
pub struct RenderControl<'a> {
    /// Called after every tile with the fraction done (of the samples, or of
    /// the time budget).
    pub progress: &'a (dyn Fn(f64) + Sync),
    /// Polled before every tile: true stops the render once the tiles in
    /// flight are done (their samples are kept).
    pub stop: &'a (dyn Fn() -> bool + Sync),
    /// What is done with the state while it runs, each at its own
    /// interval (checkpoints, previews).
    pub periodic: &'a [Periodic<'a>],
}

/// Something done with a running render's state at a fixed interval.
pub struct Periodic<'a> {
    /// Wall-clock time between calls.
    pub every: Duration,
    /// Reads a consistent snapshot (called between tiles, with the film
    /// locked), e.g. to save a checkpoint or rewrite the preview.
    pub save: &'a (dyn Fn(&Snapshot) + Sync),
}

/// The sample count at the end of the pass that starts at `done` (a pass
/// boundary), capped at `target`; `done` itself when the target is reached.
pub(super) fn next_pass_end(done: u32, target: Option<u32>) -> u32 {
    let end = (2 * done).min(done + MAX_PASS_SAMPLES).max(1);
    target.map_or(end, |n| end.min(n).max(done))
}

/// Whether sample index `samples` is a pass boundary of a render from
/// `first` towards `target`.
fn is_pass_end(samples: u32, first: u32, target: Option<u32>) -> bool {
    let mut end = first;
    while end < samples {
        let next = next_pass_end(end, target);
        if next == end {
            return false;
        }
        end = next;
    }
    end == samples
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_double_then_grow_by_sixteen_and_stop_at_the_target() {
        let ends = |target| {
            let mut ends = vec![0];
            loop {
                let e = next_pass_end(*ends.last().unwrap(), target);
                if e == *ends.last().unwrap() || ends.len() > 10 {
                    return ends;
                }
                ends.push(e);
            }
        };
        assert_eq!(ends(Some(40)), [0, 1, 2, 4, 8, 16, 32, 40]);
        assert_eq!(ends(None), [0, 1, 2, 4, 8, 16, 32, 48, 64, 80, 96]);
        assert!(is_pass_end(40, 0, Some(40)) && is_pass_end(32, 0, Some(40)));
        assert!(!is_pass_end(40, 0, None) && !is_pass_end(3, 0, Some(40)));
        assert!(!is_pass_end(41, 0, Some(40)));
        // A sample-range part from 20: 20, 36, 52, 60.
        assert!(is_pass_end(36, 20, Some(60)) && is_pass_end(52, 20, Some(60)));
        assert!(!is_pass_end(40, 20, Some(60)) && !is_pass_end(10, 20, Some(60)));
    }
}
