//! One frame over many processes: `cirrus render --tile I/N | --crop |
//! --sample-range A..B -o PART.film` renders a part of a frame into a
//! film-state file, and `cirrus merge PARTS... -o OUT.exr` adds the parts
//! into the frame. Parts split by window are bit-identical to the frame
//! rendered whole (each pixel takes all its samples in one part); parts split
//! by samples continue the same sample sequence, so the merged frame equals
//! the whole one up to the rounding of adding two f64 partial sums.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Result};
use glam::UVec2;
use serde::{Deserialize, Serialize};

use super::checkpoint::{self, FilmStateHeader, OutputFiles};
use cirrus::film::{Film, Tile};
use cirrus::image::Compression;
use cirrus::integrator::{RayCounts, RenderStats};
use cirrus::output::write_preview;
use cirrus::output::{write_film, AovFiles};
use cirrus::volumes::TrackingStats;

/// Which part of a frame `cirrus render` takes (all of it by default).
#[derive(clap::Args, Debug, Default)]
pub struct PartArgs {
    /// Render only horizontal band I of N (0-based, e.g. 2/4: the third of
    /// four bands of rows) into a film state (-o PART.film).
    #[arg(long, value_name = "I/N", value_parser = parse_tile, conflicts_with = "crop")]
    tile: Option<(u32, u32)>,
    /// Render only the pixels x0 <= x < x1, y0 <= y < y1 into a film state
    /// (-o PART.film).
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_crop)]
    crop: Option<[u32; 4]>,
    /// Take only sample indices START..END (END exclusive, at most --spp) of
    /// the frame's sequence into a film state (-o PART.film).
    #[arg(long, value_name = "START..END", value_parser = parse_sample_range)]
    sample_range: Option<Range<u32>>,
}

/// Where a film-state part sits in its frame.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(super) struct PartInfo {
    /// Sample indices this part takes.
    pub samples: Range<u32>,
    /// Samples per pixel of the whole frame (`--spp`).
    pub frame_spp: u32,
}

impl PartArgs {
    /// Whether a part (not the whole frame) is asked for.
    pub fn is_part(&self) -> bool {
        self.tile.is_some() || self.crop.is_some() || self.sample_range.is_some()
    }

    /// The window of an image of `resolution` this part covers.
    pub fn window(&self, resolution: UVec2) -> Result<Tile> {
        if let Some((i, n)) = self.tile {
            let row = |k: u32| (u64::from(k) * u64::from(resolution.y) / u64::from(n)) as u32;
            let (y0, y1) = (row(i), row(i + 1));
            if y0 == y1 {
                bail!("--tile {i}/{n}: the image has only {} rows", resolution.y);
            }
            return Ok(Tile {
                origin: UVec2::new(0, y0),
                size: UVec2::new(resolution.x, y1 - y0),
            });
        }
        if let Some([x0, y0, x1, y1]) = self.crop {
            if x1 > resolution.x || y1 > resolution.y {
                bail!(
                    "--crop {x0},{y0},{x1},{y1}: outside the {}x{} image",
                    resolution.x,
                    resolution.y
                );
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
    pub fn samples(&self, frame_spp: u32) -> Result<Range<u32>> {
        match &self.sample_range {
            Some(r) if r.end > frame_spp => bail!(
                "--sample-range {}..{}: the frame has {frame_spp} samples (--spp)",
                r.start,
                r.end
            ),
            Some(r) => Ok(r.clone()),
            None => Ok(0..frame_spp),
        }
    }
}

/// Parses `I/N` with 0 <= I < N.
fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once('/')
        .and_then(|(i, n)| Some((i.parse::<u32>().ok()?, n.parse::<u32>().ok()?)));
    match parsed {
        Some((i, n)) if i < n => Ok((i, n)),
        _ => Err(format!("{s:?}: expected I/N with 0 <= I < N, e.g. 0/4")),
    }
}

/// Parses `X0,Y0,X1,Y1` with X0 < X1 and Y0 < Y1.
fn parse_crop(s: &str) -> Result<[u32; 4], String> {
    let values: Vec<u32> = s.split(',').filter_map(|v| v.trim().parse().ok()).collect();
    match values[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        _ => Err(format!(
            "{s:?}: expected X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, e.g. 0,0,640,360"
        )),
    }
}

/// Parses `START..END` with START < END.
fn parse_sample_range(s: &str) -> Result<Range<u32>, String> {
    let parsed = s
        .split_once("..")
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)));
    match parsed {
        Some((a, b)) if a < b => Ok(a..b),
        _ => Err(format!(
            "{s:?}: expected START..END with START < END, e.g. 0..32"
        )),
    }
}

/// `cirrus merge` arguments.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The parts' film states (`cirrus render ... -o PART.film`).
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The EXR to write; a tone-mapped PNG preview is written beside it.
    #[arg(short, long)]
    output: PathBuf,
    /// One multi-channel EXR, or one file per AOV (OUT.<aov>.exr).
    #[arg(long, value_parser = super::choice::<AovFiles>(), default_value_t)]
    aov_files: AovFiles,
    /// EXR compression.
    #[arg(long, value_parser = super::choice::<Compression>(), default_value_t)]
    compression: Compression,
    /// Overwrite existing outputs.
    #[arg(long)]
    force: bool,
}

