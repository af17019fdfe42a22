//! PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
//! Statistically Good Algorithms for Random Number Generation"): a small,
//! fast generator with independent streams, deterministic for a given seed.

/// The PCG-XSH-RR 64/32 generator: 64-bit state, 32-bit output.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MULTIPLIER: u64 = 6364136223846793005;

    /// A generator for `seed` on stream `stream`; different streams never overlap.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The next uniformly distributed 32-bit integer.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in [0, 1): 24 random mantissa bits, never exactly 1.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// A uniform double in [0, 1), from 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_sequence_and_streams_differ() {
        let a: Vec<u32> = (0..8)
            .scan(Pcg32::new(7, 1), |r, _| Some(r.next_u32()))
            .collect();
        let b: Vec<u32> = (0..8)
            .scan(Pcg32::new(7, 1), |r, _| Some(r.next_u32()))
            .collect();
        let c: Vec<u32> = (0..8)
            .scan(Pcg32::new(7, 2), |r, _| Some(r.next_u32()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn uniform_mean_and_variance_within_4_sigma() {
        // For U(0,1): mean 1/2, variance 1/12. The sample mean of n draws has
        // standard deviation sqrt(1/12/n).
        let n = 200_000;
        let mut rng = Pcg32::new(42, 0);
        let xs: Vec<f64> = (0..n).map(|_| rng.next_f32() as f64).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let sigma = (1.0 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 4.0 * sigma, "mean {mean}");
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        // Var of the sample variance for U(0,1) is (mu4 - sigma^4)/n = (1/80 - 1/144)/n.
        let var_sigma = ((1.0 / 80.0 - 1.0 / 144.0) / n as f64).sqrt();
        assert!((var - 1.0 / 12.0).abs() < 4.0 * var_sigma, "variance {var}");
    }
}
