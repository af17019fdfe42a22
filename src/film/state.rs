//! Film-state files: a film's exact sums plus a caller's JSON header (the
//! settings and progress of the render that made it), so an interrupted
//! render resumes bit-identically. Written atomically, checked by CRC-32.
//!
//! Layout, version 3 (integers and floats little-endian; version 2 has the
//! same bytes and is still read, its caller's header lacking what version 3
//! added: the image's layer names, data window and pixel aspect):
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `CIRRUSFS` |
//! | 4 | format version, u32 |
//! | 8 | length of the JSON frame, u64 |
//! | .. | JSON frame: `{"resolution": [w, h], "window": [x, y, w, h], "aovs": "...", "non_finite": {...}, "header": {...}}` |
//! | 56 per pixel | `rgb` 3 x f64, `rgb_squared` 3 x f64, `count` u32, `opaque` u32, row-major over the window |
//! | 4 x stride per pixel | summed AOVs (light paths, albedo, N, P) as f32, in set order |
//! | 4 per pixel | minimum depth f32, when `Z` is chosen |
//! | .. per pixel | Cryptomatte object, material then asset coverage, when chosen: u32 n, then n x (u32 id, u32 samples), the id being the MurmurHash3 of the name |
//! | 29 per pixel | when `adaptive`: the half buffer's `rgb` 3 x f64 and `count` u32, then u8 1 if the pixel samples in the current pass |
//! | 4 | CRC-32 (IEEE) of every byte before it |

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::UVec2;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::aov::AovSet;
use super::cryptomatte::CryptoCoverage;
use super::sums::{Film, NonFiniteSamples, PixelSum, Tile};

/// The first bytes of every film-state file.
const MAGIC: &[u8; 8] = b"CIRRUSFS";
/// The layout version this build writes.
/// (Version 1 stored Cryptomatte coverage by mesh and material index;
/// version 2 by the names' MurmurHash3, and adaptive sampling's half
/// buffer when the frame says `adaptive`; version 3 is version 2 whose
/// header records how its image is written (a render product's layer
/// names, data window and pixel aspect), so a Cirrus that would write it
/// otherwise refuses it.)
pub const FILM_STATE_VERSION: u32 = 3;
/// The layout versions this build reads: 2 (its image written with the
/// film's layer names, whole and of square pixels) and 3.
const READABLE_VERSIONS: [u32; 2] = [2, FILM_STATE_VERSION];
/// Bytes of one [`PixelSum`] on disk.
const PIXEL_BYTES: usize = 56;

/// Why a film-state file cannot be read or written.
#[derive(Debug, Error)]
pub enum FilmStateError {
    /// The file system refused.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's message.
        message: String,
    },
    /// The file is not a film state, is damaged or truncated.
    #[error("{path}: not a valid Cirrus film state ({what})")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// What the JSON frame holds besides the caller's header.
#[derive(Serialize, Deserialize)]
struct Frame<H> {
    resolution: [u32; 2],
    window: [u32; 4],
    aovs: String,
    non_finite: NonFiniteRecord,
    /// The film keeps adaptive sampling's half buffer.
    #[serde(default)]
    adaptive: bool,
    header: H,
}

/// [`NonFiniteSamples`] as JSON: the count and the first (x, y, sample).
#[derive(Serialize, Deserialize)]
struct NonFiniteRecord {
    count: u64,
    first: Option<[u32; 3]>,
}