/// One part read back.
struct Part {
    path: PathBuf,
    header: FilmStateHeader,
    film: Film,
}

/// Runs `cirrus merge`: checks that the parts are of one frame (same scene
/// and settings), finished, and cover every pixel's samples exactly once,
/// listing every problem; then adds them and writes the frame.
pub fn merge(args: MergeArgs) -> Result<()> {
    let mut parts = Vec::new();
    for path in &args.parts {
        let (header, film) = checkpoint::read(path)?;
        parts.push(Part {
            path: path.clone(),
            header,
            film,
        });
    }
    let problems = problems(&parts);
    if !problems.is_empty() {
        bail!(
            "cannot merge these {} parts:\n  {}",
            parts.len(),
            problems.join("\n  ")
        );
    }
    let first = &parts[0];
    let files = OutputFiles::new(&args.output, args.aov_files, first.film.aov_set());
    files.refuse_existing(args.force)?;
    let mut frame = Film::new(first.film.resolution, first.film.aov_set().clone());
    let mut stats = RenderStats {
        samples_per_pixel: first.header.identity.part.frame_spp,
        elapsed: Duration::ZERO,
        rays: RayCounts::default(),
        non_finite: Default::default(),
        tracking: TrackingStats::default(),
        complete: true,
    };
    for part in &parts {
        frame.add_part(&part.film);
        let p = &part.header.progress;
        stats.elapsed += Duration::from_secs_f64(p.seconds);
        stats.rays.add(&p.rays);
        stats.tracking.merge(&p.tracking);
    }
    stats.non_finite = frame.non_finite;
    let header = &first.header.identity.exr;
    write_film(
        &args.output,
        args.aov_files,
        &frame,
        header,
        &stats,
        args.compression,
    )?;
    let r = frame.resolution;
    let preview = args.output.with_extension("png");
    write_preview(&preview, r.x, r.y, &frame.rgb())?;
    println!(
        "merged {} parts ({:.1} s of rendering) into {} and {}",
        parts.len(),
        stats.elapsed.as_secs_f64(),
        args.output.display(),
        preview.display()
    );
    Ok(())
}

/// Everything that stops `parts` from making one frame, one line each.
fn problems(parts: &[Part]) -> Vec<String> {
    let mut problems = Vec::new();
    let first = &parts[0];
    let name = |p: &Part| p.path.display().to_string();
    for part in &parts[1..] {
        let (a, b) = (&first.header.identity, &part.header.identity);
        problems.extend(
            a.fingerprint
                .differences(&b.fingerprint, [&name(first), &name(part)]),
        );
        if b.part.frame_spp != a.part.frame_spp || part.film.resolution != first.film.resolution {
            problems.push(format!(
                "{} is of another frame than {}",
                name(part),
                name(first)
            ));
        }
    }
    for part in parts {
        let p = &part.header.progress;
        if p.next_sample() != part.header.identity.part.samples.end {
            problems.push(format!(
                "{} is unfinished ({} of samples {:?}); resume it",
                name(part),
                p.samples_per_pixel(),
                part.header.identity.part.samples
            ));
        }
    }
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            let (sa, sb) = (
                &a.header.identity.part.samples,
                &b.header.identity.part.samples,
            );
            if overlap(a.film.window, b.film.window) && sa.start < sb.end && sb.start < sa.end {
                problems.push(format!(
                    "{} and {} overlap (both take samples {}..{} of some pixels)",
                    name(a),
                    name(b),
                    sa.start.max(sb.start),
                    sa.end.min(sb.end)
                ));
            }
        }
    }
    if problems.is_empty() {
        problems.extend(missing(parts));
    }
    problems
}

/// Whether two windows share a pixel.
fn overlap(a: Tile, b: Tile) -> bool {
    let (a1, b1) = (a.origin + a.size, b.origin + b.size);
    a.origin.x < b1.x && b.origin.x < a1.x && a.origin.y < b1.y && b.origin.y < a1.y
}

/// Pixels whose samples the (non-overlapping) parts do not all cover: the
/// count and the first such pixel.
fn missing(parts: &[Part]) -> Option<String> {
    let first = &parts[0];
    let r = first.film.resolution;
    let spp = first.header.identity.part.frame_spp;
    let mut covered = vec![0u32; r.x as usize * r.y as usize];
    for part in parts {
        let w = part.film.window;
        let n = part.header.identity.part.samples.len() as u32;
        for y in w.origin.y..w.origin.y + w.size.y {
            let row = y as usize * r.x as usize;
            for x in w.origin.x..w.origin.x + w.size.x {
                covered[row + x as usize] += n;
            }
        }
    }
    let short: Vec<usize> = (0..covered.len()).filter(|&i| covered[i] < spp).collect();
    let i = *short.first()?;
    Some(format!(
        "{} pixels lack samples; the first, ({}, {}), has {} of {spp}: a part is missing",
        short.len(),
        i % r.x as usize,
        i / r.x as usize,
        covered[i]
    ))
}

/// Whether `-o` names a film state (`.film`) rather than an image.
pub(super) fn is_film_output(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "film")
}
