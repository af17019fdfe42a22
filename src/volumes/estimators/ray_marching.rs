//! Unbiased ray-marching transmittance (Kettunen, d'Eon, Pantaleoni and
//! Novák 2021, "An Unbiased Ray-marching Transmittance Estimator", ACM TOG
//! 40(4)): a power series of `exp` around an online control optical depth
//! from one jittered ray march, whose higher orders, estimated from more
//! independent marches and rarely evaluated, remove ray marching's bias.
//! Derived from the paper's construction (power-series expansion, control
//! variate from a sampled optical depth, equidistant "comb" of lookups,
//! U-statistics, Russian roulette on the order); our comb, control and order
//! distribution are our own choices, documented below and in docs/volumes.md.
//!
//! With `x = tbar - tau` for any `tbar` independent of the `Y_j` below,
//!
//! ```text
//! exp(-tau) = exp(-tbar) exp(x) = exp(-tbar) sum_k x^k / k!
//! ```
//!
//! Given `N` independent unbiased estimates `Y_1..Y_N` of `x`, the
//! elementary symmetric mean `e_k(Y) / C(N, k)` is an unbiased estimate of
//! `x^k` for every `k <= N` (a U-statistic: the mean over all `k`-subsets of
//! products of independent estimates). Drawing `N` independently of the
//! `Y`s and weighting order `k` by `1 / P(N >= k)` gives
//!
//! ```text
//! T = exp(-tbar) sum_{k=0}^{N} e_k(Y_1..Y_N) / (C(N, k) k! P(N >= k)),
//! ```
//!
//! whose expectation is `exp(-tbar) sum_k P(N >= k) x^k / (k! P(N >= k))
//! = exp(-tau)` exactly: unbiased for any `tbar` and any order distribution
//! with `P(N >= k) > 0`.

use glam::{DVec3, Vec3};
use smallvec::SmallVec;

use super::stats::TrackingStats;
use crate::sampling::Pcg32;
use crate::volumes::segment::MajorantSegment;

/// Comb points per unit of the ray's bound width `W = ∫ (sigma_maj - sigma_min) dt`
/// (see [`Comb`]): about one lookup per unit of optical depth the majorant
/// grid cannot pin down.
const POINTS_PER_WIDTH: f64 = 1.0;

/// The most points one comb takes; wider rays get a coarser comb (still
/// unbiased; the orders then carry more of the estimate).
const MAX_POINTS: u32 = 64;

/// Rays whose bound width `W` is at most this take the bounds' midpoint as
/// control without a pilot comb: `|x| <= W / 2` already, so the series
/// converges in a few orders, and a thin ray costs `W / 2` lookups on
/// average instead of at least one.
const PILOT_WIDTH: f64 = 2.0;

/// Below this control transmittance `exp(-tbar)` the correction orders are
/// Russian-rouletted as a whole (survival `exp(-tbar) / threshold`), so rays
/// the pilot march already finds opaque stop after one comb.
const CONTROL_ROULETTE_THRESHOLD: f32 = 0.05;

