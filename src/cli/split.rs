//! Flags for one frame over many processes: `cirrus render --tile I/N |
//! --crop | --sample-range A..B -o PART.film` and `cirrus merge PARTS... -o
//! OUT.exr` (the work is `job::PartRequest` and `farm::merge`).

use std::ops::Range;
use std::path::PathBuf;

use anyhow::Result;

use cirrus::farm;
use cirrus::image::Compression;
use cirrus::job::PartRequest;
use cirrus::output::AovFiles;

/// Which part of a frame `cirrus render` takes (all of it by default).
#[derive(clap::Args, Clone, Debug, Default)]
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

impl PartArgs {
    /// The part asked for.
    pub fn request(&self) -> PartRequest {
        PartRequest {
            tile: self.tile,
            crop: self.crop,
            sample_range: self.sample_range.clone(),
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
    /// Accepted for old scripts; outputs are always overwritten.
    #[arg(long = "force", hide = true)]
    _force: bool,
}

/// Runs `cirrus merge`.
pub fn merge(args: MergeArgs) -> Result<()> {
    let merged = farm::merge(&args.parts, &args.output, args.aov_files, args.compression)?;
    println!(
        "merged {} parts ({:.1} s of rendering) into {} and {}",
        merged.parts,
        merged.seconds,
        args.output.display(),
        merged.preview.display()
    );
    Ok(())
}
