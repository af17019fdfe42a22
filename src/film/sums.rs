//! The film: per-pixel sums of radiance samples and of the chosen AOVs,
//! filled tile by tile and merged in a fixed order, so the image does not
//! depend on the thread count.

use glam::{UVec2, Vec3};

use std::collections::BTreeSet;

use super::adaptive::{ActivePixels, HalfSum, Halves};
use super::aov::{Aov, AovSample, AovSet, CRYPTOMATTES};
use super::cryptomatte::{CryptoCoverage, CHANNELS};
use crate::image::{Channel, PixelType};

/// One pixel's running sums of finite radiance samples, W/(m^2 sr).
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelSum {
    /// Sum of the samples' RGB, in double precision so thousands of samples
    /// add without rounding drift.
    pub rgb: [f64; 3],
    /// Sum of the squares of the samples' RGB (for the variance AOV).
    pub rgb_squared: [f64; 3],
    /// Finite samples summed (non-finite ones are dropped and counted apart).
    pub count: u32,
    /// Samples whose camera ray hit a surface or collided in a volume.
    pub opaque: u32,
}

impl PixelSum {
    fn add(&mut self, other: &PixelSum) {
        for c in 0..3 {
            self.rgb[c] += other.rgb[c];
            self.rgb_squared[c] += other.rgb_squared[c];
        }
        self.count += other.count;
        self.opaque += other.opaque;
    }
}

/// The chosen AOVs' accumulators over a region's pixels: f32 sums of the
/// averaged AOVs (light paths, albedo, N, P; `stride` per pixel, in set
/// order), the minimum depth, and Cryptomatte coverage. Unchosen AOVs cost
/// nothing.
#[derive(Clone, Debug)]
pub(super) struct AovBuffers {
    /// (AOV, offset of its 3 floats within a pixel's `sums`, its slot in
    /// [`AovSample::primvars`] for a primvar).
    summed: Vec<(Aov, usize, Option<usize>)>,
    stride: usize,
    /// `stride` floats per pixel.
    pub(super) sums: Vec<f32>,
    /// Minimum camera-space depth per pixel, when `Z` is chosen.
    pub(super) depth: Option<Vec<f32>>,
    /// Coverage per pixel for each of [`CRYPTOMATTES`], when chosen.
    pub(super) crypto: [Option<Vec<CryptoCoverage>>; 3],
}

impl AovBuffers {
    fn new(set: &AovSet, pixels: usize) -> Self {
        let summed: Vec<(Aov, usize, Option<usize>)> = set
            .aovs()
            .iter()
            .map(|a| (*a, set.primvar_slot(*a)))
            .filter(|(a, slot)| summed_value(*a, *slot, &AovSample::default()).is_some())
            .enumerate()
            .map(|(i, (a, slot))| (a, 3 * i, slot))
            .collect();
        let stride = 3 * summed.len();
        let crypto = |aov| {
            set.contains(aov)
                .then(|| vec![CryptoCoverage::default(); pixels])
        };
        Self {
            summed,
            stride,
            sums: vec![0.0; stride * pixels],
            depth: set.contains(Aov::Z).then(|| vec![f32::INFINITY; pixels]),
            crypto: CRYPTOMATTES.map(crypto),
        }
    }

    fn add(&mut self, i: usize, sample: &AovSample) {
        let sums = &mut self.sums[i * self.stride..(i + 1) * self.stride];
        for (aov, offset, slot) in &self.summed {
            if let Some(v) = summed_value(*aov, *slot, sample) {
                for (s, x) in sums[*offset..*offset + 3].iter_mut().zip(v.to_array()) {
                    *s += x;
                }
            }
        }
        let Some(hit) = sample.hit else {
            return;
        };
        if let Some(depth) = &mut self.depth {
            depth[i] = depth[i].min(hit.depth);
        }
        for (coverage, aov) in self.crypto.iter_mut().zip(CRYPTOMATTES) {
            if let (Some(coverage), Some(id)) = (coverage, hit.ids.of(aov)) {
                coverage[i].add(id);
            }
        }
    }

    /// Replaces this one's pixel `to` by `other`'s pixel `from`.
    fn copy(&mut self, to: usize, other: &AovBuffers, from: usize) {
        let n = self.stride;
        self.sums[to * n..(to + 1) * n].copy_from_slice(&other.sums[from * n..(from + 1) * n]);
        if let (Some(d), Some(s)) = (&mut self.depth, &other.depth) {
            d[to] = s[from];
        }
        for (d, s) in self.crypto.iter_mut().zip(&other.crypto) {
            if let (Some(d), Some(s)) = (d, s) {
                d[to] = s[from].clone();
            }
        }
    }

