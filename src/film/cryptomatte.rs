//! Cryptomatte v1.1 (Psyop): ID hashing and per-pixel coverage ranks.
//!
//! Implements Friedman and Jones, "Fully Automatic ID Mattes with Support for
//! Motion Blur and Transparency" (SIGGRAPH 2015 poster) as fixed by the
//! Cryptomatte Specification 1.1.0 (github.com/Psyop/Cryptomatte,
//! `specification/`): names are hashed with MurmurHash3_x86_32 (seed 0), the
//! hash becomes a float id by `uint32_to_float32` (exponent clamped to
//! [1, 254]), and each pixel stores its [`RANKS`] highest-coverage ids as
//! (id, coverage) pairs in the layers `{name}00`, `{name}01`, `{name}02`.
//! The EXR header carries `cryptomatte/<key>/{name,hash,conversion,manifest}`.

use serde_json::{Map, Value};

/// Number of (id, coverage) ranks stored per pixel: the specification's
/// suggested default of 6, i.e. three RGBA layers of two ranks each.
pub const RANKS: usize = 6;

/// Channels per Cryptomatte layer: one id and one coverage per rank.
pub const CHANNELS: usize = 2 * RANKS;

/// Distinct ids a pixel holds without allocating (edges rarely see more).
const INLINE_HITS: usize = 4;

/// MurmurHash3_x86_32 (Austin Appleby, SMHasher) of `bytes` with `seed`;
/// Cryptomatte hashes the UTF-8 bytes of a name with seed 0.
pub fn murmur3_32(bytes: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let scramble = |k: u32| k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);

    let mut h = seed;
    let mut blocks = bytes.chunks_exact(4);
    for block in &mut blocks {
        let k = u32::from_le_bytes([block[0], block[1], block[2], block[3]]);
        h ^= scramble(k);
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let k = tail
            .iter()
            .rev()
            .fold(0u32, |k, &byte| (k << 8) | u32::from(byte));
        h ^= scramble(k);
    }

    // Finalization mix (fmix32); the length is taken modulo 2^32 as in the
    // reference, which hashes `int len`.
    h ^= bytes.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^= h >> 16;
    h
}

/// The specification's `uint32_to_float32`: the hash's bits reinterpreted as
/// an `f32` with the exponent clamped to [1, 254], so every id is a finite,
/// normal float (no zero, denormal, infinity or NaN; 0.0 means "no object").
pub fn hash_to_float(hash: u32) -> f32 {
    let mantissa = hash & ((1 << 23) - 1);
    let exponent = ((hash >> 23) & 0xff).clamp(1, 254) << 23;
    let sign = hash & (1 << 31);
    f32::from_bits(sign | exponent | mantissa)
}

/// The float id of `name`: `hash_to_float(murmur3_32(name, 0))`, the
/// reference implementation's `mm3hash_float`.
pub fn name_to_id(name: &str) -> f32 {
    hash_to_float(murmur3_32(name.as_bytes(), 0))
}

/// An id as the manifest writes it: the 8 lowercase hex digits of the float's
/// bits (the reference's `id_to_hex`).
fn id_to_hex(id: f32) -> String {
    format!("{:08x}", id.to_bits())
}

/// The 7-character metadata key of a layer (e.g. "CryptoObject" -> "3ae39a5"):
/// the first 7 hex digits of its name's float id, as the reference
/// `layer_hash` computes it; stable across frames and shots, as the
/// specification asks.
pub fn layer_key(layer_name: &str) -> String {
    let mut hex = id_to_hex(name_to_id(layer_name));
    hex.truncate(7);
    hex
}

/// The channel names of Cryptomatte layer `name` in file order:
/// `{name}00.R`, `.G`, `.B`, `.A`, then `{name}01.*` and `{name}02.*`
/// ([`CHANNELS`] in all). Rank `r` sits in layer `r / 2`: its id in R (even
/// `r`) or B (odd `r`), its coverage in G or A.
pub fn channel_names(name: &str) -> Vec<String> {
    (0..RANKS / 2)
        .flat_map(|layer| ["R", "G", "B", "A"].map(|c| format!("{name}{layer:02}.{c}")))
        .collect()
}

/// One Cryptomatte type (e.g. "CryptoObject" over USD prim paths): its name
/// and the precomputed float id of every name, indexed by our object index.
#[derive(Clone, Debug)]
pub struct CryptoLayer {
    name: String,
    names: Vec<String>,
    ids: Vec<f32>,
}

