//! The pass-through weight of a camera ray (`--camera-ray-transmittance`,
//! docs/volumes.md "Camera rays"): an unbiased estimate of the transmittance
//! of the whole ray, computed on the tentative collisions of the free flight
//! that delta tracking samples along it, so it costs no lookups of its own
//! before the flight's real collision.
//!
//! Ratio tracking with a control (Novák et al. 2014, §4, on another walk's
//! collisions): for tentative collisions t_i of rate sigma_maj and any
//! control extinction sigma_c,
//!
//! ```text
//! E[ prod_i (1 - (sigma_t(t_i) - sigma_c) / sigma_maj) ] = exp(-integral of (sigma_t - sigma_c)),
//! ```
//!
//! so exp(-integral of sigma_c) times the product is unbiased for T. The control is each
//! majorant segment's minorant: every factor then lies in [sigma_c / sigma_maj, 1]
//! while the bounds hold, and a constant cell (sigma_c = sigma_t = sigma_maj) is exact.
//! Unlike residual ratio tracking, the collisions keep rate sigma_maj (delta
//! tracking needs them), so a cell whose majorant equals its control is still
//! sampled: a majorant that is too low stays unbiased here (docs/stability.md).
//! The running weight up to t_i, before t_i's factor, also weighs emission
//! collected at t_i: E[sum_i W(t_i) f(t_i) / sigma_maj] = integral of T f.

use std::cell::Cell;

use glam::Vec3;

use super::tracking::russian_roulette;
use crate::sampling::Pcg32;
use crate::volumes::segment::MajorantSegment;

/// The running pass-through weight along a walk of tentative collisions.
/// Its state is in cells so that the segment iterator ([`Self::enter`]) and
/// the collision visitor ([`Self::collide`]) can share it.
#[derive(Default)]
pub struct PassThrough {
    /// The weight per RGB channel, control applied up to `done`.
    weight: Cell<Vec3>,
    /// The control's optical depth up to the last collision.
    done: Cell<f32>,
    /// The control's optical depth before the current segment.
    before: Cell<f32>,
    /// The current segment's span and control extinction.
    segment: Cell<(f32, f32, f32)>,
}

impl PassThrough {
    /// Weight 1, before any segment.
    pub fn new() -> Self {
        Self {
            weight: Cell::new(Vec3::ONE),
            ..Self::default()
        }
    }

    /// The walk enters segment `s`; its control is its minorant, kept
    /// within [0, sigma_maj].
    pub fn enter(&self, s: &MajorantSegment) {
        self.before.set(self.control_depth(self.segment.get().1));
        let sigma_c = s.sigma_min.clamp(0.0, s.sigma_maj.max(0.0));
        self.segment.set((s.t_min, s.t_max, sigma_c));
    }

    /// A tentative collision at `t` in the current segment (majorant
    /// `sigma_maj`, extinction `sigma_t`): returns the weight up to `t`
    /// (for emission there), then takes the collision's factor, with
    /// Russian roulette below [`super::RUSSIAN_ROULETTE_THRESHOLD`].
    pub fn collide(&self, t: f32, sigma_maj: f32, sigma_t: Vec3, rng: &mut Pcg32) -> Vec3 {
        let weight = self.advance(t);
        let sigma_c = self.segment.get().2;
        let factor = Vec3::ONE - (sigma_t - Vec3::splat(sigma_c)) / sigma_maj;
        self.weight.set(russian_roulette(weight * factor, rng));
        weight
    }

    /// Whether Russian roulette has not ended it (0 stays 0).
    pub fn alive(&self) -> bool {
        self.weight.get() != Vec3::ZERO
    }

    /// The estimate of the transmittance to the end of the last segment
    /// entered (every segment must have been entered).
    pub fn finish(&self) -> Vec3 {
        self.advance(self.segment.get().1)
    }

    /// The weight with the control applied up to `t`.
    fn advance(&self, t: f32) -> Vec3 {
        let depth = self.control_depth(t);
        let weight = self.weight.get() * (self.done.get() - depth).exp();
        self.weight.set(weight);
        self.done.set(depth);
        weight
    }