    /// Adds `other`'s pixel `from` into this one's pixel `to`.
    fn merge(&mut self, to: usize, other: &AovBuffers, from: usize) {
        let n = self.stride;
        for (d, s) in self.sums[to * n..(to + 1) * n]
            .iter_mut()
            .zip(&other.sums[from * n..(from + 1) * n])
        {
            *d += s;
        }
        if let (Some(d), Some(s)) = (&mut self.depth, &other.depth) {
            d[to] = d[to].min(s[from]);
        }
        for (d, s) in self.crypto.iter_mut().zip(&other.crypto) {
            if let (Some(d), Some(s)) = (d, s) {
                d[to].merge(&s[from]);
            }
        }
    }
}

/// The per-sample value an averaged AOV sums (a primvar's from its `slot`
/// in [`AovSample::primvars`]); `None` for the AOVs that are not sums of
/// samples (depth, counts, variance, Cryptomatte) and for a primvar beyond
/// the slots.
fn summed_value(aov: Aov, slot: Option<usize>, sample: &AovSample) -> Option<Vec3> {
    let hit =
        |f: fn(&super::aov::CameraHit) -> Vec3| Some(sample.hit.as_ref().map_or(Vec3::ZERO, f));
    match aov {
        Aov::Emission => Some(sample.light_paths[0]),
        Aov::DiffuseDirect => Some(sample.light_paths[1]),
        Aov::DiffuseIndirect => Some(sample.light_paths[2]),
        Aov::SpecularDirect => Some(sample.light_paths[3]),
        Aov::SpecularIndirect => Some(sample.light_paths[4]),
        Aov::Transmission => Some(sample.light_paths[5]),
        Aov::VolumeDirect => Some(sample.light_paths[6]),
        Aov::VolumeIndirect => Some(sample.light_paths[7]),
        Aov::Albedo => Some(sample.albedo),
        Aov::N => hit(|h| h.normal),
        Aov::P => hit(|h| h.position),
        Aov::Z
        | Aov::SampleCount
        | Aov::Variance
        | Aov::CryptoObject
        | Aov::CryptoMaterial
        | Aov::CryptoAsset => None,
        Aov::Primvar { .. } => slot.map(|s| sample.primvars[s]),
    }
}

/// One image layer ready for an EXR: its channels and their values,
/// interleaved channel-fastest, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Layer {
    /// Channel names and storage.
    pub channels: Vec<Channel>,
    /// `channels.len()` values per pixel.
    pub pixels: Vec<f32>,
}

/// Samples that were NaN or infinite: dropped from the image, counted, and
/// reported with the first one (lowest sample index, then pixel in row-major
/// order, so the report is the same whatever the thread count).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NonFiniteSamples {
    /// How many were dropped.
    pub count: u64,
    /// (pixel, sample index) of the first.
    pub first: Option<(UVec2, u32)>,
}

impl NonFiniteSamples {
    /// Records one dropped sample.
    pub fn record(&mut self, pixel: UVec2, sample: u32) {
        self.count += 1;
        let key = |(p, s): (UVec2, u32)| (s, p.y, p.x);
        if self.first.is_none_or(|f| key((pixel, sample)) < key(f)) {
            self.first = Some((pixel, sample));
        }
    }

    /// Adds another tile's counts.
    pub fn merge(&mut self, other: &NonFiniteSamples) {
        if let Some((pixel, sample)) = other.first {
            self.record(pixel, sample);
            self.count += other.count - 1;
        }
    }
}

/// A rectangle of the image: where a tile's pixels go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Top-left pixel.
    pub origin: UVec2,
    /// Width and height in pixels.
    pub size: UVec2,
}

/// A tile's pixel sums, row-major within the tile.
#[derive(Clone, Debug)]
pub struct TileFilm {
    /// Where the tile is.
    pub tile: Tile,
    /// Its pixels' sums.
    pub pixels: Vec<PixelSum>,
    /// Its dropped samples.
    pub non_finite: NonFiniteSamples,
    aovs: AovBuffers,
    /// Sums of the odd-indexed samples, for adaptive sampling.
    halves: Option<Vec<HalfSum>>,
}

