//! `cirrus farm submit`: a frame range split into parts as a Slurm job
//! array, and a merge job array that runs when every part succeeded.
//!
//! Each frame is exported once at submit time into the job folder, so the
//! nodes need only the `cirrus` binary. Task `K` of the parts array renders
//! part `K % N` of frame `K / N` into `parts/FRAME.PART.film`, checkpointing
//! every minute and resuming a checkpoint left by a pre-empted run; it
//! records its exit code in `status/part-K`. The merge array (task `F` joins
//! frame `F`) depends on the whole parts array (`afterok`) and is cancelled
//! if a part fails; a failed part can be re-run alone with
//! `sbatch --array=K parts.sbatch`, then its frame's merge with
//! `sbatch --array=F merge.sbatch`.

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use glam::UVec2;

/// `cirrus farm` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum Farm {
    /// Write (and submit, unless --dry-run) the Slurm job arrays that render
    /// FRAMES of SCENE in --split parts each and merge them.
    Submit(SubmitArgs),
}

/// How a frame is split into parts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SplitBy {
    /// Horizontal bands of rows (`--tile I/N`): merged bit-identical to a
    /// whole render.
    #[default]
    Tiles,
    /// Ranges of the sample sequence (`--sample-range`): every part sees the
    /// whole image (good for progressive previews), merged within rounding.
    Samples,
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
    /// Frames (USD time codes) A-B, inclusive (default: the stage's default time).
    #[arg(long, value_name = "A-B", value_parser = parse_frames)]
    frames: Option<RangeInclusive<i64>>,
    /// Parts per frame.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    split: u32,
    /// Split each frame by image bands or by sample ranges.
    #[arg(long, value_enum, default_value_t)]
    split_by: SplitBy,
    /// Samples per pixel of each frame.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Image size WIDTHxHEIGHT (default: the stage's).
    #[arg(long, value_parser = super::render::parse_resolution)]
    res: Option<UVec2>,
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

/// Parses `A-B` (or a single frame `A`) with A <= B.
fn parse_frames(s: &str) -> Result<RangeInclusive<i64>, String> {
    let (a, b) = match s.trim().split_once('-').filter(|(a, _)| !a.is_empty()) {
        Some((a, b)) => (a, b),
        None => (s, s),
    };
    match (a.trim().parse::<i64>(), b.trim().parse::<i64>()) {
        (Ok(a), Ok(b)) if a <= b => Ok(a..=b),
        _ => Err(format!("{s:?}: expected frames A-B with A <= B, e.g. 1-24")),
    }
}

/// The output path of `frame`: runs of `#` replaced by the zero-padded number.
fn frame_output(pattern: &Path, frame: Option<i64>) -> PathBuf {
    let text = pattern.to_string_lossy();
    let Some(frame) = frame else {
        return pattern.to_path_buf();
    };
    let Some(start) = text.find('#') else {
        return pattern.to_path_buf();
    };
    let width = text[start..].chars().take_while(|&c| c == '#').count();
    let number = format!("{frame:0width$}");
    PathBuf::from(format!(
        "{}{number}{}",
        &text[..start],
        &text[start + width..]
    ))
}

/// `s` quoted for bash.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

fn quote_path(p: &Path) -> String {
    quote(&p.to_string_lossy())
}

/// An absolute path (the scripts run elsewhere).
fn absolute(p: &Path) -> Result<PathBuf> {
    std::path::absolute(p).with_context(|| format!("{}", p.display()))
}

/// Runs `cirrus farm`.
pub fn run(farm: Farm) -> Result<()> {
    match farm {
        Farm::Submit(args) => submit(args),
    }
}

