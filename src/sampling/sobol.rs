//! Per-pixel sample sequences: Owen-scrambled Sobol or independent random.
//!
//! The Sobol sampler is the "padded", shuffled and scrambled construction of
//! Burley 2020, "Practical Hash-based Owen Scrambling" (JCGT 9(4)), which is
//! also pbrt-v4's `PaddedSobolSampler` with its `FastOwenScrambler`: every
//! dimension (1D) or dimension pair (2D) of a pixel gets its own seed, hashed
//! from (pixel, dimension, user seed). With that seed the sample index is
//! Owen-scrambled (a nested uniform shuffle, so the first 2^k samples of any
//! pixel are one aligned block of 2^k Sobol points), then Sobol dimensions 0
//! and 1 are Owen-scrambled with further hashes of it. Scrambling keeps the
//! (0,2)-sequence stratification of the pair, and the per-pixel,
//! per-dimension seeds decorrelate pixels and dimensions without needing the
//! sample count in advance (the renderer also runs to a time budget).
//!
//! Hash scrambling: Laine and Karras 2011, "Stratified sampling for stochastic
//! transparency", with the improved constants of Nathan Vegdahl (2021) used by
//! pbrt-v4's `FastOwenScrambler`. Everything is a pure function of
//! (seed, pixel, sample index, dimension), so images do not depend on the
//! thread count or on the order pixels are visited.

use glam::{UVec2, Vec2};

use super::Pcg32;

/// Which sequence a [`Sampler`] draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    /// Owen-scrambled Sobol, decorrelated per pixel and per dimension.
    Sobol,
    /// Independent uniform random numbers (for comparison).
    Independent,
}

crate::choice::choice!(SamplerKind {
    Sobol => "sobol",
    Independent => "independent",
});

/// A sample generator for one pixel sample at a time; cheap to clone, one per
/// thread. Call [`Sampler::start_pixel_sample`] before drawing.
#[derive(Clone, Debug)]
pub struct Sampler {
    seed: u64,
    sequence: Sequence,
}

/// Where the current pixel sample stands, per kind.
#[derive(Clone, Debug)]
enum Sequence {
    /// Padded Sobol: each draw hashes its own dimension seed.
    Sobol(SobolState),
    /// A generator seeded from (pixel, sample index, seed).
    Independent(Pcg32),
}

/// One pixel sample's position in its padded Sobol sequence.
#[derive(Clone, Debug)]
struct SobolState {
    /// The hash of (pixel, user seed), computed once per pixel sample;
    /// each dimension's seed mixes the dimension into it.
    pixel_hash: u64,
    sample_index: u32,
    /// Dimensions consumed so far (a 2D draw consumes two).
    dimension: u32,
}

impl SobolState {
    /// Consumes `count` dimensions and returns the Owen-shuffled sample
    /// index and the 64-bit seed of those dimensions (its high half
    /// scrambles the first Sobol dimension).
    fn draw(&mut self, count: u32) -> (u32, u64) {
        let hash = dimension_hash(self.pixel_hash, self.dimension);
        self.dimension += count;
        (owen_scramble(self.sample_index, hash as u32), hash)
    }

    /// At `sample_index` of the pixel whose hash is `pixel_hash`, dimension 0.
    fn start(pixel_hash: u64, sample_index: u32) -> Self {
        Self {
            pixel_hash,
            sample_index,
            dimension: 0,
        }
    }
}

impl Sampler {
    /// The next dimension, in [0, 1).
    pub fn next_1d(&mut self) -> f32 {
        match &mut self.sequence {
            Sequence::Sobol(state) => {
                let (index, hash) = state.draw(1);
                unit_float(owen_scramble(sobol_0(index), (hash >> 32) as u32))
            }
            Sequence::Independent(rng) => rng.next_f32(),
        }
    }

    /// The next two dimensions, in [0, 1)^2: the pair is a scrambled
    /// (0,2)-sequence, stratified in every elementary interval.
    pub fn next_2d(&mut self) -> Vec2 {
        match &mut self.sequence {
            Sequence::Sobol(state) => {
                let (index, hash) = state.draw(2);
                Vec2::new(
                    unit_float(owen_scramble(sobol_0(index), (hash >> 32) as u32)),
                    unit_float(owen_scramble(sobol_1(index), mix_bits(hash) as u32)),
                )
            }
            Sequence::Independent(rng) => Vec2::new(rng.next_f32(), rng.next_f32()),
        }
    }