impl TileFilm {
    /// An empty film for `tile`, accumulating the AOVs in `set`.
    pub fn new(tile: Tile, set: &AovSet) -> Self {
        let pixels = (tile.size.x * tile.size.y) as usize;
        Self {
            tile,
            pixels: vec![PixelSum::default(); pixels],
            non_finite: NonFiniteSamples::default(),
            aovs: AovBuffers::new(set, pixels),
            halves: None,
        }
    }

    /// Adds one sample to `pixel` (image coordinates, inside the tile): its
    /// radiance and its AOV values. A NaN or infinite radiance drops the
    /// whole sample (AOVs included, so they still sum to the beauty) and is
    /// counted instead.
    pub fn add(&mut self, pixel: UVec2, sample: u32, radiance: Vec3, aovs: &AovSample) {
        if !radiance.is_finite() {
            self.non_finite.record(pixel, sample);
            return;
        }
        let local = pixel - self.tile.origin;
        let i = (local.y * self.tile.size.x + local.x) as usize;
        let sum = &mut self.pixels[i];
        for c in 0..3 {
            let v = f64::from(radiance[c]);
            sum.rgb[c] += v;
            sum.rgb_squared[c] += v * v;
        }
        sum.count += 1;
        sum.opaque += u32::from(aovs.opaque);
        self.aovs.add(i, aovs);
        if let Some(half) = self.halves.as_mut().filter(|_| sample % 2 == 1) {
            half[i].add(&HalfSum {
                rgb: radiance.to_array().map(f64::from),
                count: 1,
            });
        }
    }
}

/// The sums of a window of the image (all of it unless the render was
/// cropped), row-major within the window.
#[derive(Clone, Debug)]
pub struct Film {
    /// The whole image's size in pixels.
    pub resolution: UVec2,
    /// The pixels this film holds.
    pub window: Tile,
    /// Row-major pixel sums.
    pub(super) pixels: Vec<PixelSum>,
    /// Every dropped sample so far.
    pub non_finite: NonFiniteSamples,
    set: AovSet,
    /// The chosen AOVs' accumulators.
    pub(super) aovs: AovBuffers,
    /// Adaptive sampling's half buffer and active pixels, when on.
    pub(super) halves: Option<Halves>,
}

impl Film {
    /// An empty film of the whole image, accumulating the AOVs in `set`.
    pub fn new(resolution: UVec2, set: AovSet) -> Self {
        let whole = Tile {
            origin: UVec2::ZERO,
            size: resolution,
        };
        Self::cropped(resolution, whole, set)
    }

    /// An empty film of `window` (inside an image of `resolution`).
    pub fn cropped(resolution: UVec2, window: Tile, set: AovSet) -> Self {
        let pixels = window.size.x as usize * window.size.y as usize;
        Self {
            resolution,
            window,
            pixels: vec![PixelSum::default(); pixels],
            non_finite: NonFiniteSamples::default(),
            aovs: AovBuffers::new(&set, pixels),
            set,
            halves: None,
        }
    }

    /// Keeps the half buffer adaptive sampling decides from (see
    /// `adaptive.rs`), with every pixel active; call on an empty film. A
    /// film that keeps it already is left as it is.
    pub fn keep_halves(&mut self) {
        if self.halves.is_none() {
            self.halves = Some(Halves::new(self.pixels.len()));
        }
    }

    /// Whether the film keeps the half buffer (an adaptive render's).
    pub fn keeps_halves(&self) -> bool {
        self.halves.is_some()
    }

    /// At a pass boundary of an adaptive render: decides which pixels take
    /// the next pass's samples (`adaptive.rs`), every pixel's error under
    /// `threshold` against the sums so far.
    pub fn decide_active(&mut self, threshold: f32) {
        if let Some(halves) = &mut self.halves {
            let full = self.pixels.iter().map(|p| (p.rgb, p.count));
            halves.decide(full, self.window.size.x as usize, threshold);
        }
    }

    /// The pixels that take the current pass's samples; `None` when the
    /// film does not adapt (every pixel does).
    pub fn active_pixels(&self) -> Option<ActivePixels> {
        let halves = self.halves.as_ref()?;
        let (origin, width) = (self.window.origin, self.window.size.x);
        Some(ActivePixels::new(origin, width, halves.active.clone()))
    }

    /// An empty film of `tile` (inside the window) that sums what this one
    /// does, ready to [`merge`](Self::merge) into it.
    pub fn tile_film(&self, tile: Tile) -> TileFilm {
        let mut film = TileFilm::new(tile, &self.set);
        if self.halves.is_some() {
            film.halves = Some(vec![HalfSum::default(); film.pixels.len()]);
        }
        film
    }