fn submit(args: SubmitArgs) -> Result<()> {
    if args.split_by == SplitBy::Samples && args.split > args.spp {
        bail!(
            "--split {} by samples needs at least that many --spp ({})",
            args.split,
            args.spp
        );
    }
    let output = absolute(&args.output)?;
    let stem = output
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy().replace('#', ""));
    let dir = match &args.job_dir {
        Some(d) => absolute(d)?,
        None => output.with_file_name(format!("farm-{}", stem.trim_end_matches('.'))),
    };
    if dir
        .to_string_lossy()
        .contains(|c: char| c.is_whitespace() || c == '\'' || c == '"')
    {
        // `#SBATCH --output=` lines are not shell-quoted.
        bail!(
            "the job folder {} must not contain spaces or quotes (--job-dir)",
            dir.display()
        );
    }
    for sub in ["scenes", "parts", "logs", "status"] {
        std::fs::create_dir_all(dir.join(sub))
            .with_context(|| format!("cannot create {}", dir.join(sub).display()))?;
    }
    let frames: Vec<Option<i64>> = match &args.frames {
        Some(r) => r.clone().map(Some).collect(),
        None => vec![None],
    };
    let label = |f: Option<i64>| f.map_or("default".to_string(), |f| f.to_string());
    for &frame in &frames {
        let scene = dir.join("scenes").join(label(frame));
        if super::is_usd(&args.scene) {
            cirrus::scene::export(&args.scene, &scene, frame.map(|f| f as f64))?;
        } else if frame.is_some() {
            bail!(
                "--frames needs a USD scene; {} is exported",
                args.scene.display()
            );
        } else {
            let _ = std::fs::remove_file(&scene);
            std::os::unix::fs::symlink(absolute(&args.scene)?, &scene)
                .with_context(|| format!("cannot link {}", scene.display()))?;
        }
    }
    let cirrus = std::env::current_exe().context("cannot find the cirrus binary")?;
    let labels: Vec<String> = frames.iter().map(|&f| quote(&label(f))).collect();
    let outputs: Vec<String> = frames
        .iter()
        .map(|&f| quote_path(&frame_output(&output, f)))
        .collect();
    let n = args.split;
    let part_flag = match args.split_by {
        SplitBy::Tiles => format!("--tile \"$part/{n}\""),
        SplitBy::Samples => {
            let spp = args.spp;
            format!("--sample-range \"$((part * {spp} / {n}))..$(((part + 1) * {spp} / {n}))\"")
        }
    };
    let res = args
        .res
        .map_or(String::new(), |r| format!(" --res {}x{}", r.x, r.y));
    let parts_script = format!(
        r#"#!/usr/bin/env bash
#SBATCH --job-name=cirrus-parts
#SBATCH --array=0-{last_part}
#SBATCH --cpus-per-task={cpus}
#SBATCH --output={raw_dir}/logs/part-%a.log
# Task K renders part K % {n} of frame K / {n} (cirrus farm submit).
set -uo pipefail
frames=({labels})
frame=${{frames[$((SLURM_ARRAY_TASK_ID / {n}))]}}
part=$((SLURM_ARRAY_TASK_ID % {n}))
film={dir}/parts/"$frame.$part.film"
resume=()
if [ -e "${{film%.film}}.checkpoint" ]; then resume=(--resume); fi
{cirrus} render {dir}/scenes/"$frame" -o "$film" {part_flag} --spp {spp}{res} \
  --threads "${{SLURM_CPUS_PER_TASK:-1}}" --checkpoint-every 60 --force "${{resume[@]}}" {extra}
code=$?
echo "$code" > {dir}/status/part-"$SLURM_ARRAY_TASK_ID"
exit "$code"
"#,
        last_part = frames.len() as u32 * n - 1,
        raw_dir = dir.display(),
        cpus = args.cpus_per_task,
        dir = quote_path(&dir),
        labels = labels.join(" "),
        cirrus = quote_path(&cirrus),
        spp = args.spp,
        extra = args.render_args,
    );
    let merge_script = format!(
        r#"#!/usr/bin/env bash
#SBATCH --job-name=cirrus-merge
#SBATCH --array=0-{last_frame}
#SBATCH --output={raw_dir}/logs/merge-%a.log
# Task F joins the {n} parts of frame F (cirrus farm submit).
set -uo pipefail
frames=({labels})
outputs=({outputs})
frame=${{frames[$SLURM_ARRAY_TASK_ID]}}
parts=()
for ((part = 0; part < {n}; part++)); do parts+=({dir}/parts/"$frame.$part.film"); done
{cirrus} merge "${{parts[@]}}" -o "${{outputs[$SLURM_ARRAY_TASK_ID]}}" --force
code=$?
echo "$code" > {dir}/status/merge-"$SLURM_ARRAY_TASK_ID"
exit "$code"
"#,
        last_frame = frames.len() - 1,
        raw_dir = dir.display(),
        dir = quote_path(&dir),
        labels = labels.join(" "),
        outputs = outputs.join(" "),
        cirrus = quote_path(&cirrus),
    );
    let parts_path = dir.join("parts.sbatch");
    let merge_path = dir.join("merge.sbatch");
    for (path, text) in [(&parts_path, &parts_script), (&merge_path, &merge_script)] {
        cirrus::image::write_file(path, text.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let tasks = frames.len() as u32 * n;
    if args.dry_run {
        println!("sbatch --parsable {}", parts_path.display());
        println!(
            "sbatch --parsable --dependency=afterok:<parts job> --kill-on-invalid-dep=yes {}",
            merge_path.display()
        );
        return Ok(());
    }
    let parts_job = sbatch(&[], &parts_path)?;
    let merge_job = sbatch(
        &[
            format!("--dependency=afterok:{parts_job}"),
            "--kill-on-invalid-dep=yes".into(),
        ],
        &merge_path,
    )?;
    println!(
        "submitted parts job {parts_job} ({tasks} tasks) and merge job {merge_job} ({frames} frames); \
         logs in {dir}/logs, exit codes in {dir}/status",
        frames = frames.len(),
        dir = dir.display()
    );
    Ok(())
}

/// Submits `script` with `flags`; returns the job id.
fn sbatch(flags: &[String], script: &Path) -> Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(flags)
        .arg(script)
        .output()
        .context("cannot run sbatch (is Slurm installed and SLURM_CONF set?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed: {}",
            script.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let id = String::from_utf8_lossy(&out.stdout).trim().to_string();
    // `--parsable` prints `ID` or `ID;CLUSTER`.
    Ok(id.split(';').next().unwrap_or_default().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_patterns_and_ranges_parse() {
        let p = Path::new("/o/shot.####.exr");
        assert_eq!(frame_output(p, Some(7)), Path::new("/o/shot.0007.exr"));
        assert_eq!(frame_output(p, None), p);
        assert_eq!(
            frame_output(Path::new("/o/a.exr"), Some(3)),
            Path::new("/o/a.exr")
        );
        assert_eq!(parse_frames("1-24"), Ok(1..=24));
        assert_eq!(parse_frames("5"), Ok(5..=5));
        assert!(parse_frames("9-2").is_err() && parse_frames("x").is_err());
        assert_eq!(quote("it's"), r"'it'\''s'");
    }
}
