//! `cirrus merge PARTS... -o OUT.exr`: joins the film states of one frame's
//! parts (`cirrus render --tile I/N | --crop | --sample-range A..B -o
//! PART.film`) into its EXR (the work is `farm::merge`).

use std::path::PathBuf;

use anyhow::Result;

use cirrus::farm;
use cirrus::image::Compression;
use cirrus::output::AovFiles;

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