    /// Bytes the sums of a film of `pixels` pixels accumulating `set` hold
    /// (each Cryptomatte coverage's list of ids beyond its inline ranks aside).
    pub fn bytes_for(pixels: u64, set: &AovSet) -> u64 {
        let buffers = AovBuffers::new(set, 0);
        let crypto = buffers.crypto.iter().flatten().count();
        let per_pixel = std::mem::size_of::<PixelSum>()
            + 4 * buffers.stride
            + 4 * usize::from(buffers.depth.is_some())
            + crypto * std::mem::size_of::<CryptoCoverage>();
        pixels * per_pixel as u64
    }

    /// Bytes held by the sums (see [`Self::bytes_for`]).
    pub fn memory_bytes(&self) -> u64 {
        let a = &self.aovs;
        let crypto: usize = a.crypto.iter().flatten().map(Vec::capacity).sum();
        (self.pixels.capacity() * std::mem::size_of::<PixelSum>()
            + 4 * a.sums.capacity()
            + 4 * a.depth.as_ref().map_or(0, Vec::capacity)
            + crypto * std::mem::size_of::<CryptoCoverage>()
            + self.halves.as_ref().map_or(0, |h| {
                h.sums.capacity() * std::mem::size_of::<HalfSum>() + h.active.capacity()
            })) as u64
    }

    /// The AOVs this film accumulates.
    pub fn aov_set(&self) -> &AovSet {
        &self.set
    }

    /// The tiles of `size` pixels (smaller at the right and bottom edges)
    /// covering the window, row-major.
    pub fn tiles(&self, size: u32) -> Vec<Tile> {
        let (start, end) = (self.window.origin, self.window.origin + self.window.size);
        let mut tiles = Vec::new();
        for y in (start.y..end.y).step_by(size as usize) {
            for x in (start.x..end.x).step_by(size as usize) {
                let origin = UVec2::new(x, y);
                tiles.push(Tile {
                    origin,
                    size: (end - origin).min(UVec2::splat(size)),
                });
            }
        }
        tiles
    }

    /// Index in `pixels` of image pixel `p` (inside the window).
    fn index(&self, p: UVec2) -> usize {
        let local = p - self.window.origin;
        local.y as usize * self.window.size.x as usize + local.x as usize
    }

    /// Adds a tile's sums into the film.
    pub fn merge(&mut self, tile: &TileFilm) {
        let t = tile.tile;
        for y in 0..t.size.y {
            for x in 0..t.size.x {
                let from = (y * t.size.x + x) as usize;
                let to = self.index(t.origin + UVec2::new(x, y));
                self.pixels[to].add(&tile.pixels[from]);
                self.aovs.merge(to, &tile.aovs, from);
                if let (Some(h), Some(t)) = (&mut self.halves, &tile.halves) {
                    h.sums[to].add(&t[from]);
                }
            }
        }
        self.non_finite.merge(&tile.non_finite);
    }

    /// Adds another film of the same image and AOVs (a part of a split
    /// render) into this one: its window's pixels add to the same pixels
    /// here. A pixel that has no sample yet takes the part's sums as they
    /// are, so a frame assembled from disjoint windows is bit-identical to
    /// one rendered whole.
    pub fn add_part(&mut self, part: &Film) {
        let w = part.window;
        for y in 0..w.size.y {
            for x in 0..w.size.x {
                let from = part.index(w.origin + UVec2::new(x, y));
                let to = self.index(w.origin + UVec2::new(x, y));
                if self.pixels[to].count == 0 {
                    self.pixels[to] = part.pixels[from];
                    self.aovs.copy(to, &part.aovs, from);
                } else {
                    self.pixels[to].add(&part.pixels[from]);
                    self.aovs.merge(to, &part.aovs, from);
                }
            }
        }
        self.non_finite.merge(&part.non_finite);
    }

