//! One frame of a job: its flags checked against each other, the scene
//! opened with its memory preflight, the outputs planned and claimed, the
//! peak memory checked, the render state built; then the frame rendered (or
//! resumed) with its periodic checkpoints and previews, and written, or
//! saved for `--resume` when its caller stops it.

use std::ops::Range;
use std::time::Instant;

use super::{
    is_film_output, open, plan_outputs, resume, save_interrupted, write_finished, write_snapshot,
    Fingerprint, FrameOutcome, ImageFormat, JobControl, JobError, OutputFiles, OutputFlags,
    OutputPlan, PartInfo, RenderIdentity, RenderJob, DEFAULT_SPP,
};
use crate::film::{AovSet, Film};
use crate::integrator::{
    self, Budget, Periodic, RenderControl, RenderSettings, RenderStats, Snapshot,
};
use crate::memory;
use crate::output::{preview_path, write_film_preview, ExrHeader};
use crate::progress_bar::ProgressDisplay;
use crate::render_state::{self, RenderState, StateOptions};
use crate::scene::{ExportOptions, OpenOptions, Refinement, Scene};

/// A frame ready to render: its render state, settings and identity.
struct Ready {
    state: RenderState,
    settings: RenderSettings,
    identity: RenderIdentity,
}

/// Renders `job.frame` of `job.scene` to `job.output`; `in_sequence`: the
/// frame is one of several, so the products' names need a frame token.
pub(super) fn render_frame(
    job: &RenderJob,
    in_sequence: bool,
    control: &JobControl,
) -> Result<FrameOutcome, JobError> {
    let (mut settings, samples) = checked_settings(job)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = job.threads {
        pool = pool.num_threads(n.into());
    }
    let pool = pool.build()?;
    let start = Instant::now();
    let options = OpenOptions {
        export: ExportOptions {
            frame: job.frame,
            camera: job.camera.as_deref(),
            settings: job.settings.as_deref(),
            shutter: job.shutter,
        },
        refinement: Refinement::Level(job.subdiv_level),
    };
    let scene = open(&job.scene, &options, job.memory_limit)?;
    let flags = OutputFlags {
        output: job.output.as_deref(),
        aovs: job.aovs.as_ref(),
        resolution: job.resolution.is_some(),
        camera: job.camera.is_some(),
        sequence: in_sequence,
    };
    let m = &scene.manifest;
    let plan = plan_outputs(&m.render, m.source.time_code, &flags)?;
    settings.aovs = plan.aovs.clone();
    let Some(files) = plan.claim(job.aov_files, job.skip_existing, job.resume)? else {
        return Ok(FrameOutcome::Complete(plan.outputs[0].path.clone()));
    };
    let (ready, from) = build(job, scene, settings, samples, &plan, &files, &pool)?;
    let size = from.film.window.size;
    log::info!(
        "{}: ready in {:.2} s, {}x{}",
        job.scene.display(),
        start.elapsed().as_secs_f64(),
        size.x,
        size.y
    );
    let (end, stats) = render(job, &ready, from, &files[0], control, &pool);
    let identity = ready.identity.named(&ready.state, &end.film);
    if !stats.complete {
        return Err(stopped(job, &files[0], &identity, &end, &stats));
    }
    let mut written = Vec::new();
    for (files, product) in files.iter().zip(&plan.outputs) {
        let format = ImageFormat {
            aov_files: job.aov_files,
            compression: job.compression,
            layers: &product.layers,
        };
        written.extend(write_finished(files, &identity, &end, &stats, format)?);
    }
    stats.log_summary();
    Ok(FrameOutcome::Written(written))
}

/// The render settings `job` asks for (the AOVs left to the output plan),
/// and the sample indices its part takes; refuses flags that contradict
/// each other.
fn checked_settings(job: &RenderJob) -> Result<(RenderSettings, Range<u32>), JobError> {
    let refuse = |why: &str| Err(JobError::Refused(why.into()));
    let budget = match (job.spp, job.time) {
        (_, Some(t)) => Budget::Time(t),
        (Some(0), _) => return refuse("--spp 0: at least one sample per pixel"),
        (spp, None) => Budget::Samples(spp.unwrap_or(DEFAULT_SPP)),
    };
    if job.path.clamp.is_some_and(|c| c.is_nan() || c <= 0.0) {
        return refuse("--clamp must be positive");
    }
    let film_output = job.output.as_deref().is_some_and(is_film_output);
    let part = &job.part;
    if film_output && job.preview_every.is_some() {
        return refuse("--preview-every: a film state (-o *.film) has no preview; write an EXR");
    }
    if job.adaptive.is_some() && part.sample_range.is_some() {
        return refuse("--noise-threshold cannot be split by --sample-range: which pixels stop depends on all their samples; split the frame by --tile or --crop instead");
    }
    if part.is_part() && !film_output {
        return refuse("--tile, --crop and --sample-range render a part of a frame: write it with -o PART.film and join the parts with cirrus merge");
    }
    let frame_spp = match budget {
        Budget::Samples(n) => n,
        Budget::Time(_) if film_output => {
            return refuse("a film state (-o *.film) needs --spp, not --time")
        }
        Budget::Time(_) => 0,
    };
    let settings = RenderSettings {
        budget,
        seed: job.seed,
        sampler: job.sampler,
        filter: job.filter,
        path: job.path,
        aovs: AovSet::default(),
        adaptive: job.adaptive,
    };
    Ok((settings, part.samples(frame_spp)?))
}

