//! One frame over many processes: a render can take a part of a frame, a
//! band of rows (`--tile I/N`), a window (`--crop`) or a range of the sample
//! sequence (`--sample-range A..B`), into a film-state file. Parts split by
//! window are bit-identical to the frame rendered whole (each pixel takes
//! all its samples in one part); parts split by samples continue the same
//! sample sequence, so the merged frame equals the whole one up to the
//! rounding of adding two f64 partial sums.

use std::ops::Range;

use glam::UVec2;
use serde::{Deserialize, Serialize};

use super::FarmError;
use crate::film::Tile;

/// Which part of a frame a render takes (all of it by default).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PartRequest {
    /// Horizontal band `I` of `N` (0-based).
    pub tile: Option<(u32, u32)>,
    /// The pixels `x0 <= x < x1`, `y0 <= y < y1`, as `[x0, y0, x1, y1]`.
    pub crop: Option<[u32; 4]>,
    /// Sample indices `START..END` of the frame's sequence.
    pub sample_range: Option<Range<u32>>,
}

/// Where a film-state part sits in its frame.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartInfo {
    /// Sample indices this part takes.
    pub samples: Range<u32>,
    /// Samples per pixel of the whole frame (`--spp`).
    pub frame_spp: u32,
}

impl PartRequest {
    /// Whether a part (not the whole frame) is asked for.
    pub fn is_part(&self) -> bool {
        self.tile.is_some() || self.crop.is_some() || self.sample_range.is_some()
    }

    /// The window of an image of `resolution` this part covers.
    pub fn window(&self, resolution: UVec2) -> Result<Tile, FarmError> {
        if let Some((i, n)) = self.tile {
            let row = |k: u32| (u64::from(k) * u64::from(resolution.y) / u64::from(n)) as u32;
            let (y0, y1) = (row(i), row(i + 1));
            if y0 == y1 {
                return Err(FarmError::Refused(format!(
                    "--tile {i}/{n}: the image has only {} rows",
                    resolution.y
                )));
            }
            return Ok(Tile {
                origin: UVec2::new(0, y0),
                size: UVec2::new(resolution.x, y1 - y0),
            });
        }
        if let Some([x0, y0, x1, y1]) = self.crop {
            if x1 > resolution.x || y1 > resolution.y {
                return Err(FarmError::Refused(format!(
                    "--crop {x0},{y0},{x1},{y1}: outside the {}x{} image",
                    resolution.x, resolution.y
                )));
            }
            return Ok(Tile {
                origin: UVec2::new(x0, y0),
                size: UVec2::new(x1 - x0, y1 - y0),
            });
        }
        Ok(Tile {
            origin: UVec2::ZERO,
            size: resolution,
        })
    }

    /// The sample indices this part takes of a frame of `frame_spp`.
    pub fn samples(&self, frame_spp: u32) -> Result<Range<u32>, FarmError> {
        match &self.sample_range {
            Some(r) if r.end > frame_spp => Err(FarmError::Refused(format!(
                "--sample-range {}..{}: the frame has {frame_spp} samples (--spp)",
                r.start, r.end
            ))),
            Some(r) => Ok(r.clone()),
            None => Ok(0..frame_spp),
        }
    }
}