    /// Starts sample `sample_index` of `pixel` at dimension 0.
    pub fn start_pixel_sample(&mut self, pixel: UVec2, sample_index: u32) {
        let pixel_key = (u64::from(pixel.x) << 32) | u64::from(pixel.y);
        self.sequence = match self.sequence {
            Sequence::Sobol(_) => Sequence::Sobol(SobolState::start(
                pixel_hash(pixel_key, self.seed),
                sample_index,
            )),
            Sequence::Independent(_) => {
                Sequence::Independent(independent_rng(pixel_key, sample_index, self.seed))
            }
        };
    }

    /// A sampler of `kind`; `seed` changes every sequence. It starts at
    /// sample 0 of pixel (0, 0).
    pub fn new(kind: SamplerKind, seed: u64) -> Self {
        let sequence = match kind {
            SamplerKind::Sobol => Sequence::Sobol(SobolState::start(pixel_hash(0, seed), 0)),
            SamplerKind::Independent => Sequence::Independent(independent_rng(0, 0, seed)),
        };
        Self { seed, sequence }
    }
}

/// Sobol dimension 0, the van der Corput sequence in base 2: the index's bits
/// mirrored about the binary point (as a 0.32 fixed-point fraction).
fn sobol_0(index: u32) -> u32 {
    index.reverse_bits()
}

/// Sobol dimension 1 (primitive polynomial x + 1, all m_j = 1): the XOR of
/// the direction numbers of the index's set bits, as a 0.32 fraction, read
/// a byte of the index at a time from [`SOBOL_1_BYTES`] (four loads, where a
/// loop over the set bits of a scrambled index takes about sixteen steps).
fn sobol_1(index: u32) -> u32 {
    let [b0, b1, b2, b3] = index.to_le_bytes();
    SOBOL_1_BYTES[0][b0 as usize]
        ^ SOBOL_1_BYTES[1][b1 as usize]
        ^ SOBOL_1_BYTES[2][b2 as usize]
        ^ SOBOL_1_BYTES[3][b3 as usize]
}

/// Direction numbers of Sobol dimension 1: v_0 = 1/2, v_j = v_{j-1} xor
/// (v_{j-1} >> 1), i.e. column j of the upper-triangular Pascal matrix mod 2
/// (0x80000000, 0xc0000000, 0xa0000000, 0xf0000000, 0x88000000, ...).
const SOBOL_1_DIRECTIONS: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut j = 1;
    while j < 32 {
        v[j] = v[j - 1] ^ (v[j - 1] >> 1);
        j += 1;
    }
    v
};

/// `SOBOL_1_BYTES[k][b]`: the XOR of the direction numbers
/// `SOBOL_1_DIRECTIONS[8 k + i]` over the set bits i of byte value `b`, so
/// [`sobol_1`] of an index is the XOR of one entry per byte of it (4 KiB).
const SOBOL_1_BYTES: [[u32; 256]; 4] = {
    let mut table = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 1;
        while b < 256 {
            // Entry b extends entry b without its lowest set bit.
            let low = (b as u32).trailing_zeros() as usize;
            table[k][b] = table[k][b & (b - 1)] ^ SOBOL_1_DIRECTIONS[8 * k + low];
            b += 1;
        }
        k += 1;
    }
    table
};

/// Nested uniform (Owen) scrambling of a 0.32 fraction `v` (Burley 2020 §3):
/// bit i of the result depends only on bits i and above of `v`, so every
/// elementary interval maps onto one of the same size. Reversing the bits
/// turns that into the low-to-high dependence of a Laine-Karras style hash
/// (constants from pbrt-v4's `FastOwenScrambler`).
fn owen_scramble(v: u32, seed: u32) -> u32 {
    let mut v = v.reverse_bits();
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v.reverse_bits()
}

/// 64 well-mixed bits from (pixel, user seed): the per-pixel part of every
/// dimension's scrambling seed.
fn pixel_hash(pixel_key: u64, seed: u64) -> u64 {
    mix_bits(pixel_key ^ mix_bits(seed))
}

/// The scrambling seed of one dimension (or dimension pair) of one pixel,
/// from its [`pixel_hash`].
fn dimension_hash(pixel_hash: u64, dimension: u32) -> u64 {
    mix_bits(pixel_hash ^ u64::from(dimension))
}