/// Unbiased ray-marching transmittance `exp(-∫ sigma_t dt)` per RGB channel
/// along `segments` (Kettunen et al. 2021). `sigma_t(t)` is the extinction
/// per scene unit per channel; each segment's grey `[sigma_min, sigma_maj]`
/// brackets it. Estimator:
///
/// - **Comb**: one estimate of `∫ (sigma_t - sigma_mid) dt`, `sigma_mid` the
///   midpoint of each segment's bounds, by `M` equidistant points with one
///   shared jitter, spaced evenly in the bound width `∫ w dt`,
///   `w = sigma_maj - sigma_min` (so constant cells, `w = 0`, take none and
///   are exact); each point weighs `(sigma_t - sigma_mid) W / (M w)`, within
///   `±W / (2M)` when the bounds hold. `M = ceil(W)` capped at 64.
/// - **Control**: `tbar = ∫ sigma_mid dt + ` one comb (the pilot): a
///   ray-marched optical depth, so `x = tbar - tau` is the march's error.
///   Where `W <= 2` ([`PILOT_WIDTH`]) the pilot is skipped: `tbar = ∫ sigma_mid dt`.
/// - **Orders**: `Y_j` = pilot minus a fresh comb, `j = 1..N`; `N` is drawn
///   with continuation `P(N >= k | N >= k - 1) = min(1, a / k)`,
///   `a = W / (2M)` (the bound on one point's weight, and on `|Y|` for a
///   one-point comb): `P(N >= k)` falls like `a^k / k!` past `a`, so the
///   variance of the orders stays below about `exp(E[Y^2] / a)`: small where
///   the comb resolves the density, large where it cannot (spikes narrower
///   than its spacing; docs/stability.md).
/// - Below [`CONTROL_ROULETTE_THRESHOLD`] the orders are rouletted as a whole.
///
/// Single estimates can be negative or above 1 (the series alternates);
/// the mean is exact. With chromatic extinction every channel has its own
/// control and `Y`s over the same points. A violated bound keeps it
/// unbiased except on a segment with `sigma_maj = sigma_min`, which takes no
/// points (as residual ratio tracking's, docs/stability.md).
pub(super) fn ray_marching(
    segments: impl IntoIterator<Item = MajorantSegment>,
    mut sigma_t: impl FnMut(f32) -> Vec3,
    rng: &mut Pcg32,
    stats: &mut TrackingStats,
) -> Vec3 {
    let comb = Comb::new(segments);
    if comb.width <= 0.0 {
        return Vec3::splat((-comb.depth_mid).exp() as f32);
    }
    let pilot = if comb.width > PILOT_WIDTH {
        comb.estimate(&mut sigma_t, rng, stats)
    } else {
        DVec3::ZERO
    };
    // In f64: tbar is a small difference of large depths on wide rays, and
    // f32 rounding there is a bias (4e-5 on a teapot ray).
    let control = (-(DVec3::splat(comb.depth_mid) + pilot)).exp().as_vec3();
    let mut weight = control;
    let largest = control.max_element();
    if largest < CONTROL_ROULETTE_THRESHOLD {
        let survive = largest / CONTROL_ROULETTE_THRESHOLD;
        if rng.next_f32() >= survive {
            return Vec3::ZERO;
        }
        weight /= survive;
    }
    let order = draw_order(comb.width / (2.0 * f64::from(comb.points)), rng);
    // e_k(Y_1..Y_N), built one Y at a time; then the k-th term is
    // e_k / (C(N, k) k! P(N >= k)) = e_k (N - k)! / (N! P(N >= k)). In f64:
    // the alternating terms of a wide ray's series cancel.
    let mut symmetric: SmallVec<[DVec3; 8]> = SmallVec::new();
    symmetric.push(DVec3::ONE);
    for _ in 0..order.len() {
        let y = pilot - comb.estimate(&mut sigma_t, rng, stats);
        symmetric.push(DVec3::ZERO);
        for k in (1..symmetric.len()).rev() {
            let below = symmetric[k - 1];
            symmetric[k] += below * y;
        }
    }
    let n = order.len();
    let mut sum = DVec3::ZERO;
    for (k, e_k) in symmetric.iter().enumerate() {
        // (N - k)! / N! = 1 / (N (N - 1) ... (N - k + 1)).
        let falling: f64 = (n - k + 1..=n).map(|i| i as f64).product();
        sum += *e_k / (falling * order.at_least(k));
    }
    weight * sum.as_vec3()
}

/// The expansion order `N` and its tail probabilities `P(N >= k)`.
struct Order {
    /// `P(N >= k)` for `k = 0..=N`.
    at_least: SmallVec<[f64; 8]>,
}

impl Order {
    /// `N`.
    fn len(&self) -> usize {
        self.at_least.len() - 1
    }

    /// `P(N >= k)` for `k <= N`.
    fn at_least(&self, k: usize) -> f64 {
        self.at_least[k]
    }
}

