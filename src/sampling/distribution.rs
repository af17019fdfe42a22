//! Piecewise-constant 1D and 2D distributions (pbrt-v4's `PiecewiseConstant1D`
//! and `PiecewiseConstant2D`, §A.4): sample a tabulated function in proportion
//! to its values, for light selection, triangle selection by area and
//! environment-map importance sampling.

use glam::Vec2;

/// A piecewise-constant density over [0, 1) from non-negative weights, one
/// bin of width 1/n per weight. Weights that are all zero (or negative, or not
/// finite) give the uniform density instead, so sampling never fails.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// The weights as given (non-finite or negative ones as 0; all 1 when none is positive).
    func: Vec<f32>,
    /// `n + 1` entries: cdf[0] = 0, cdf[n] = 1.
    cdf: Vec<f32>,
    /// Integral of `func` over [0, 1): the mean weight.
    integral: f32,
}

/// A continuous sample of a [`Distribution1D`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContinuousSample {
    /// The sampled point in [0, 1).
    pub x: f32,
    /// Density at `x` (with respect to length on [0, 1)).
    pub pdf: f32,
    /// The bin `x` falls in.
    pub index: usize,
}

/// A discrete sample of a [`Distribution1D`]: one of its bins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscreteSample {
    /// The bin picked.
    pub index: usize,
    /// Probability of picking it: its weight over the sum of weights.
    pub probability: f32,
    /// The random number rescaled to [0, 1) within the bin, reusable as a
    /// fresh uniform variate (pbrt's `uRemapped`).
    pub remapped: f32,
}

/// A piecewise-constant density over [0, 1)^2 (rows of [`Distribution1D`]
/// under a marginal), as for a lat-long environment map.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    /// One conditional distribution over x per row (y bin).
    rows: Vec<Distribution1D>,
    /// Over rows, weighted by each row's integral.
    marginal: Distribution1D,
}

impl Distribution1D {
    /// Bytes held: the weights and the CDF.
    pub fn memory_bytes(&self) -> usize {
        4 * (self.func.capacity() + self.cdf.capacity())
    }

    /// Bytes a distribution over `n` weights holds.
    pub fn bytes_for(n: u64) -> u64 {
        4 * (2 * n + 1)
    }

    /// Samples a point in [0, 1) with density proportional to the weights,
    /// by inverting the piecewise-linear CDF.
    pub fn sample_continuous(&self, u: f32) -> ContinuousSample {
        let index = self.find_bin(u);
        let (c0, c1) = (self.cdf[index], self.cdf[index + 1]);
        let du = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.0 };
        let n = self.func.len() as f32;
        let x = ((index as f32 + du.clamp(0.0, 1.0)) / n).min(ONE_MINUS_EPSILON);
        ContinuousSample {
            x,
            pdf: self.func[index] / self.integral,
            index,
        }
    }

    /// Picks a bin with probability proportional to its weight.
    pub fn sample_discrete(&self, u: f32) -> DiscreteSample {
        let index = self.find_bin(u);
        let (c0, c1) = (self.cdf[index], self.cdf[index + 1]);
        let remapped = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.0 };
        DiscreteSample {
            index,
            probability: self.probability(index),
            remapped: remapped.clamp(0.0, ONE_MINUS_EPSILON),
        }
    }

    /// Density of the continuous sample at `x` in [0, 1).
    pub fn pdf(&self, x: f32) -> f32 {
        let n = self.func.len();
        let index = ((x * n as f32) as usize).min(n - 1);
        self.func[index] / self.integral
    }

    /// Probability that [`Self::sample_discrete`] picks bin `index`.
    pub fn probability(&self, index: usize) -> f32 {
        self.func[index] / (self.integral * self.func.len() as f32)
    }

    /// Integral of the weights over [0, 1) (their mean), as used for the
    /// density; 1 when the weights were replaced by the uniform ones.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The last bin whose CDF start is at or below `u` and that has weight.
    fn find_bin(&self, u: f32) -> usize {
        let n = self.func.len();
        // First cdf entry above u, minus one: the bin [cdf[i], cdf[i+1]) holding u.
        let above = self.cdf.partition_point(|&c| c <= u);
        let mut index = above.saturating_sub(1).min(n - 1);
        // Rounding can land u on an empty bin at the top; step back to one with weight.
        while self.func[index] == 0.0 && index > 0 {
            index -= 1;
        }
        index
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl Distribution2D {
    /// Samples `(x, y)` in [0, 1)^2 with density proportional to the weights:
    /// a row from the marginal, then x within it. Returns the point and its
    /// density per unit square.
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let y = self.marginal.sample_continuous(u.y);
        let x = self.rows[y.index].sample_continuous(u.x);
        (Vec2::new(x.x, y.x), x.pdf * y.pdf)
    }

    /// Density per unit square at `uv` in [0, 1)^2.
    pub fn pdf(&self, uv: Vec2) -> f32 {
        let height = self.rows.len();
        let row = ((uv.y * height as f32) as usize).min(height - 1);
        self.rows[row].pdf(uv.x) * self.marginal.pdf(uv.y)
    }
}