/// The generator of one independent pixel sample, a pure function of
/// (pixel, sample index, user seed).
fn independent_rng(pixel_key: u64, sample_index: u32, seed: u64) -> Pcg32 {
    let hash = mix_bits(pixel_hash(pixel_key, seed) ^ u64::from(sample_index));
    Pcg32::new(hash, mix_bits(hash))
}

/// MurmurHash3's 64-bit finaliser `fmix64` (Appleby): every input bit flips
/// each output bit with probability about 1/2.
fn mix_bits(mut v: u64) -> u64 {
    v ^= v >> 33;
    v = v.wrapping_mul(0xff51_afd7_ed55_8ccd);
    v ^= v >> 33;
    v = v.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    v ^ (v >> 33)
}

/// A 0.32 fixed-point fraction as an f32 in [0, 1): its top 24 bits, exactly
/// representable, so the result never rounds up to 1.
fn unit_float(v: u32) -> f32 {
    (v >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KINDS: [SamplerKind; 2] = [SamplerKind::Sobol, SamplerKind::Independent];

    /// The first `n` 2D points of `pixel`, drawn after `skip` 1D dimensions.
    fn points_2d(sampler: &mut Sampler, pixel: UVec2, n: u32, skip: u32) -> Vec<Vec2> {
        (0..n)
            .map(|i| {
                sampler.start_pixel_sample(pixel, i);
                for _ in 0..skip {
                    sampler.next_1d();
                }
                sampler.next_2d()
            })
            .collect()
    }

    /// The first values of the first `dims` dimensions of sample `index`.
    fn draws(sampler: &mut Sampler, pixel: UVec2, index: u32, dims: u32) -> Vec<f32> {
        sampler.start_pixel_sample(pixel, index);
        (0..dims).map(|_| sampler.next_1d()).collect()
    }

    #[test]
    fn sobol_1_directions_are_the_pascal_matrix_columns() {
        assert_eq!(
            SOBOL_1_DIRECTIONS[..8],
            [
                0x8000_0000,
                0xc000_0000,
                0xa000_0000,
                0xf000_0000,
                0x8800_0000,
                0xcc00_0000,
                0xaa00_0000,
                0xff00_0000
            ]
        );
        // Sobol dimension 1 in index order (pbrt-v4's `SobolSample`, not Gray-code order).
        let expected = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, e) in expected.iter().enumerate() {
            assert_eq!(unit_float(sobol_1(i as u32)), *e, "index {i}");
        }
    }

    /// The byte tables give, for any index, the XOR of the direction
    /// numbers of its set bits, bit by bit (every single bit, then hashed
    /// indices with about sixteen set bits).
    #[test]
    fn sobol_1_byte_tables_match_the_direction_numbers() {
        let by_bits = |index: u32| {
            (0..32)
                .filter(|j| index >> j & 1 == 1)
                .fold(0, |x, j| x ^ SOBOL_1_DIRECTIONS[j])
        };
        let singles = (0..32).map(|j| 1u32 << j);
        let hashed = (0..10_000u64).map(|i| mix_bits(i) as u32);
        for index in singles.chain(hashed).chain([0, u32::MAX]) {
            assert_eq!(sobol_1(index), by_bits(index), "index {index:#x}");
        }
    }

    #[test]
    fn every_value_is_in_unit_interval() {
        for kind in KINDS {
            let mut sampler = Sampler::new(kind, 3);
            for p in 0..64 {
                for i in 0..64 {
                    sampler.start_pixel_sample(UVec2::new(p, 7 * p), i);
                    for _ in 0..8 {
                        let x = sampler.next_1d();
                        let v = sampler.next_2d();
                        for y in [x, v.x, v.y] {
                            assert!((0.0..1.0).contains(&y), "{kind:?}: {y}");
                        }
                    }
                }
            }
        }
        // The largest fraction does not round to 1.
        assert!(unit_float(u32::MAX) < 1.0);
    }

    #[test]
    fn same_inputs_same_values_and_pixels_dimensions_seeds_differ() {
        for kind in KINDS {
            let pixel = UVec2::new(5, 9);
            let a = draws(&mut Sampler::new(kind, 11), pixel, 3, 16);
            // A sampler that drew other pixels before gives the same values.
            let mut used = Sampler::new(kind, 11);
            draws(&mut used, UVec2::new(1, 2), 40, 5);
            assert_eq!(a, draws(&mut used, pixel, 3, 16), "{kind:?}");
            let other_pixel = draws(&mut Sampler::new(kind, 11), UVec2::new(9, 5), 3, 16);
            let other_seed = draws(&mut Sampler::new(kind, 12), pixel, 3, 16);
            let other_index = draws(&mut Sampler::new(kind, 11), pixel, 4, 16);
            for other in [&other_pixel, &other_seed, &other_index] {
                assert!(a.iter().zip(other).all(|(x, y)| x != y), "{kind:?}");
            }
            // No two dimensions of one sample coincide.
            for (i, x) in a.iter().enumerate() {
                assert!(a[i + 1..].iter().all(|y| x != y), "{kind:?}: {a:?}");
            }
        }
    }

    #[test]
    fn sobol_pairs_are_stratified_in_every_elementary_interval() {
        // A (0,2)-sequence in base 2: for every k, the first 2^k points put
        // exactly one point in each 2^a x 2^(k-a) box, a = 0..=k.
        let mut sampler = Sampler::new(SamplerKind::Sobol, 5);
        for (pixel, skip) in [(UVec2::new(0, 0), 0), (UVec2::new(17, 3), 3)] {
            let points = points_2d(&mut sampler, pixel, 256, skip);
            for k in 0..=8u32 {
                let n = 1usize << k;
                for a in 0..=k {
                    let mut hits = vec![0u32; n];
                    for p in &points[..n] {
                        let cx = (p.x * (1u32 << a) as f32) as usize;
                        let cy = (p.y * (1u32 << (k - a)) as f32) as usize;
                        hits[(cy << a) | cx] += 1;
                    }
                    assert!(hits.iter().all(|&h| h == 1), "k {k}, a {a}");
                }
            }
        }
    }

    #[test]
    fn sobol_1d_prefixes_are_stratified() {
        let mut sampler = Sampler::new(SamplerKind::Sobol, 8);
        let xs: Vec<f32> = (0..128)
            .map(|i| draws(&mut sampler, UVec2::new(2, 6), i, 3)[2])
            .collect();
        for k in 0..=7 {
            let n = 1usize << k;
            let mut cells: Vec<usize> = xs[..n].iter().map(|x| (x * n as f32) as usize).collect();
            cells.sort_unstable();
            assert_eq!(cells, (0..n).collect::<Vec<_>>(), "k {k}");
        }
    }

    #[test]
    fn mean_over_pixels_is_one_half_within_4_sigma() {
        // One value per (pixel, dimension): independent across pixels, so
        // the mean has sigma sqrt(1/12/n) for a uniform variable.
        for kind in KINDS {
            let mut sampler = Sampler::new(kind, 21);
            let mut xs = Vec::new();
            for y in 0..64 {
                for x in 0..64 {
                    xs.extend(draws(&mut sampler, UVec2::new(x, y), 0, 4));
                }
            }
            let n = xs.len() as f64;
            let mean = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
            let var = xs
                .iter()
                .map(|&x| (f64::from(x) - mean).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            let sigma = (var / n).sqrt();
            assert!((mean - 0.5).abs() < 4.0 * sigma, "{kind:?}: mean {mean}");
        }
    }

    #[test]
    fn sobol_integrates_a_smooth_function_far_better_than_independent() {
        // f(x, y) = x y e^x, whose integral over [0,1]^2 is 1 * 1/2.
        let f = |p: Vec2| f64::from(p.x * p.y * p.x.exp());
        let mse = |kind| {
            let mut sampler = Sampler::new(kind, 1234);
            let pixels = 64;
            let total: f64 = (0..pixels)
                .map(|p| {
                    let points = points_2d(&mut sampler, UVec2::new(p, 2 * p + 1), 256, 1);
                    let estimate = points.iter().map(|&q| f(q)).sum::<f64>() / 256.0;
                    (estimate - 0.5).powi(2)
                })
                .sum();
            total / f64::from(pixels)
        };
        let (sobol, independent) = (mse(SamplerKind::Sobol), mse(SamplerKind::Independent));
        assert!(
            sobol * 10.0 < independent,
            "sobol {sobol:e}, independent {independent:e}"
        );
    }
}
