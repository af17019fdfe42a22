//! `cirrus farm submit` flags: a frame range split into parts as a Slurm job
//! array, and a merge job array that runs when every part succeeded (the
//! work is `farm::submit`).

use std::path::PathBuf;

use anyhow::Result;
use glam::UVec2;

use cirrus::farm::{self, SlurmJob, SplitBy};
use cirrus::job::FrameRange;

/// `cirrus farm` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum Farm {
    /// Write (and submit, unless --dry-run) the Slurm job arrays that render
    /// FRAMES of SCENE in --split parts each and merge them.
    Submit(SubmitArgs),
}

/// `cirrus farm submit` arguments.
#[derive(clap::Args, Debug)]
pub struct SubmitArgs {
    /// The USD file (or exported scene folder) to render.
    scene: PathBuf,
    /// The EXR of each frame; a run of `#` becomes the zero-padded frame
    /// number (e.g. out/shot.####.exr).
    #[arg(short, long)]
    output: PathBuf,
    /// Frames (USD time codes) A-B[xSTEP], inclusive (default: the stage's default time).
    #[arg(long, value_name = "A-B[xSTEP]")]
    frames: Option<FrameRange>,
    /// Parts per frame.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    split: u32,
    /// Split each frame by image bands or by sample ranges.
    #[arg(long, value_parser = super::choice::<SplitBy>(), default_value_t)]
    split_by: SplitBy,
    /// Samples per pixel of each frame.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Image size WIDTHxHEIGHT (default: the stage's).
    #[arg(long, value_parser = cirrus::job::parse_resolution)]
    res: Option<UVec2>,
    /// Shutter OPEN,CLOSE (frames) each frame is exported and rendered with
    /// (default: the camera's).
    #[arg(long, value_name = "OPEN,CLOSE", allow_hyphen_values = true)]
    shutter: Option<cirrus::motion::Shutter>,
    /// Further `cirrus render` flags given to every part (e.g. "--aovs all --seed 3").
    #[arg(long, allow_hyphen_values = true, default_value = "")]
    render_args: String,
    /// CPUs per part (the render uses as many threads).
    #[arg(long, default_value_t = 1)]
    cpus_per_task: u32,
    /// Folder for the exported frames, job scripts, parts, logs and task
    /// exit codes (default: farm-<output stem> beside the output).
    #[arg(long)]
    job_dir: Option<PathBuf>,
    /// Write the job scripts and print the sbatch commands, submitting nothing.
    #[arg(long)]
    dry_run: bool,
}

/// Runs `cirrus farm submit`: writes (and submits) the job scripts and
/// prints the sbatch commands or the submitted jobs ([`farm::Submitted`]).
pub fn submit(args: SubmitArgs) -> Result<()> {
    let job = SlurmJob {
        scene: args.scene,
        output: args.output,
        frames: args.frames,
        split: args.split,
        split_by: args.split_by,
        spp: args.spp,
        res: args.res,
        shutter: args.shutter,
        render_args: args.render_args,
        cpus_per_task: args.cpus_per_task,
        job_dir: args.job_dir,
        dry_run: args.dry_run,
    };
    println!("{}", farm::submit(&job)?);
    Ok(())
}
