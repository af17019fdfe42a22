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

use super::JobError;
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
    /// The frame's data window (a render product's `dataWindowNDC`) as
    /// `[x, y, width, height]` pixels, y down, when it is not the whole
    /// image (always so in film states of version 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data_window: Option<[u32; 4]>,
}

impl PartInfo {
    /// The frame's data window as `[x, y, width, height]` when `window`
    /// (of an image of `resolution`) is not the whole image.
    pub fn data_window_of(window: Tile, resolution: UVec2) -> Option<[u32; 4]> {
        let [x, y] = window.origin.to_array();
        let [w, h] = window.size.to_array();
        (window.size != resolution).then_some([x, y, w, h])
    }

    /// The pixels of an image of `resolution` the frame covers: its data window.
    pub fn frame_window(&self, resolution: UVec2) -> Tile {
        match self.data_window {
            Some([x, y, w, h]) => Tile {
                origin: UVec2::new(x, y),
                size: UVec2::new(w, h),
            },
            None => Tile {
                origin: UVec2::ZERO,
                size: resolution,
            },
        }
    }
}

impl PartRequest {
    /// Whether a part (not the whole frame) is asked for.
    pub fn is_part(&self) -> bool {
        self.tile.is_some() || self.crop.is_some() || self.sample_range.is_some()
    }

    /// The pixels this part covers of a frame covering `frame` of an image
    /// of `resolution` (all of it, or a render product's data window):
    /// `--tile` splits its rows; `--crop` (in image pixels) must lie inside it.
    pub fn window(&self, frame: Tile, resolution: UVec2) -> Result<Tile, JobError> {
        let (start, end) = (frame.origin, frame.origin + frame.size);
        if let Some((i, n)) = self.tile {
            let row = |k: u32| (u64::from(k) * u64::from(frame.size.y) / u64::from(n)) as u32;
            let (y0, y1) = (row(i), row(i + 1));
            if y0 == y1 {
                return Err(JobError::Refused(format!(
                    "--tile {i}/{n}: the frame has only {} rows",
                    frame.size.y
                )));
            }
            return Ok(Tile {
                origin: UVec2::new(start.x, start.y + y0),
                size: UVec2::new(frame.size.x, y1 - y0),
            });
        }
        if let Some([x0, y0, x1, y1]) = self.crop {
            if x0 < start.x || y0 < start.y || x1 > end.x || y1 > end.y {
                let frame = if frame.size == resolution {
                    format!("the {}x{} image", resolution.x, resolution.y)
                } else {
                    let [a, b, c, d] = [start.x, start.y, end.x, end.y];
                    format!("the render product's data window {a},{b},{c},{d} (dataWindowNDC)")
                };
                return Err(JobError::Refused(format!(
                    "--crop {x0},{y0},{x1},{y1}: outside {frame}"
                )));
            }
            return Ok(Tile {
                origin: UVec2::new(x0, y0),
                size: UVec2::new(x1 - x0, y1 - y0),
            });
        }
        Ok(frame)
    }

    /// The sample indices this part takes of a frame of `frame_spp`.
    pub fn samples(&self, frame_spp: u32) -> Result<Range<u32>, JobError> {
        match &self.sample_range {
            Some(r) if r.end > frame_spp => Err(JobError::Refused(format!(
                "--sample-range {}..{}: the frame has {frame_spp} samples (--spp)",
                r.start, r.end
            ))),
            Some(r) => Ok(r.clone()),
            None => Ok(0..frame_spp),
        }
    }
}
