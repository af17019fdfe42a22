//! The film: per-pixel sums of radiance samples, filled tile by tile and
//! merged in a fixed order, so the image does not depend on the thread count.

use glam::{UVec2, Vec3};

/// One pixel's running sum of finite radiance samples, W/(m^2 sr).
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelSum {
    /// Sum of the samples' RGB, in double precision so thousands of samples
    /// add without rounding drift.
    pub rgb: [f64; 3],
    /// Finite samples summed (non-finite ones are dropped and counted apart).
    pub count: u32,
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
}

impl TileFilm {
    /// An empty film for `tile`.
    pub fn new(tile: Tile) -> Self {
        Self {
            tile,
            pixels: vec![PixelSum::default(); (tile.size.x * tile.size.y) as usize],
            non_finite: NonFiniteSamples::default(),
        }
    }

    /// Adds one radiance sample to `pixel` (image coordinates, inside the
    /// tile); a NaN or infinite sample is dropped and counted instead.
    pub fn add(&mut self, pixel: UVec2, sample: u32, radiance: Vec3) {
        if !radiance.is_finite() {
            self.non_finite.record(pixel, sample);
            return;
        }
        let local = pixel - self.tile.origin;
        let sum = &mut self.pixels[(local.y * self.tile.size.x + local.x) as usize];
        for (s, v) in sum.rgb.iter_mut().zip(radiance.to_array()) {
            *s += f64::from(v);
        }
        sum.count += 1;
    }
}

/// The whole image's sums.
#[derive(Clone, Debug)]
pub struct Film {
    /// Image size in pixels.
    pub resolution: UVec2,
    pixels: Vec<PixelSum>,
    /// Every dropped sample so far.
    pub non_finite: NonFiniteSamples,
}

impl Film {
    /// An empty film.
    pub fn new(resolution: UVec2) -> Self {
        Self {
            resolution,
            pixels: vec![PixelSum::default(); (resolution.x * resolution.y) as usize],
            non_finite: NonFiniteSamples::default(),
        }
    }

    /// The tiles of `size` pixels (smaller at the right and bottom edges)
    /// covering the image, row-major.
    pub fn tiles(&self, size: u32) -> Vec<Tile> {
        let r = self.resolution;
        let mut tiles = Vec::new();
        for y in (0..r.y).step_by(size as usize) {
            for x in (0..r.x).step_by(size as usize) {
                let origin = UVec2::new(x, y);
                tiles.push(Tile {
                    origin,
                    size: (r - origin).min(UVec2::splat(size)),
                });
            }
        }
        tiles
    }

    /// Adds a tile's sums into the image.
    pub fn merge(&mut self, tile: &TileFilm) {
        let t = tile.tile;
        for y in 0..t.size.y {
            for x in 0..t.size.x {
                let src = &tile.pixels[(y * t.size.x + x) as usize];
                let dst = &mut self.pixels
                    [((t.origin.y + y) * self.resolution.x + t.origin.x + x) as usize];
                for (d, s) in dst.rgb.iter_mut().zip(src.rgb) {
                    *d += s;
                }
                dst.count += src.count;
            }
        }
        self.non_finite.merge(&tile.non_finite);
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_image_once_and_merge_back() {
        let mut film = Film::new(UVec2::new(37, 21));
        let tiles = film.tiles(16);
        assert_eq!(tiles.len(), 3 * 2);
        for tile in &tiles {
            let mut t = TileFilm::new(*tile);
            for y in 0..tile.size.y {
                for x in 0..tile.size.x {
                    let p = tile.origin + UVec2::new(x, y);
                    t.add(p, 0, Vec3::splat((p.y * 37 + p.x) as f32));
                    t.add(p, 1, Vec3::splat(f32::NAN));
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