/// Checks the frame's peak memory, builds its render state (then drops
/// the scene) and its identity, and the film it starts from: fresh, or
/// the checkpoint `--resume` continues.
fn build(
    job: &RenderJob,
    scene: Scene,
    mut settings: RenderSettings,
    samples: Range<u32>,
    plan: &OutputPlan,
    files: &[OutputFiles],
    pool: &rayon::ThreadPool,
) -> Result<(Ready, Snapshot), JobError> {
    let resolution = render_state::resolution_for(&scene, job.resolution);
    let frame = plan.frame_window(resolution)?;
    let window = job.part.window(frame, resolution)?;
    let needs = pool.install(|| memory::estimate(&scene, window.size, &settings.aovs))?;
    memory::check(&needs, job.memory_limit)?;
    log::debug!("estimated peak memory: {needs}");
    let options = StateOptions {
        majorant: job.majorant,
        volume_lights: job.volume_light_sampling,
        shutter: job.shutter,
    };
    let state = pool.install(|| RenderState::build(&scene, job.resolution, options))?;
    // Samples per pixel of the whole frame (0 for a time budget).
    let frame_spp = settings.budget.target().unwrap_or(0);
    let identity = RenderIdentity {
        fingerprint: Fingerprint::new(&scene, state.resolution, &settings, options)?,
        exr: ExrHeader::new(&state, &settings).with_layers(&plan.outputs[0].layers),
        part: PartInfo {
            samples: samples.clone(),
            frame_spp,
            data_window: PartInfo::data_window_of(frame, resolution),
        },
    };
    drop(scene);
    if let Budget::Samples(_) = settings.budget {
        // The integrator's target is the last sample index of this part.
        settings.budget = Budget::Samples(samples.end);
    }
    let film = Film::cropped(state.resolution, window, settings.aovs.clone());
    let fresh = Snapshot::new(film, samples.start);
    let from = if job.resume {
        let checkpoint = &files[0].checkpoint;
        let resumed = resume(checkpoint, &identity, &fresh, &settings)?;
        log::info!(
            "resuming {} at {} spp",
            checkpoint.display(),
            resumed.progress.samples_per_pixel()
        );
        resumed
    } else {
        fresh
    };
    let ready = Ready {
        state,
        settings,
        identity,
    };
    Ok((ready, from))
}

/// Renders `ready` on from `from` to its end, or until `control` stops it,
/// saving the checkpoint of `files` and rewriting its preview as often as
/// `job` asks; shows the progress.
fn render(
    job: &RenderJob,
    ready: &Ready,
    from: Snapshot,
    files: &OutputFiles,
    control: &JobControl,
    pool: &rayon::ThreadPool,
) -> (Snapshot, RenderStats) {
    let progress = ProgressDisplay::new();
    let save = |s: &Snapshot| {
        let identity = ready.identity.named(&ready.state, &s.film);
        if let Err(e) = write_snapshot(&files.checkpoint, &identity, s) {
            log::warn!("checkpoint not saved: {e:#}");
        }
    };
    let preview = |s: &Snapshot| {
        if let Err(e) = write_film_preview(&preview_path(files.output()), &s.film) {
            log::warn!("preview not written: {e}");
        }
    };
    let periodic: Vec<Periodic> = [
        (job.checkpoint_every, &save as &(dyn Fn(&Snapshot) + Sync)),
        (job.preview_every, &preview),
    ]
    .into_iter()
    .filter_map(|(every, save)| every.map(|every| Periodic { every, save }))
    .collect();
    let render_control = RenderControl {
        progress: &|f| progress.update(f),
        stop: control.stop,
        periodic: &periodic,
    };
    let ended = pool
        .install(|| integrator::render_from(&ready.state, &ready.settings, from, &render_control));
    progress.finish();
    ended
}

/// Why a job whose frame its caller stopped at `end` ends: the frame's
/// checkpoint and partial image saved to `files` for `--resume`, unless it
/// took no sample.
fn stopped(
    job: &RenderJob,
    files: &OutputFiles,
    identity: &RenderIdentity,
    end: &Snapshot,
    stats: &RenderStats,
) -> JobError {
    if end.progress.is_empty() {
        let nothing = "interrupted before the first sample; nothing written";
        return JobError::Interrupted(nothing.into());
    }
    if let Err(e) = save_interrupted(files, identity, end, stats, job.compression) {
        return JobError::NotCheckpointed(Box::new(e));
    }
    let spp = end.progress.samples_per_pixel();
    let (c, p) = (files.checkpoint.display(), files.partial.display());
    JobError::Interrupted(format!(
        "interrupted at {spp} spp: saved {c} and {p}; run the same command with --resume to finish"
    ))
}