impl CryptoLayer {
    /// The float id of name `index` (an index into the names given to
    /// [`CryptoLayer::new`]); panics when the index is out of range.
    pub fn id(&self, index: u32) -> f32 {
        self.ids[index as usize]
    }

    /// The layer's channel names in file order (see [`channel_names`]).
    pub fn channel_names(&self) -> Vec<String> {
        channel_names(&self.name)
    }

    /// EXR header attributes for this layer, `cryptomatte/<key>/name`,
    /// `/hash` ("MurmurHash3_32"), `/conversion` ("uint32_to_float32") and
    /// `/manifest` (a JSON object from each name to its id's 8 hex digits).
    pub fn metadata(&self) -> Vec<(String, String)> {
        let key = layer_key(&self.name);
        let manifest: Map<String, Value> = self
            .names
            .iter()
            .zip(&self.ids)
            .map(|(name, &id)| (name.clone(), Value::String(id_to_hex(id))))
            .collect();
        let manifest = Value::Object(manifest).to_string();
        [
            ("name", self.name.clone()),
            ("hash", "MurmurHash3_32".to_string()),
            ("conversion", "uint32_to_float32".to_string()),
            ("manifest", manifest),
        ]
        .into_iter()
        .map(|(field, value)| (format!("cryptomatte/{key}/{field}"), value))
        .collect()
    }

    /// A layer called `name` (the channel prefix, e.g. "CryptoObject") whose
    /// object `i` is `names[i]` (e.g. a USD prim path); hashes every name once.
    pub fn new(name: &str, names: Vec<String>) -> Self {
        let ids = names.iter().map(|n| name_to_id(n)).collect();
        Self {
            name: name.to_string(),
            names,
            ids,
        }
    }
}

/// Camera samples of one pixel that hit one object.
#[derive(Clone, Copy, Debug, Default)]
struct Hit {
    index: u32,
    count: u32,
}

impl Hit {
    /// Ranking order: more samples first, then the lower index (deterministic).
    fn ranks_before(&self, other: &Hit) -> bool {
        (self.count, std::cmp::Reverse(self.index)) > (other.count, std::cmp::Reverse(other.index))
    }
}

/// Per-pixel sample counts per object index: the ranking pixel filter's
/// accumulator for equally weighted samples (filter importance sampling), so
/// an object's coverage is its fraction of the pixel's samples. Holds up to
/// four distinct objects without allocating.
#[derive(Clone, Debug, Default)]
pub struct CryptoCoverage {
    inline: [Hit; INLINE_HITS],
    inline_len: u8,
    spill: Vec<Hit>,
}

impl CryptoCoverage {
    /// Records one camera sample that hit object `index`; samples that hit
    /// nothing are not recorded (they only count in `samples` of [`Self::ranks`]).
    pub fn add(&mut self, index: u32) {
        self.add_count(index, 1);
    }

    /// Adds another accumulator's counts for the same pixel (e.g. a later pass).
    pub fn merge(&mut self, other: &CryptoCoverage) {
        for hit in other.hits() {
            self.add_count(hit.index, hit.count);
        }
    }

    /// Writes the pixel's [`CHANNELS`] values in [`CryptoLayer::channel_names`]
    /// order: (id, coverage) for the [`RANKS`] objects with the most samples,
    /// by descending coverage (ties: lower index first), coverage = count /
    /// `samples`; unused ranks are (0, 0). Panics unless `out` has
    /// [`CHANNELS`] entries.
    pub fn ranks(&self, layer: &CryptoLayer, samples: u32, out: &mut [f32]) {
        assert_eq!(
            out.len(),
            CHANNELS,
            "a Cryptomatte pixel has {CHANNELS} channels"
        );
        let mut top = [Hit::default(); RANKS];
        let mut len = 0;
        for hit in self.hits() {
            // Insertion into the sorted top list; a full list drops its last.
            let mut slot = len;
            while slot > 0 && hit.ranks_before(&top[slot - 1]) {
                slot -= 1;
            }
            if slot < RANKS {
                len = (len + 1).min(RANKS);
                top.copy_within(slot..len - 1, slot + 1);
                top[slot] = *hit;
            }
        }
        out.fill(0.0);
        for (pair, hit) in out.chunks_exact_mut(2).zip(&top[..len]) {
            pair[0] = layer.id(hit.index);
            pair[1] = hit.count as f32 / samples as f32;
        }
    }

