//! Alias tables (Walker 1977; Vose 1991, "A Linear Algorithm for Generating
//! Random Numbers with a Given Distribution", IEEE TSE 17(9)): one of n
//! weighted bins in constant time, one bin read and at most one more, for
//! distributions sampled on every light sample whose CDF's binary search
//! costs more than the rest of the sample (an emitting volume's cells and
//! their unit cubes: 9-13% of a fire-lit render, `perf`, docs/benchmarks.md
//! "Fire").

use super::DiscreteSample;

/// Largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Picks bins in proportion to non-negative weights. Weights that are all
/// zero (or negative, or not finite) give the uniform distribution instead,
/// so sampling never fails.
#[derive(Clone, Debug)]
pub struct AliasTable {
    bins: Vec<AliasBin>,
}

/// One bin: kept with probability `threshold` of landing on it, else its
/// alias is picked.
#[derive(Clone, Copy, Debug)]
struct AliasBin {
    /// Share of the bin's 1/n of [0, 1) that picks the bin itself.
    threshold: f32,
    /// The bin picked in the rest of it.
    alias: u32,
    /// Probability of picking this bin: its weight over the sum.
    probability: f32,
}

impl AliasTable {
    /// Over `weights` (at least one).
    pub fn new(weights: &[f32]) -> Self {
        assert!(!weights.is_empty(), "an alias table needs a bin");
        let clean = |w: f32| {
            if w.is_finite() && w > 0.0 {
                f64::from(w)
            } else {
                0.0
            }
        };
        let sum: f64 = weights.iter().map(|&w| clean(w)).sum();
        let n = weights.len();
        let probabilities: Vec<f64> = if sum > 0.0 {
            weights.iter().map(|&w| clean(w) / sum).collect()
        } else {
            vec![1.0 / n as f64; n]
        };
        let mut scaled: Vec<f64> = probabilities.iter().map(|p| p * n as f64).collect();
        let mut bins: Vec<AliasBin> = (0..n)
            .map(|i| AliasBin {
                threshold: 1.0,
                alias: i as u32,
                probability: probabilities[i] as f32,
            })
            .collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            large.pop();
            bins[s].threshold = scaled[s] as f32;
            bins[s].alias = l as u32;
            scaled[l] += scaled[s] - 1.0;
            if scaled[l] < 1.0 {
                small.push(l);
            } else {
                large.push(l);
            }
        }
        // What is left holds 1 up to rounding: keeps itself.
        Self { bins }
    }

    /// Picks a bin with probability proportional to its weight; the
    /// random number rescaled within what picked it is uniform again.
    pub fn sample_discrete(&self, u: f32) -> DiscreteSample {
        let n = self.bins.len();
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        let f = (x - i as f32).clamp(0.0, ONE_MINUS_EPSILON);
        let bin = self.bins[i];
        let (index, remapped) = if f < bin.threshold {
            (i, f / bin.threshold)
        } else {
            (
                bin.alias as usize,
                (f - bin.threshold) / (1.0 - bin.threshold),
            )
        };
        DiscreteSample {
            index,
            probability: self.bins[index].probability,
            remapped: remapped.clamp(0.0, ONE_MINUS_EPSILON),
        }
    }

    /// Probability that [`Self::sample_discrete`] picks bin `index`.
    pub fn probability(&self, index: usize) -> f32 {
        self.bins[index].probability
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.bins.capacity() * std::mem::size_of::<AliasBin>()
    }

    /// Bytes a table over `n` weights holds.
    pub fn bytes_for(n: u64) -> u64 {
        n * std::mem::size_of::<AliasBin>() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// Each bin is picked as often as its probability says (within 4 sigma),
    /// a zero-weight bin never, and the remapped number stays uniform.
    #[test]
    fn picks_bins_by_weight() {
        let weights = [1.0, 0.0, 7.0, 0.5, 1.5, f32::NAN];
        let table = AliasTable::new(&weights);
        let mut rng = Pcg32::new(3, 0);
        let n = 100_000;
        let mut counts = [0u32; 6];
        let mut remapped = 0.0f64;
        for _ in 0..n {
            let s = table.sample_discrete(rng.next_f32());
            counts[s.index] += 1;
            assert_eq!(s.probability, table.probability(s.index));
            remapped += f64::from(s.remapped);
        }
        for (i, &w) in weights.iter().enumerate() {
            let p = if w.is_finite() {
                f64::from(w) / 10.0
            } else {
                0.0
            };
            assert!((f64::from(table.probability(i)) - p).abs() < 1e-6);
            let expected = p * f64::from(n);
            let sigma = (expected * (1.0 - p)).sqrt();
            let got = f64::from(counts[i]);
            assert!(
                (got - expected).abs() <= 4.0 * sigma,
                "bin {i}: {got} vs {expected}"
            );
        }
        let mean = remapped / f64::from(n);
        assert!(
            (mean - 0.5).abs() < 4.0 * (1.0 / 12.0 / f64::from(n)).sqrt(),
            "{mean}"
        );
        let uniform = AliasTable::new(&[0.0, 0.0]);
        assert_eq!(uniform.probability(1), 0.5);
    }
}