/// Writes `film` and `header` to `path` atomically (a crash leaves the old
/// file or none).
pub fn write_film_state<H: Serialize>(
    path: &Path,
    film: &Film,
    header: &H,
) -> Result<(), FilmStateError> {
    let frame = Frame {
        resolution: film.resolution.to_array(),
        window: [
            film.window.origin.x,
            film.window.origin.y,
            film.window.size.x,
            film.window.size.y,
        ],
        aovs: film.aov_set().to_string(),
        non_finite: NonFiniteRecord {
            count: film.non_finite.count,
            first: film.non_finite.first.map(|(p, s)| [p.x, p.y, s]),
        },
        adaptive: film.keeps_halves(),
        header,
    };
    let json = serde_json::to_vec(&frame).map_err(|e| FilmStateError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    crate::image::replace_file(path, |temp| {
        let mut out = CrcWriter {
            inner: BufWriter::new(std::fs::File::create(temp)?),
            crc: crc32fast::Hasher::new(),
        };
        out.write_all(MAGIC)?;
        out.write_all(&FILM_STATE_VERSION.to_le_bytes())?;
        out.write_all(&(json.len() as u64).to_le_bytes())?;
        out.write_all(&json)?;
        write_sums(&mut out, film)?;
        let crc = out.crc.clone().finalize();
        out.inner.write_all(&crc.to_le_bytes())?;
        out.inner
            .into_inner()
            .map_err(|e| e.into_error())?
            .sync_all()
    })
    .map_err(|e| FilmStateError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Reads a film-state file: the caller's header and the film.
pub fn read_film_state<H: DeserializeOwned>(path: &Path) -> Result<(H, Film), FilmStateError> {
    let bytes = std::fs::read(path).map_err(|e| FilmStateError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    decode(&bytes).map_err(|what| FilmStateError::Corrupt {
        path: path.to_path_buf(),
        what,
    })
}

/// Streams the film's sums in the layout above.
fn write_sums(out: &mut impl Write, film: &Film) -> std::io::Result<()> {
    for p in &film.pixels {
        for v in p.rgb.iter().chain(&p.rgb_squared) {
            out.write_all(&v.to_le_bytes())?;
        }
        out.write_all(&p.count.to_le_bytes())?;
        out.write_all(&p.opaque.to_le_bytes())?;
    }
    let aovs = &film.aovs;
    for v in aovs.sums.iter().chain(aovs.depth.iter().flatten()) {
        out.write_all(&v.to_le_bytes())?;
    }
    for coverage in aovs.crypto.iter().flatten().flatten() {
        let counts: Vec<(u32, u32)> = coverage.counts().collect();
        out.write_all(&(counts.len() as u32).to_le_bytes())?;
        for (index, samples) in counts {
            out.write_all(&index.to_le_bytes())?;
            out.write_all(&samples.to_le_bytes())?;
        }
    }
    if let Some(halves) = &film.halves {
        for (half, &active) in halves.sums.iter().zip(&halves.active) {
            for v in half.rgb {
                out.write_all(&v.to_le_bytes())?;
            }
            out.write_all(&half.count.to_le_bytes())?;
            out.write_all(&[u8::from(active)])?;
        }
    }
    Ok(())
}

/// Parses a whole file; the error says what is wrong.
fn decode<H: DeserializeOwned>(bytes: &[u8]) -> Result<(H, Film), String> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err("no CIRRUSFS magic".into());
    }
    let (body, trailer) = bytes.split_at(bytes.len().saturating_sub(4).max(MAGIC.len()));
    let stored = trailer
        .try_into()
        .map(u32::from_le_bytes)
        .map_err(|_| "truncated".to_string())?;
    if crc32fast::hash(body) != stored {
        return Err("checksum mismatch: the file is damaged or truncated".into());
    }
    let mut r = Reader {
        bytes: &body[MAGIC.len()..],
    };
    let version = r.u32()?;
    if !READABLE_VERSIONS.contains(&version) {
        return Err(format!(
            "version {version}; this Cirrus reads versions {READABLE_VERSIONS:?} (render again, or \
             finish it with the Cirrus that wrote it)"
        ));
    }
    let json_len = usize::try_from(r.u64()?).map_err(|_| "frame length overflows")?;
    let frame: Frame<H> =
        serde_json::from_slice(r.take(json_len)?).map_err(|e| format!("bad JSON frame: {e}"))?;
    let set: AovSet = frame.aovs.parse()?;
    let resolution = UVec2::from(frame.resolution);
    let [x, y, w, h] = frame.window;
    let window = Tile {
        origin: UVec2::new(x, y),
        size: UVec2::new(w, h),
    };
    let end = window.origin.as_u64vec2() + window.size.as_u64vec2();
    if end.x > u64::from(resolution.x) || end.y > u64::from(resolution.y) {
        return Err(format!("window {:?} outside the image", frame.window));
    }
    let pixels = w as usize * h as usize;
    if pixels == 0 || pixels.saturating_mul(PIXEL_BYTES) > r.bytes.len() {
        return Err(format!("{w}x{h} pixels do not fit in the file"));
    }
    let mut film = Film::cropped(resolution, window, set);
    for p in &mut film.pixels {
        *p = PixelSum {
            rgb: [r.f64()?, r.f64()?, r.f64()?],
            rgb_squared: [r.f64()?, r.f64()?, r.f64()?],
            count: r.u32()?,
            opaque: r.u32()?,
        };
    }
    let aovs = &mut film.aovs;
    for v in aovs.sums.iter_mut().chain(aovs.depth.iter_mut().flatten()) {
        *v = f32::from_bits(r.u32()?);
    }
    for coverage in aovs.crypto.iter_mut().flatten().flatten() {
        *coverage = CryptoCoverage::default();
        for _ in 0..r.u32()? {
            coverage.add_count(r.u32()?, r.u32()?);
        }
    }
    if frame.adaptive {
        film.keep_halves();
    }
    if let Some(halves) = &mut film.halves {
        for (half, active) in halves.sums.iter_mut().zip(&mut halves.active) {
            half.rgb = [r.f64()?, r.f64()?, r.f64()?];
            half.count = r.u32()?;
            *active = match r.take(1)? {
                [0] => false,
                [1] => true,
                other => return Err(format!("active flag {other:?} is neither 0 nor 1")),
            };
        }
    }
    if !r.bytes.is_empty() {
        return Err(format!("{} bytes left over", r.bytes.len()));
    }
    film.non_finite = NonFiniteSamples {
        count: frame.non_finite.count,
        first: frame
            .non_finite
            .first
            .map(|[x, y, s]| (UVec2::new(x, y), s)),
    };
    Ok((frame.header, film))
}

/// A little-endian cursor over the file's bytes.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.bytes.len() {
            return Err("truncated".into());
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    fn f64(&mut self) -> Result<f64, String> {
        self.u64().map(f64::from_bits)
    }
}

/// A writer that checksums what passes through it.
struct CrcWriter<W> {
    inner: W,
    crc: crc32fast::Hasher,
}

impl<W: Write> Write for CrcWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.crc.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::TileFilm;
    use crate::film::{AovSample, CameraHit, CryptoIds};
    use glam::Vec3;

    /// A small cropped film with every AOV, a few samples per pixel and one NaN.
    fn film() -> Film {
        let set: AovSet = "all".parse().unwrap();
        let window = Tile {
            origin: UVec2::new(2, 3),
            size: UVec2::new(5, 3),
        };
        let mut film = Film::cropped(UVec2::new(9, 7), window, set.clone());
        for tile in film.tiles(4) {
            let mut t = TileFilm::new(tile, &set);
            for y in tile.origin.y..tile.origin.y + tile.size.y {
                for x in tile.origin.x..tile.origin.x + tile.size.x {
                    for s in 0..3u32 {
                        let v = (x * 7 + y * 3 + s) as f32 * 0.1;
                        let sample = AovSample {
                            albedo: Vec3::splat(v),
                            hit: (s != 1).then_some(CameraHit {
                                normal: Vec3::Z,
                                position: Vec3::splat(v),
                                depth: v + 1.0,
                                ids: CryptoIds {
                                    object: x % 3,
                                    material: Some(s),
                                    asset: 0x8000_0000 | y,
                                },
                            }),
                            ..AovSample::default()
                        };
                        t.add(UVec2::new(x, y), s, Vec3::new(v, 2.0 * v, 0.3), &sample);
                    }
                }
            }
            t.add(tile.origin, 5, Vec3::NAN, &AovSample::default());
            film.merge(&t);
        }
        film
    }

    fn layers(film: &Film) -> Vec<Vec<u32>> {
        let mut all = vec![film.beauty_layer()];
        all.extend(film.aov_set().aovs().iter().map(|&a| film.aov_layer(a)));
        all.iter()
            .map(|l| l.pixels.iter().map(|v| v.to_bits()).collect())
            .collect()
    }

    #[test]
    fn a_film_round_trips_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("cirrus_film_state_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.checkpoint");
        let film = film();
        write_film_state(&path, &film, &"header").unwrap();
        let (header, back): (String, Film) = read_film_state(&path).unwrap();
        assert_eq!(header, "header");
        assert_eq!(
            (back.resolution, back.window),
            (film.resolution, film.window)
        );
        assert_eq!(back.non_finite, film.non_finite);
        assert_eq!(layers(&back), layers(&film));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn adaptive_films_round_trip_and_other_versions_are_refused() {
        let dir = std::env::temp_dir().join(format!("cirrus_film_adaptive_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.checkpoint");
        let mut adaptive =
            Film::cropped(film().resolution, film().window, film().aov_set().clone());
        adaptive.keep_halves();
        for tile in adaptive.tiles(4) {
            let mut t = adaptive.tile_film(tile);
            for s in 0..4u32 {
                let v = Vec3::new(s as f32, 1.0, 2.0 * (tile.origin.x + s) as f32);
                t.add(tile.origin, s, v, &AovSample::default());
            }
            adaptive.merge(&t);
        }
        adaptive.decide_active(0.01);
        write_film_state(&path, &adaptive, &0u32).unwrap();
        let (_, back): (u32, Film) = read_film_state(&path).unwrap();
        assert!(back.halves.is_some() && back.halves == adaptive.halves);
        assert_eq!(layers(&back), layers(&adaptive));
        // A film without halves reads back without them.
        write_film_state(&path, &film(), &0u32).unwrap();
        let (_, plain): (u32, Film) = read_film_state(&path).unwrap();
        assert!(!plain.keeps_halves());
        assert_eq!(layers(&plain), layers(&film()));
        // Version 2 (the same bytes) is read; version 1 (coverage by
        // index) and a future version are refused.
        let mut bytes = std::fs::read(&path).unwrap();
        let body = bytes.len() - 4;
        for version in [2u32, 1, 4] {
            bytes[8..12].copy_from_slice(&version.to_le_bytes());
            let crc = crc32fast::hash(&bytes[..body]);
            bytes[body..].copy_from_slice(&crc.to_le_bytes());
            std::fs::write(&path, &bytes).unwrap();
            match read_film_state::<u32>(&path) {
                Ok((_, two)) => assert!(version == 2 && layers(&two) == layers(&film())),
                Err(e) => assert!(
                    version != 2
                        && e.to_string().contains(&format!(
                            "version {version}; this Cirrus reads versions [2, 3]"
                        )),
                    "{e}"
                ),
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn damaged_truncated_and_foreign_files_are_refused() {
        let dir = std::env::temp_dir().join(format!("cirrus_film_bad_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.checkpoint");
        write_film_state(&path, &film(), &0u32).unwrap();
        let good = std::fs::read(&path).unwrap();
        let mut flipped = good.clone();
        flipped[good.len() / 2] ^= 1;
        let cases: [(&str, Vec<u8>, &str); 4] = [
            ("flipped", flipped, "checksum mismatch"),
            (
                "truncated",
                good[..good.len() - 9].to_vec(),
                "checksum mismatch",
            ),
            ("foreign", b"P6\n5 3\n255\n".to_vec(), "no CIRRUSFS magic"),
            ("empty", Vec::new(), "no CIRRUSFS magic"),
        ];
        for (name, bytes, want) in cases {
            std::fs::write(&path, bytes).unwrap();
            let err = read_film_state::<u32>(&path).unwrap_err().to_string();
            assert!(
                err.contains(want) && err.contains("a.checkpoint"),
                "{name}: {err}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
