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

use std::collections::{BTreeMap, BTreeSet};

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
    let mut hasher = Murmur3::new(seed);
    hasher.write(bytes);
    hasher.finish()
}

/// MurmurHash3_x86_32 fed in pieces: the hash of the pieces' concatenation,
/// so a name spelled from parts (an instancer's path, `[12]`, a path below
/// its prototype) is hashed without being assembled in memory.
#[derive(Clone, Copy, Debug)]
pub struct Murmur3 {
    h: u32,
    /// Bytes of an unfinished 4-byte block, little-endian from bit 0.
    pending: u32,
    pending_len: u32,
    len: u32,
}

impl Murmur3 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;

    /// A hasher with `seed` (0 for Cryptomatte) that has seen no bytes.
    pub fn new(seed: u32) -> Self {
        Self {
            h: seed,
            pending: 0,
            pending_len: 0,
            len: 0,
        }
    }

    fn scramble(k: u32) -> u32 {
        k.wrapping_mul(Self::C1)
            .rotate_left(15)
            .wrapping_mul(Self::C2)
    }

    /// Appends `bytes` to what is hashed.
    pub fn write(&mut self, bytes: &[u8]) {
        // The length is taken modulo 2^32 as in the reference (`int len`).
        self.len = self.len.wrapping_add(bytes.len() as u32);
        let mut rest = bytes;
        while self.pending_len != 0 && !rest.is_empty() {
            self.pending |= u32::from(rest[0]) << (8 * self.pending_len);
            self.pending_len += 1;
            rest = &rest[1..];
            if self.pending_len == 4 {
                self.block(self.pending);
                (self.pending, self.pending_len) = (0, 0);
            }
        }
        let mut blocks = rest.chunks_exact(4);
        for b in &mut blocks {
            self.block(u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        }
        for (i, &byte) in blocks.remainder().iter().enumerate() {
            self.pending |= u32::from(byte) << (8 * i);
            self.pending_len += 1;
        }
    }

    fn block(&mut self, k: u32) {
        self.h ^= Self::scramble(k);
        self.h = self
            .h
            .rotate_left(13)
            .wrapping_mul(5)
            .wrapping_add(0xe654_6b64);
    }

    /// The hash of every byte written (the tail mixed, then fmix32).
    pub fn finish(self) -> u32 {
        let mut h = self.h;
        if self.pending_len != 0 {
            h ^= Self::scramble(self.pending);
        }
        h ^= self.len;
        h ^= h >> 16;
        h = h.wrapping_mul(0x85eb_ca6b);
        h ^= h >> 13;
        h = h.wrapping_mul(0xc2b2_ae35);
        h ^= h >> 16;
        h
    }
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

/// Names of Cryptomatte ids: each name's MurmurHash3 (the id before
/// `uint32_to_float32`) to the name.
pub type CryptoNames = BTreeMap<u32, String>;

/// One Cryptomatte type (e.g. "CryptoObject" over USD prim paths) as an EXR
/// writes it: its name and the names of its ids.
#[derive(Clone, Debug)]
pub struct CryptoLayer {
    name: String,
    names: CryptoNames,
}

impl CryptoLayer {
    /// A layer called `name` (the channel prefix, e.g. "CryptoObject")
    /// whose ids are named by `names`.
    pub fn new(name: &str, names: CryptoNames) -> Self {
        Self {
            name: name.to_string(),
            names,
        }
    }

    /// The layer with only the names of the ids that occur in `pixels` (the
    /// layer's values, [`CHANNELS`] per pixel): the manifest lists what the
    /// image holds, not every object of the scene.
    pub fn present_in(mut self, pixels: &[f32]) -> Self {
        let present: BTreeSet<u32> = pixels
            .chunks_exact(2)
            .filter(|pair| pair[1] > 0.0)
            .map(|pair| pair[0].to_bits())
            .collect();
        self.names
            .retain(|&hash, _| present.contains(&hash_to_float(hash).to_bits()));
        self
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
            .map(|(&hash, name)| (name.clone(), Value::String(id_to_hex(hash_to_float(hash)))))
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
}

/// Camera samples of one pixel that hit one object.
#[derive(Clone, Copy, Debug, Default)]
struct Hit {
    /// The object's id: the MurmurHash3 of its name.
    id: u32,
    count: u32,
}

impl Hit {
    /// Ranking order: more samples first, then the lower id (deterministic).
    fn ranks_before(&self, other: &Hit) -> bool {
        (self.count, std::cmp::Reverse(self.id)) > (other.count, std::cmp::Reverse(other.id))
    }
}

/// Per-pixel sample counts per object id: the ranking pixel filter's
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
    /// Records one camera sample that hit the object of id `id` (the
    /// MurmurHash3 of its name); samples that hit nothing are not recorded
    /// (they only count in `samples` of [`Self::ranks`]).
    pub fn add(&mut self, id: u32) {
        self.add_count(id, 1);
    }

    /// Adds another accumulator's counts for the same pixel (e.g. a later pass).
    pub fn merge(&mut self, other: &CryptoCoverage) {
        for hit in other.hits() {
            self.add_count(hit.id, hit.count);
        }
    }

    /// Writes the pixel's [`CHANNELS`] values in [`channel_names`] order:
    /// (float id, coverage) for the [`RANKS`] objects with the most samples,
    /// by descending coverage (ties: lower id first), coverage = count /
    /// `samples`; unused ranks are (0, 0). Panics unless `out` has
    /// [`CHANNELS`] entries.
    pub fn ranks(&self, samples: u32, out: &mut [f32]) {
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
            pair[0] = hash_to_float(hit.id);
            pair[1] = hit.count as f32 / samples as f32;
        }
    }

    /// (object id, samples) of every object recorded, in first-hit
    /// order: what a film-state file stores.
    pub(super) fn counts(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.hits().map(|h| (h.id, h.count))
    }

    /// Every recorded (id, count), in first-hit order.
    fn hits(&self) -> impl Iterator<Item = &Hit> {
        self.inline[..usize::from(self.inline_len)]
            .iter()
            .chain(&self.spill)
    }

    /// Adds `count` samples to object `id`, keeping one entry per id.
    pub(super) fn add_count(&mut self, id: u32, count: u32) {
        let inline_len = usize::from(self.inline_len);
        let existing = self.inline[..inline_len]
            .iter_mut()
            .chain(&mut self.spill)
            .find(|hit| hit.id == id);
        match existing {
            Some(hit) => hit.count += count,
            None if inline_len < INLINE_HITS => {
                self.inline[inline_len] = Hit { id, count };
                self.inline_len += 1;
            }
            None => self.spill.push(Hit { id, count }),
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

    /// The float id the film writes for object id `id`.
    fn id(id: u32) -> f32 {
        hash_to_float(id)
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
    fn murmur3_in_pieces_equals_murmur3_of_the_whole() {
        let name = b"/World/scatter[12]/Geom/with a longer tail";
        for cuts in [[0, 0], [1, 2], [3, 7], [5, 5], [4, 8], [17, 40]] {
            let mut hasher = Murmur3::new(0);
            hasher.write(&name[..cuts[0]]);
            hasher.write(&name[cuts[0]..cuts[1]]);
            hasher.write(&name[cuts[1]..]);
            assert_eq!(hasher.finish(), murmur3_32(name, 0), "{cuts:?}");
        }
    }

    #[test]
    fn manifest_is_json_mapping_present_names_to_ids() {
        let names = [
            "bunny".to_string(),
            "default".to_string(),
            "/World/quote\"back\\slash/ünï".to_string(),
            "absent".to_string(),
        ];
        let hashes: Vec<u32> = names.iter().map(|n| murmur3_32(n.as_bytes(), 0)).collect();
        let table: CryptoNames = hashes.iter().copied().zip(names.clone()).collect();
        // Two pixels: the first three names present, "absent" nowhere (a
        // zero-coverage rank does not count).
        let mut pixels = [0.0; 2 * CHANNELS];
        pixels[..6].copy_from_slice(&[id(hashes[0]), 0.5, id(hashes[1]), 0.5, id(hashes[3]), 0.0]);
        pixels[CHANNELS..CHANNELS + 2].copy_from_slice(&[id(hashes[2]), 1.0]);
        let layer = CryptoLayer::new("CryptoObject", table).present_in(&pixels);
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
        assert_eq!(manifest.len(), 3);
        assert_eq!(manifest["bunny"], "13851a76");
        assert_eq!(manifest["default"], "42c9679f");
        assert!(!manifest.contains_key("absent"));
        for (name, &hash) in names.iter().zip(&hashes).take(3) {
            let hex = manifest[name.as_str()].as_str().unwrap();
            let float = f32::from_bits(u32::from_str_radix(hex, 16).unwrap());
            assert_eq!(float, name_to_id(name), "{name}");
            assert_eq!(float, id(hash), "{name}");
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
        assert_eq!(channel_names("CryptoObject"), expected);
    }

    #[test]
    fn ranks_sort_by_coverage() {
        let mut pixel = CryptoCoverage::default();
        for (index, count) in [(2, 3), (0, 5), (1, 2)] {
            (0..count).for_each(|_| pixel.add(index));
        }
        let mut out = [f32::NAN; CHANNELS];
        pixel.ranks(10, &mut out);
        let expected = [
            id(0),
            0.5,
            id(2),
            0.3,
            id(1),
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
        // samples each, and the lower id wins.
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
        pixel.ranks(samples, &mut out);

        let kept = [1, 9, 2, 0, 6, 4];
        for (index, count) in counts {
            let coverage = decode(&out, id(index));
            let expected = if kept.contains(&index) {
                count as f32 / samples as f32
            } else {
                0.0
            };
            assert_eq!(coverage, expected, "object {index}");
        }
        let ranked: Vec<f32> = out.chunks_exact(2).map(|pair| pair[0]).collect();
        let expected: Vec<f32> = kept.iter().map(|&i| id(i)).collect();
        assert_eq!(ranked, expected);
    }
}