    /// Mean radiance per pixel, RGB interleaved, row-major from the top row:
    /// the beauty image, W/(m^2 sr). A pixel with no finite sample is black.
    pub fn rgb(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| {
                let n = f64::from(p.count.max(1));
                p.rgb.map(|v| (v / n) as f32)
            })
            .collect()
    }

    /// The beauty as an EXR layer: `R,G,B` and alpha `A` (the fraction of
    /// samples whose camera ray hit something), float.
    pub fn beauty_layer(&self) -> Layer {
        let pixels = self
            .pixels
            .iter()
            .flat_map(|p| {
                let n = f64::from(p.count.max(1));
                let [r, g, b] = p.rgb.map(|v| (v / n) as f32);
                [r, g, b, (f64::from(p.opaque) / n) as f32]
            })
            .collect();
        Layer {
            channels: channels(&["R", "G", "B", "A"], PixelType::Float),
            pixels,
        }
    }

    /// Every id Cryptomatte `aov` recorded (its ranks beyond the sixth
    /// included): the ids whose names a film-state file carries.
    pub fn crypto_ids(&self, aov: Aov) -> BTreeSet<u32> {
        let slot = CRYPTOMATTES.iter().position(|&a| a == aov);
        let coverage = slot.and_then(|s| self.aovs.crypto[s].as_ref());
        coverage
            .into_iter()
            .flatten()
            .flat_map(|c| c.counts().map(|(id, _)| id))
            .collect()
    }

    /// The layer of `aov` (which must be in the film's set).
    pub fn aov_layer(&self, aov: Aov) -> Layer {
        let channels: Vec<Channel> = aov
            .channels()
            .iter()
            .map(|n| Channel {
                name: n.clone(),
                pixel_type: aov.pixel_type(),
            })
            .collect();
        let width = channels.len();
        let mut pixels = vec![0.0f32; width * self.pixels.len()];
        let summed = self.aovs.summed.iter().find(|(a, ..)| *a == aov);
        let slot = CRYPTOMATTES.iter().position(|&a| a == aov);
        let coverage = slot.and_then(|s| self.aovs.crypto[s].as_ref());
        for (i, (p, out)) in self.pixels.iter().zip(pixels.chunks_mut(width)).enumerate() {
            let n = f64::from(p.count.max(1));
            match aov {
                Aov::SampleCount => out[0] = p.count as f32,
                Aov::Variance => {
                    // Sample variance (n - 1 in the denominator) over n.
                    for (c, v) in out.iter_mut().enumerate() {
                        let mean = p.rgb[c] / n;
                        let second_moment = (p.rgb_squared[c] / n - mean * mean).max(0.0);
                        *v = (second_moment / (n - 1.0).max(1.0)) as f32;
                    }
                }
                Aov::Z => out[0] = self.aovs.depth.as_ref().map_or(f32::INFINITY, |d| d[i]),
                Aov::CryptoObject | Aov::CryptoMaterial | Aov::CryptoAsset => {
                    if let Some(coverage) = coverage {
                        debug_assert_eq!(width, CHANNELS);
                        coverage[i].ranks(p.count, out);
                    }
                }
                _ => {
                    if let Some((_, offset, _)) = summed {
                        let sums = &self.aovs.sums[i * self.aovs.stride + offset..][..3];
                        for (v, s) in out.iter_mut().zip(sums) {
                            *v = s / n as f32;
                        }
                    }
                }
            }
        }
        Layer { channels, pixels }
    }
}

/// Channels of one storage type.
fn channels(names: &[&str], pixel_type: PixelType) -> Vec<Channel> {
    names
        .iter()
        .map(|n| Channel {
            name: (*n).to_string(),
            pixel_type,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_memory_estimate_is_what_a_film_holds() {
        let size = UVec2::new(13, 7);
        for aovs in ["beauty", "default", "all", "Z,CryptoObject", "albedo,N,P"] {
            let set: AovSet = aovs.parse().unwrap();
            let film = Film::new(size, set.clone());
            assert_eq!(Film::bytes_for(91, &set), film.memory_bytes(), "{aovs}");
        }
    }

    #[test]
    fn tiles_cover_the_image_once_and_merge_back() {
        let set = AovSet::default();
        let mut film = Film::new(UVec2::new(37, 21), set.clone());
        let tiles = film.tiles(16);
        assert_eq!(tiles.len(), 3 * 2);
        let none = AovSample::default();
        for tile in &tiles {
            let mut t = TileFilm::new(*tile, &set);
            for y in 0..tile.size.y {
                for x in 0..tile.size.x {
                    let p = tile.origin + UVec2::new(x, y);
                    t.add(p, 0, Vec3::splat((p.y * 37 + p.x) as f32), &none);
                    t.add(p, 1, Vec3::splat(f32::NAN), &none);
                }
            }
            film.merge(&t);
        }
        let rgb = film.rgb();
        for (i, v) in rgb.chunks(3).enumerate() {
            assert_eq!(v[0], i as f32, "pixel {i} covered once");
        }
        assert_eq!(film.non_finite.count, 37 * 21);
        assert_eq!(film.non_finite.first, Some((UVec2::ZERO, 1)));
    }
}