/// Draws the order `N`: from `N >= k - 1` on to `N >= k` with probability
/// `min(1, a / k)`, so the first `floor(a)` orders are always taken and
/// the tail falls like a Poisson distribution's of mean `a`.
fn draw_order(a: f64, rng: &mut Pcg32) -> Order {
    let mut at_least = SmallVec::new();
    let mut p = 1.0f64;
    at_least.push(p);
    let mut k = 1.0f64;
    loop {
        let go_on = (a / k).min(1.0);
        if go_on < 1.0 && rng.next_f64() >= go_on {
            return Order { at_least };
        }
        p *= go_on;
        at_least.push(p);
        k += 1.0;
    }
}

/// The ray's segments with the midpoint control and bound width of each,
/// and the comb that marches them.
struct Comb {
    /// `(segment, sigma_lo, w)`: the segment, its minorant clamped to
    /// `[0, sigma_maj]`, and its width `sigma_maj - sigma_lo`.
    pieces: SmallVec<[(MajorantSegment, f32, f32); 16]>,
    /// `∫ sigma_mid dt` over all segments, `sigma_mid = (sigma_maj + sigma_lo) / 2`.
    depth_mid: f64,
    /// `W = ∫ w dt`: the optical depth the bounds leave open.
    width: f64,
    /// `M`, points per comb.
    points: u32,
}

impl Comb {
    fn new(segments: impl IntoIterator<Item = MajorantSegment>) -> Self {
        let mut pieces = SmallVec::new();
        let (mut depth_mid, mut width) = (0.0f64, 0.0f64);
        for segment in segments {
            let length = segment.t_max - segment.t_min;
            let sigma_maj = segment.sigma_maj.max(0.0);
            let sigma_lo = segment.sigma_min.clamp(0.0, sigma_maj);
            let w = sigma_maj - sigma_lo;
            depth_mid += f64::from(0.5 * (sigma_maj + sigma_lo) * length);
            width += f64::from(w * length);
            pieces.push((segment, sigma_lo, w));
        }
        let points = (width * POINTS_PER_WIDTH)
            .ceil()
            .clamp(1.0, f64::from(MAX_POINTS)) as u32;
        Self {
            pieces,
            depth_mid,
            width,
            points,
        }
    }

    /// One estimate of `∫ (sigma_t - sigma_mid) dt` (per channel): `M`
    /// points at `s_i = (i + u) W / M` in bound-width depth `s = ∫ w dt`,
    /// each weighing `(sigma_t - sigma_mid) (W / M) / w` (importance
    /// sampling with density `w / W`, stratified: unbiased for any `u`
    /// uniform in [0, 1)).
    fn estimate(
        &self,
        sigma_t: &mut impl FnMut(f32) -> Vec3,
        rng: &mut Pcg32,
        stats: &mut TrackingStats,
    ) -> DVec3 {
        let spacing = self.width / f64::from(self.points);
        let jitter = rng.next_f64();
        let mut s = jitter * spacing;
        let mut sum = DVec3::ZERO;
        // Bound-width depth at the start of the current piece.
        let mut start = 0.0f64;
        let mut taken = 0;
        // The last piece takes every point left, should rounding put one past its end.
        let last = self.pieces.iter().rposition(|p| p.2 > 0.0);
        for (i, &(segment, sigma_lo, w)) in self.pieces.iter().enumerate() {
            if w <= 0.0 {
                continue;
            }
            let w64 = f64::from(w);
            let end = start + f64::from(w * (segment.t_max - segment.t_min));
            while taken < self.points && (s < end || Some(i) == last) {
                let t = (segment.t_min + ((s - start) / w64) as f32).min(segment.t_max);
                let sigma = sigma_t(t);
                stats.count_lookup(sigma, segment.sigma_maj);
                let sigma_mid = sigma_lo + 0.5 * w;
                sum += (sigma - Vec3::splat(sigma_mid)).as_dvec3() * (spacing / w64);
                taken += 1;
                s = (f64::from(taken) + jitter) * spacing;
            }
            start = end;
        }
        sum
    }
}