    /// The control's optical depth up to `t` in the current segment.
    fn control_depth(&self, t: f32) -> f32 {
        let (start, _, sigma_c) = self.segment.get();
        self.before.get() + sigma_c * (t - start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volumes::estimators::walk_tentative_collisions;

    /// Mean, standard error and variance of `n` pass-through estimates
    /// along `segments` with grey extinction `sigma_t`, and lookups per
    /// estimate.
    fn estimate(
        segments: &[MajorantSegment],
        sigma_t: impl Fn(f32) -> f32,
        n: usize,
    ) -> (f64, f64, f64, f64) {
        let mut rng = Pcg32::new(7, 3);
        let (mut sum, mut sum_sq, mut lookups) = (0.0f64, 0.0f64, 0u64);
        for _ in 0..n {
            let pass = PassThrough::new();
            let walked = segments.iter().inspect(|s| pass.enter(s)).copied();
            walk_tentative_collisions(walked, &mut rng, |t, sigma_maj, rng| {
                lookups += 1;
                pass.collide(t, sigma_maj, Vec3::splat(sigma_t(t)), rng);
                pass.alive()
            });
            let w = if pass.alive() {
                pass.finish()
            } else {
                Vec3::ZERO
            };
            assert!(w.x == w.y && w.y == w.z, "grey gave {w}");
            sum += w.x as f64;
            sum_sq += (w.x as f64).powi(2);
        }
        let n = n as f64;
        let mean = sum / n;
        let variance = (sum_sq / n - mean * mean).max(0.0) * n / (n - 1.0);
        (mean, (variance / n).sqrt(), variance, lookups as f64 / n)
    }

    fn segment(t_min: f32, t_max: f32, sigma_maj: f32, sigma_min: f32) -> MajorantSegment {
        MajorantSegment {
            t_min,
            t_max,
            sigma_maj,
            sigma_min,
        }
    }

    /// A constant cell is exact (no variance); a ramp split into cells with
    /// exact bounds, a gap between segments, a loose majorant, a thin
    /// (depth 0.02) and a dense (depth 600) slab all read exp(-depth) within
    /// 4 sigma; the dense slab stops after about one lookup.
    #[test]
    fn pass_through_weight_reads_the_transmittance() {
        let (mean, _, variance, _) = estimate(&[segment(0.0, 2.0, 0.7, 0.7)], |_| 0.7, 2_000);
        assert!((mean - (-1.4f64).exp()).abs() < 1e-5 && variance < 1e-10);

        // sigma_t = 2 + t on [0, 1) in 4 cells, then a gap, then 0.5 on [2, 3).
        let ramp = |t: f32| if t < 1.0 { 2.0 + t } else { 0.5 };
        let mut cells: Vec<_> = (0..4)
            .map(|i| {
                let (a, b) = (i as f32 / 4.0, (i + 1) as f32 / 4.0);
                segment(a, b, 2.0 + b, 2.0 + a)
            })
            .collect();
        cells.push(segment(2.0, 3.0, 2.0, 0.0));
        let (mean, sigma, ..) = estimate(&cells, ramp, 40_000);
        let truth = (-(2.5f64 + 0.5)).exp();
        assert!(
            (mean - truth).abs() < 4.0 * sigma,
            "{mean} +- {sigma} vs {truth}"
        );

        for (sigma_t, max_lookups) in [(0.02f32, 0.05), (600.0, 1.5)] {
            let (mean, sigma, _, lookups) =
                estimate(&[segment(0.0, 1.0, sigma_t, 0.0)], |_| sigma_t, 20_000);
            let truth = (-sigma_t as f64).exp();
            assert!(
                (mean - truth).abs() < 4.0 * sigma + 1e-6,
                "depth {sigma_t}: {mean} +- {sigma} vs {truth}"
            );
            assert!(lookups < max_lookups, "depth {sigma_t}: {lookups} lookups");
        }
    }

    /// Too low a majorant (half the true maximum of the ramp 2 + t on [0, 1),
    /// control 0.5x its minimum too): delta tracking is biased there, but the
    /// pass-through weight stays unbiased (its collisions keep their rate),
    /// only noisier.
    #[test]
    fn pass_through_weight_stays_unbiased_under_too_low_a_majorant() {
        let ramp = |t: f32| 2.0 + t;
        let truth = (-2.5f64).exp();
        let (tight_mean, tight_sigma, tight_var, _) =
            estimate(&[segment(0.0, 1.0, 3.0, 2.0)], ramp, 40_000);
        let (low_mean, low_sigma, low_var, _) =
            estimate(&[segment(0.0, 1.0, 1.5, 1.0)], ramp, 40_000);
        eprintln!(
            "ramp 2 + t: true majorant {tight_mean:.4} +- {tight_sigma:.4} (variance {tight_var:.2e}), \
             half {low_mean:.4} +- {low_sigma:.4} (variance {low_var:.2e}); truth {truth:.4}"
        );
        for (mean, sigma) in [(tight_mean, tight_sigma), (low_mean, low_sigma)] {
            assert!((mean - truth).abs() < 4.0 * sigma, "{mean} +- {sigma}");
        }
        assert!(low_var > tight_var);
    }
}
