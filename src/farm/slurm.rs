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

use std::fmt;
use std::path::{Path, PathBuf};
use std::process::Command;

use glam::UVec2;

use super::FarmError;
use crate::file_error::FileError;
use crate::job::{frame_output, shell_quote, FrameRange};
use crate::motion::Shutter;

/// How a frame is split into parts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SplitBy {
    /// Horizontal bands of rows (`--tile I/N`): merged bit-identical to a
    /// whole render.
    #[default]
    Tiles,
    /// Ranges of the sample sequence (`--sample-range`): every part sees the
    /// whole image (good for progressive previews), merged within rounding.
    Samples,
}

crate::choice::choice!(SplitBy {
    Tiles => "tiles",
    Samples => "samples",
});

/// A frame range to render on Slurm (`cirrus farm submit`).
#[derive(Clone, Debug)]
pub struct SlurmJob {
    /// The USD file (or exported scene folder) to render.
    pub scene: PathBuf,
    /// The EXR of each frame; a run of `#` becomes the zero-padded frame
    /// number (e.g. out/shot.####.exr).
    pub output: PathBuf,
    /// Frames (USD time codes), inclusive; `None`: the stage's default time.
    pub frames: Option<FrameRange>,
    /// Parts per frame (at least 1).
    pub split: u32,
    /// How each frame is split.
    pub split_by: SplitBy,
    /// Samples per pixel of each frame.
    pub spp: u32,
    /// Image size (default: the stage's).
    pub res: Option<UVec2>,
    /// Shutter each frame is exported with (default: the camera's); the
    /// parts render the exported frames, so with their motion keys.
    pub shutter: Option<Shutter>,
    /// Further `cirrus render` flags given to every part.
    pub render_args: String,
    /// CPUs per part (the render uses as many threads).
    pub cpus_per_task: u32,
    /// Folder for the exported frames, job scripts, parts, logs and task
    /// exit codes (default: farm-<output stem> beside the output).
    pub job_dir: Option<PathBuf>,
    /// Write the job scripts, submitting nothing.
    pub dry_run: bool,
}

/// What [`submit`] wrote and submitted.
#[derive(Clone, Debug)]
pub struct Submitted {
    /// The job folder.
    pub dir: PathBuf,
    /// Tasks of the parts array.
    pub tasks: u32,
    /// Frames, one merge task each.
    pub frames: usize,
    /// `parts.sbatch` and `merge.sbatch`.
    pub scripts: [PathBuf; 2],
    /// The parts and merge job ids; `None` for a dry run.
    pub jobs: Option<[String; 2]>,
}

impl fmt::Display for Submitted {
    /// The two sbatch commands that submit the scripts (a dry run), or the
    /// submitted jobs and where their logs and exit codes go.
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let [parts, merge] = &self.scripts;
        let dir = self.dir.display();
        match &self.jobs {
            None => write!(
                f,
                "sbatch --parsable {}\nsbatch --parsable {} {}",
                parts.display(),
                merge_flags("<parts job>").join(" "),
                merge.display()
            ),
            Some([parts_job, merge_job]) => write!(
                f,
                "submitted parts job {parts_job} ({} tasks) and merge job {merge_job} ({} frames); \
                 logs in {dir}/logs, exit codes in {dir}/status",
                self.tasks, self.frames
            ),
        }
    }
}

/// The sbatch flags of the merge job: it runs once every task of
/// `parts_job` succeeded, and is cancelled when one failed.
fn merge_flags(parts_job: &str) -> [String; 2] {
    [
        format!("--dependency=afterok:{parts_job}"),
        "--kill-on-invalid-dep=yes".into(),
    ]
}

/// A path quoted for bash.
fn quote_path(p: &Path) -> String {
    shell_quote(&p.to_string_lossy())
}

/// An absolute path (the scripts run elsewhere).
fn absolute(p: &Path) -> Result<PathBuf, FarmError> {
    std::path::absolute(p).map_err(|e| FileError::new("resolve", p, e).into())
}

/// Exports every frame of `job` into its job folder, writes the two job
/// scripts and, unless `job.dry_run`, submits them.
pub fn submit(job: &SlurmJob) -> Result<Submitted, FarmError> {
    let args = job;
    if args.split_by == SplitBy::Samples && args.split > args.spp {
        return Err(FarmError::Refused(format!(
            "--split {} by samples needs at least that many --spp ({})",
            args.split, args.spp
        )));
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
        return Err(FarmError::Refused(format!(
            "the job folder {} must not contain spaces or quotes (--job-dir)",
            dir.display()
        )));
    }
    for sub in ["scenes", "parts", "logs", "status"] {
        let path = dir.join(sub);
        std::fs::create_dir_all(&path).map_err(|e| FileError::new("create", &path, e))?;
    }
    let frames: Vec<Option<i64>> = match &args.frames {
        Some(r) => r.frames().map(Some).collect(),
        None => vec![None],
    };
    let label = |f: Option<i64>| f.map_or("default".to_string(), |f| f.to_string());
    for &frame in &frames {
        let scene = dir.join("scenes").join(label(frame));
        if crate::scene::is_usd(&args.scene) {
            let options = crate::scene::ExportOptions {
                frame: frame.map(|f| f as f64),
                shutter: args.shutter,
                ..Default::default()
            };
            crate::scene::export(&args.scene, &scene, &options)?;
        } else if frame.is_some() || args.shutter.is_some() {
            return Err(FarmError::Refused(format!(
                "--frames and --shutter need a USD scene; {} is exported (its shutter is the \
                 one it was exported with: `cirrus export --shutter`)",
                args.scene.display()
            )));
        } else {
            let _ = std::fs::remove_file(&scene);
            std::os::unix::fs::symlink(absolute(&args.scene)?, &scene)
                .map_err(|e| FileError::new("link", &scene, e))?;
        }
    }
    let cirrus =
        std::env::current_exe().map_err(|e| FileError::new("find", "the cirrus binary", e))?;
    let labels: Vec<String> = frames.iter().map(|&f| shell_quote(&label(f))).collect();
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
  --threads "${{SLURM_CPUS_PER_TASK:-1}}" --checkpoint-every 60 "${{resume[@]}}" {extra}
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
{cirrus} merge "${{parts[@]}}" -o "${{outputs[$SLURM_ARRAY_TASK_ID]}}"
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
        crate::image::write_file(path, text.as_bytes())
            .map_err(|e| FileError::new("write", path, e))?;
    }
    let mut submitted = Submitted {
        dir,
        tasks: frames.len() as u32 * n,
        frames: frames.len(),
        scripts: [parts_path, merge_path],
        jobs: None,
    };
    if args.dry_run {
        return Ok(submitted);
    }
    let [parts_path, merge_path] = &submitted.scripts;
    let parts_job = sbatch(&[], parts_path)?;
    let merge_job = sbatch(&merge_flags(&parts_job), merge_path)?;
    submitted.jobs = Some([parts_job, merge_job]);
    Ok(submitted)
}

/// Submits `script` with `flags`; returns the job id.
fn sbatch(flags: &[String], script: &Path) -> Result<String, FarmError> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(flags)
        .arg(script)
        .output()
        .map_err(|e| FileError::new("run", "sbatch (is Slurm installed and SLURM_CONF set?)", e))?;
    if !out.status.success() {
        return Err(FarmError::Refused(format!(
            "sbatch {} failed: {}",
            script.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let id = String::from_utf8_lossy(&out.stdout).trim().to_string();
    // `--parsable` prints `ID` or `ID;CLUSTER`.
    Ok(id.split(';').next().unwrap_or_default().to_string())
}