impl Distribution1D {
    /// A distribution over `weights.len()` equal bins. Negative and non-finite
    /// weights count as 0; if none is positive, every bin gets weight 1.
    ///
    /// # Panics
    /// If `weights` is empty.
    pub fn new(weights: &[f32]) -> Self {
        assert!(!weights.is_empty(), "a distribution needs at least one bin");
        let mut func: Vec<f32> = weights
            .iter()
            .map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 })
            .collect();
        let n = func.len();
        // Sum in f64: a million small weights would lose bins in f32.
        let mut running = 0.0f64;
        let mut sums = Vec::with_capacity(n + 1);
        sums.push(0.0f64);
        for &w in &func {
            running += f64::from(w) / n as f64;
            sums.push(running);
        }
        if running <= 0.0 || !running.is_finite() {
            func.fill(1.0);
            sums = (0..=n).map(|i| i as f64 / n as f64).collect();
            running = 1.0;
        }
        let cdf = sums.iter().map(|&s| (s / running) as f32).collect();
        Self {
            func,
            cdf,
            integral: running as f32,
        }
    }
}

impl Distribution2D {
    /// A distribution over a `width` x `height` grid of weights, row-major
    /// (row 0 = the bins of smallest y).
    ///
    /// # Panics
    /// If `weights.len() != width * height` or either size is 0.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        assert!(width > 0 && height > 0 && weights.len() == width * height);
        let rows: Vec<Distribution1D> = weights
            .chunks_exact(width)
            .map(Distribution1D::new)
            .collect();
        // A row whose weights were all zero became uniform; its marginal weight stays 0.
        let row_weights: Vec<f32> = weights
            .chunks_exact(width)
            .zip(&rows)
            .map(|(w, r)| {
                if w.iter().any(|&v| v.is_finite() && v > 0.0) {
                    r.integral()
                } else {
                    0.0
                }
            })
            .collect();
        Self {
            rows,
            marginal: Distribution1D::new(&row_weights),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// Counts in each bin of `n` draws against the expected `n p`, within 4
    /// binomial sigmas.
    fn assert_histogram(counts: &[u32], probabilities: &[f64], n: u32) {
        for (i, (&c, &p)) in counts.iter().zip(probabilities).enumerate() {
            let expected = f64::from(n) * p;
            let sigma = (f64::from(n) * p * (1.0 - p)).sqrt();
            assert!(
                (f64::from(c) - expected).abs() <= 4.0 * sigma + 1e-9,
                "bin {i}: {c} draws, expected {expected} (sigma {sigma})"
            );
        }
    }

    #[test]
    fn discrete_and_continuous_samples_follow_the_weights() {
        let weights = [1.0, 0.0, 3.0, 0.5, 2.5];
        let total: f32 = weights.iter().sum();
        let p: Vec<f64> = weights.iter().map(|&w| f64::from(w / total)).collect();
        let d = Distribution1D::new(&weights);
        let mut rng = Pcg32::new(11, 0);
        let n = 100_000;
        let (mut discrete, mut continuous) = (vec![0u32; 5], vec![0u32; 5]);
        for _ in 0..n {
            let s = d.sample_discrete(rng.next_f32());
            assert!((s.probability - p[s.index] as f32).abs() < 1e-6);
            assert!((0.0..1.0).contains(&s.remapped));
            discrete[s.index] += 1;
            let c = d.sample_continuous(rng.next_f32());
            assert!((0.0..1.0).contains(&c.x));
            assert_eq!(c.index, (c.x * 5.0) as usize);
            assert!((d.pdf(c.x) - c.pdf).abs() <= 1e-6 * c.pdf);
            continuous[c.index] += 1;
        }
        assert_eq!(
            discrete[1] + continuous[1],
            0,
            "a zero-weight bin is never drawn"
        );
        assert_histogram(&discrete, &p, n);
        assert_histogram(&continuous, &p, n);
        // The density integrates to 1: bins of width 1/5.
        let integral: f32 = (0..5).map(|i| d.pdf((i as f32 + 0.5) / 5.0) / 5.0).sum();
        assert!((integral - 1.0).abs() < 1e-6);
    }

    #[test]
    fn all_zero_weights_give_the_uniform_distribution() {
        let d = Distribution1D::new(&[0.0, 0.0, f32::NAN, -1.0]);
        for i in 0..4 {
            assert_eq!(d.probability(i), 0.25);
        }
        assert_eq!(d.sample_discrete(0.6).index, 2);
        assert_eq!(d.pdf(0.1), 1.0);
    }

    #[test]
    fn two_dimensional_samples_follow_the_weights_and_their_pdf() {
        // 3 x 2 grid, row 0 = small y; the empty row 1 is never drawn.
        let weights = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 4.0, 0.0, 2.0];
        let d = Distribution2D::new(&weights, 3, 3);
        let total: f32 = weights.iter().sum();
        let p: Vec<f64> = weights.iter().map(|&w| f64::from(w / total)).collect();
        let mut rng = Pcg32::new(12, 1);
        let n = 100_000;
        let mut counts = vec![0u32; 9];
        for _ in 0..n {
            let (uv, pdf) = d.sample(Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!((0.0..1.0).contains(&uv.x) && (0.0..1.0).contains(&uv.y));
            assert!(
                (d.pdf(uv) - pdf).abs() <= 1e-5 * pdf,
                "{} vs {pdf}",
                d.pdf(uv)
            );
            let cell = (uv.y * 3.0) as usize * 3 + (uv.x * 3.0) as usize;
            // Per-cell density is 9 p (cells of area 1/9).
            assert!((pdf - 9.0 * p[cell] as f32).abs() < 1e-4);
            counts[cell] += 1;
        }
        assert_histogram(&counts, &p, n);
        let integral: f32 = (0..9)
            .map(|c| {
                d.pdf(Vec2::new(
                    ((c % 3) as f32 + 0.5) / 3.0,
                    ((c / 3) as f32 + 0.5) / 3.0,
                )) / 9.0
            })
            .sum();
        assert!((integral - 1.0).abs() < 1e-5);
    }
}
