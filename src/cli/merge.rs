//! Flags for one frame over many processes: `cirrus render --tile I/N |
//! --crop | --sample-range A..B -o PART.film` and `cirrus merge PARTS... -o
//! OUT.exr` (the work is `job::PartRequest` and `farm::merge`).

use std::ops::Range;
use std::path::PathBuf;

use anyhow::Result;

use cirrus::farm;
use cirrus::image::Compression;
use cirrus::job::{self, PartRequest};
use cirrus::output::AovFiles;

/// Which part of a frame `cirrus render` takes (all of it by default).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct PartArgs {
    /// Render only horizontal band I of N (0-based, e.g. 2/4: the third of
    /// four bands of rows) into a film state (-o PART.film).
    #[arg(long, value_name = "I/N", value_parser = job::parse_tile, conflicts_with = "crop")]
    tile: Option<(u32, u32)>,
    /// Render only the pixels x0 <= x < x1, y0 <= y < y1 into a film state
    /// (-o PART.film).
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = job::parse_crop)]
    crop: Option<[u32; 4]>,
    /// Take only sample indices START..END (END exclusive, at most --spp) of
    /// the frame's sequence into a film state (-o PART.film).
    #[arg(long, value_name = "START..END", value_parser = job::parse_sample_range)]
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