    /// (object index, samples) of every object recorded, in first-hit
    /// order: what a film-state file stores.
    pub(super) fn counts(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.hits().map(|h| (h.index, h.count))
    }

    /// Every recorded (index, count), in first-hit order.
    fn hits(&self) -> impl Iterator<Item = &Hit> {
        self.inline[..usize::from(self.inline_len)]
            .iter()
            .chain(&self.spill)
    }

    /// Adds `count` samples to object `index`, keeping one entry per index.
    pub(super) fn add_count(&mut self, index: u32, count: u32) {
        let inline_len = usize::from(self.inline_len);
        let existing = self.inline[..inline_len]
            .iter_mut()
            .chain(&mut self.spill)
            .find(|hit| hit.index == index);
        match existing {
            Some(hit) => hit.count += count,
            None if inline_len < INLINE_HITS => {
                self.inline[inline_len] = Hit { index, count };
                self.inline_len += 1;
            }
            None => self.spill.push(Hit { index, count }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sum of the coverage of every rank whose id equals `id`: the reference
    /// decoder's matte for one object.
    fn decode(pixel: &[f32], id: f32) -> f32 {
        pixel
            .chunks_exact(2)
            .filter(|pair| pair[0] == id)
            .map(|pair| pair[1])
            .sum()
    }

    fn layer(count: usize) -> CryptoLayer {
        let names = (0..count).map(|i| format!("/World/obj_{i}")).collect();
        CryptoLayer::new("CryptoObject", names)
    }

    #[test]
    fn murmur3_matches_reference_vectors() {
        // SMHasher / Python mmh3 vectors.
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"", 0xffff_ffff), 0x81f1_6f39);
        assert_eq!(murmur3_32(b"hello", 0), 0x248b_fa47);
        assert_eq!(
            murmur3_32(b"The quick brown fox jumps over the lazy dog", 0),
            0x2e4f_f723
        );
        // Tails of 1, 2 and 3 bytes (the specification manifest's names).
        assert_eq!(murmur3_32(b"bush", 0), 0xf763_d090);
        assert_eq!(murmur3_32(b"bunny", 0), 0x1385_1a76);
        assert_eq!(murmur3_32(b"default", 0), 0x42c9_679f);
        assert_eq!(murmur3_32(b"sphere", 0), 0x591e_9a8d);
    }

    #[test]
    fn name_ids_match_psyop_reference() {
        // cryptomatte_utilities_tests.py, CryptoHashing.mm3hash_float_values,
        // given as doubles and rounded to single precision as it does.
        let expected: [(&str, f64); 6] = [
            ("hello", 6.070_562_710_24e-17),
            ("cube", -4.084_619_125_19e15),
            ("sphere", 2.790_186_043_83e15),
            ("plane", 3.665_576_175_93e-11),
            ("равнина", -1.319_263_121_24e-25),
            ("mädchen", 6.236_129_821_16e25),
        ];
        for (name, id) in expected {
            assert_eq!(name_to_id(name), id as f32, "{name}");
        }
    }

    #[test]
    fn hash_to_float_is_always_finite_and_normal() {
        let edges = [
            (0x0000_0000, 0x0080_0000),
            (0x0000_0001, 0x0080_0001),
            (0x8000_0000, 0x8080_0000),
            (0x7f80_0000, 0x7f00_0000),
            (0x7fff_ffff, 0x7f7f_ffff),
            (0xffff_ffff, 0xff7f_ffff),
            (0x3f80_0000, 0x3f80_0000),
        ];
        for (hash, bits) in edges {
            let id = hash_to_float(hash);
            assert_eq!(id.to_bits(), bits, "{hash:#010x}");
            assert!(id.is_normal(), "{hash:#010x} -> {id}");
        }
        let mut rng = crate::sampling::Pcg32::new(7, 0);
        for _ in 0..100_000 {
            let hash = rng.next_u32();
            let id = hash_to_float(hash);
            assert!(id.is_normal(), "{hash:#010x} -> {id}");
            // Only the exponent may change.
            assert_eq!(id.to_bits() & 0x807f_ffff, hash & 0x807f_ffff);
        }
    }

    #[test]
    fn manifest_is_json_mapping_names_to_ids() {
        let names = vec![
            "bunny".to_string(),
            "default".to_string(),
            "/World/quote\"back\\slash/ünï".to_string(),
        ];
        let layer = CryptoLayer::new("CryptoObject", names.clone());
        let metadata = layer.metadata();
        let value = |field: &str| {
            let key = format!("cryptomatte/3ae39a5/{field}");
            let found = metadata.iter().find(|(k, _)| *k == key);
            found.unwrap_or_else(|| panic!("{key} missing")).1.clone()
        };
        assert_eq!(layer_key("CryptoObject"), "3ae39a5");
        assert_eq!(metadata.len(), 4);
        assert_eq!(value("name"), "CryptoObject");
        assert_eq!(value("hash"), "MurmurHash3_32");
        assert_eq!(value("conversion"), "uint32_to_float32");

        let manifest: Map<String, Value> = serde_json::from_str(&value("manifest")).unwrap();
        assert_eq!(manifest.len(), names.len());
        assert_eq!(manifest["bunny"], "13851a76");
        assert_eq!(manifest["default"], "42c9679f");
        for (index, name) in names.iter().enumerate() {
            let hex = manifest[name.as_str()].as_str().unwrap();
            let id = f32::from_bits(u32::from_str_radix(hex, 16).unwrap());
            assert_eq!(id, layer.id(index as u32), "{name}");
        }
    }

    #[test]
    fn channel_names_follow_spec() {
        let expected = [
            "CryptoObject00.R",
            "CryptoObject00.G",
            "CryptoObject00.B",
            "CryptoObject00.A",
            "CryptoObject01.R",
            "CryptoObject01.G",
            "CryptoObject01.B",
            "CryptoObject01.A",
            "CryptoObject02.R",
            "CryptoObject02.G",
            "CryptoObject02.B",
            "CryptoObject02.A",
        ];
        assert_eq!(layer(1).channel_names(), expected);
    }

    #[test]
    fn ranks_sort_by_coverage() {
        let layer = layer(3);
        let mut pixel = CryptoCoverage::default();
        for (index, count) in [(2, 3), (0, 5), (1, 2)] {
            (0..count).for_each(|_| pixel.add(index));
        }
        let mut out = [f32::NAN; CHANNELS];
        pixel.ranks(&layer, 10, &mut out);
        let expected = [
            layer.id(0),
            0.5,
            layer.id(2),
            0.3,
            layer.id(1),
            0.2,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        assert_eq!(out, expected);
        let total: f32 = out.chunks_exact(2).map(|pair| pair[1]).sum();
        assert!((total - 1.0).abs() < 1e-6, "{total}");
    }

    #[test]
    fn decoder_recovers_coverage_and_keeps_largest_six() {
        // Ten objects hit 49 times in shuffled first-hit order, plus one
        // sample that misses; objects 7 and 4 tie for sixth place with 4
        // samples each, and the lower index wins.
        let layer = layer(10);
        let counts = [
            (7, 4),
            (3, 1),
            (9, 8),
            (0, 6),
            (5, 2),
            (1, 9),
            (8, 3),
            (2, 7),
            (6, 5),
            (4, 4),
        ];
        let samples = 50;
        let mut pixel = CryptoCoverage::default();
        let mut other = CryptoCoverage::default();
        for (n, &(index, count)) in counts.iter().enumerate() {
            // Split the samples over two accumulators to exercise merge.
            for s in 0..count {
                if (n + s) % 2 == 0 {
                    pixel.add(index);
                } else {
                    other.add(index);
                }
            }
        }
        pixel.merge(&other);
        let mut out = [0.0; CHANNELS];
        pixel.ranks(&layer, samples, &mut out);

        let kept = [1, 9, 2, 0, 6, 4];
        for (index, count) in counts {
            let coverage = decode(&out, layer.id(index));
            let expected = if kept.contains(&index) {
                count as f32 / samples as f32
            } else {
                0.0
            };
            assert_eq!(coverage, expected, "object {index}");
        }
        let ranked: Vec<f32> = out.chunks_exact(2).map(|pair| pair[0]).collect();
        let expected: Vec<f32> = kept.iter().map(|&i| layer.id(i)).collect();
        assert_eq!(ranked, expected);
    }
}
