//! `cirrus render SCENE -o OUT.exr`: the renderer's command-line contract.
//! SCENE is a USD file (exported through the cache first) or an exported
//! scene; the beauty (linear, float RGBA) and the chosen AOVs go to OUT.exr
//! (or one file per AOV) and a tone-mapped preview beside it (OUT.png).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use glam::UVec2;

use super::signal::{Interrupted, StopSignal};
use super::split::PartArgs;
use cirrus::farm::{
    frame_output, has_frame_number, is_film_output, plan_outputs, resume, save_interrupted,
    write_finished, write_snapshot, Fingerprint, FrameRange, ImageFormat, OutputFlags, PartInfo,
    RenderIdentity,
};
use cirrus::film::Film;
use cirrus::film::FilterKind;
use cirrus::film::{AdaptiveSampling, AovSet};
use cirrus::image::Compression;
use cirrus::integrator::{
    self, Budget, PathSettings, Periodic, RenderControl, RenderSettings, RenderStats, Snapshot,
    Strategy, VolumeEstimator, DEFAULT_MAX_DEPTH,
};
use cirrus::memory;
use cirrus::output::{preview_path, write_film_preview, AovFiles, ExrHeader};
use cirrus::render_state::{self, RenderState, StateOptions};
use cirrus::sampling::SamplerKind;
use cirrus::volumes::majorant::MajorantKind;

/// Samples per pixel when neither `--spp` nor `--time` is given.
const DEFAULT_SPP: u32 = 64;

/// `cirrus render` arguments.
#[derive(clap::Args, Clone, Debug)]
pub struct RenderArgs {
    /// A USD file (.usd/.usda/.usdc/.usdz), a scene folder, or its scene.json.
    scene: PathBuf,
    /// The EXR to write (default: the render settings' first product's
    /// productName); a tone-mapped PNG preview is written beside it.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples per pixel [default: 64].
    #[arg(long, conflicts_with = "time")]
    spp: Option<u32>,
    /// Render for about this many seconds instead (whole passes; at least one sample).
    #[arg(long, value_parser = parse_seconds)]
    time: Option<Duration>,
    /// Image size WIDTHxHEIGHT (default: the stage's render settings, else 960 wide).
    #[arg(long, value_parser = parse_resolution)]
    res: Option<UVec2>,
    /// Seed of every sample sequence: same seed and spp, same image.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
    /// Sample sequence.
    #[arg(long, value_parser = super::choice::<SamplerKind>(), default_value_t = SamplerKind::Sobol)]
    sampler: SamplerKind,
    /// Light transport estimator: MIS of light and BSDF sampling, or one alone.
    #[arg(long, value_parser = super::choice::<Strategy>(), default_value_t)]
    strategy: Strategy,
    /// Most bounces per path. The default is a safety cap far beyond what
    /// Russian roulette lets through (unbiased in practice); a lower cap
    /// darkens multiple scattering (biased).
    #[arg(long, default_value_t = DEFAULT_MAX_DEPTH)]
    max_depth: u32,
    /// Clamp each sample's RGB components to this radiance (biased; off by default).
    #[arg(long)]
    clamp: Option<f32>,
    /// Pixel filter.
    #[arg(long, value_parser = super::choice::<FilterKind>(), default_value_t)]
    filter: FilterKind,
    /// Majorants of volume extinction: per 8^3-voxel cell (grid) or one per volume (global).
    #[arg(long, value_parser = super::choice::<MajorantKind>(), default_value_t = MajorantKind::Grid)]
    majorant: MajorantKind,
    /// Volume estimator: null-scattering MIS (default) or directional MIS
    /// with ratio, residual-ratio or track-length shadow transmittance.
    #[arg(long, value_parser = super::choice::<VolumeEstimator>(), default_value_t = VolumeEstimator::NullScatteringMis)]
    volume_estimator: VolumeEstimator,
    /// Turn off equiangular sampling of sphere and point lights in media.
    #[arg(long)]
    no_equiangular: bool,
    /// Light-sample emitting volumes (fire) by next-event estimation,
    /// MIS-combined with the emission tracking finds: on (default) or off
    /// (tracking alone, for comparisons). Both are unbiased.
    #[arg(long, default_value = "on", value_parser = on_off, value_name = "on|off", action = clap::ArgAction::Set)]
    volume_light_sampling: bool,
    /// Camera rays see what lies behind media through a ratio-tracking
    /// transmittance estimate, real scattering still sampled by delta
    /// tracking: on, or off (default: delta tracking's 0-or-1 survival,
    /// which measured level or better at equal time on the benchmark
    /// scenes; docs/volumes.md). Both unbiased.
    #[arg(long, default_value = "off", value_parser = on_off, value_name = "on|off", action = clap::ArgAction::Set)]
    camera_ray_transmittance: bool,
    /// Adaptive sampling: a pixel stops once its relative noise estimate is
    /// under this (e.g. 0.05), checked between passes; --spp stays the cap.
    /// Off by default (it is slightly biased: docs/rendering.md).
    #[arg(long, value_name = "T", value_parser = parse_noise_threshold, allow_hyphen_values = true)]
    noise_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling may stop it
    /// [default: max(4, ceil(16 / T^0.3)) as in Cycles: 32 at 0.1, 64 at 0.01].
    #[arg(long, requires = "noise_threshold", value_parser = clap::value_parser!(u32).range(2..))]
    min_spp: Option<u32>,
    /// AOVs beside the beauty: default, all, beauty (none) or a
    /// comma-separated list (emission, diffuse_direct, diffuse_indirect,
    /// specular_direct, specular_indirect, transmission, volume_direct,
    /// volume_indirect, albedo, N, P, Z, sample_count, variance,
    /// CryptoObject, CryptoMaterial, CryptoAsset) [default: the render products'
    /// RenderVars, else default].
    #[arg(long)]
    aovs: Option<AovSet>,
    /// One multi-channel EXR, or one file per AOV (OUT.<aov>.exr).
    #[arg(long, value_parser = super::choice::<AovFiles>(), default_value_t)]
    aov_files: AovFiles,
    /// EXR compression.
    #[arg(long, value_parser = super::choice::<Compression>(), default_value_t)]
    compression: Compression,
    /// Shutter interval OPEN,CLOSE in frames relative to the frame
    /// (default: the camera's shutter:open/close; 0,0 = no motion blur).
    #[arg(long, value_name = "OPEN,CLOSE", allow_hyphen_values = true)]
    shutter: Option<cirrus::motion::Shutter>,
    /// USD time code to export (USD input only).
    #[arg(long)]
    frame: Option<f64>,
    /// Render frames A-B[xSTEP] (USD time codes) one after the other, one
    /// export each; a run of `#` in -o becomes the frame number (out/shot.####.exr).
    #[arg(long, value_name = "A-B[xSTEP]", conflicts_with = "frame")]
    frames: Option<FrameRange>,
    /// Camera prim to render, e.g. /World/cam_side (USD input only; default:
    /// the render settings' camera, else the stage's first).
    #[arg(long, value_name = "PRIM_PATH")]
    camera: Option<String>,
    /// UsdRender.Settings prim whose products and vars to render (USD input
    /// only; default: the stage's renderSettingsPrimPath, else the only one).
    #[arg(long, value_name = "PRIM_PATH")]
    settings: Option<String>,
    /// Set for each frame of --frames: product names need a frame token.
    #[arg(skip)]
    sequence: bool,
    /// Subdivision level of meshes that do not author primvars:cirrus:subdivisionLevel.
    #[arg(long, default_value_t = cirrus::subdivision::DEFAULT_LEVEL)]
    subdiv_level: u32,
    #[command(flatten)]
    part: PartArgs,
    /// Render nothing when the output is complete (it exists, no checkpoint beside it).
    #[arg(long)]
    skip_existing: bool,
    /// Accepted for old scripts; outputs are always overwritten.
    #[arg(long = "force", hide = true)]
    _force: bool,
    /// Save the film state to OUT.checkpoint every this many seconds (it is
    /// always saved when SIGINT or SIGTERM stops the render).
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    checkpoint_every: Option<Duration>,
    /// Rewrite the PNG preview (OUT.png) every this many seconds while rendering.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    preview_every: Option<Duration>,
    /// Continue the render saved in OUT.checkpoint (same scene and settings;
    /// the result is bit-identical to an uninterrupted render).
    #[arg(long)]
    resume: bool,
    /// Refuse to start when the estimated peak memory exceeds this (e.g.
    /// 8G, 512M; default: the memory available to this process).
    #[arg(long, value_parser = memory::parse_bytes)]
    memory_limit: Option<u64>,
}

/// Parses `WIDTHxHEIGHT`.
pub(super) fn parse_resolution(s: &str) -> Result<UVec2, String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 1280x720"))?;
    let side = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&n| (1..=65536).contains(&n))
            .ok_or_else(|| format!("{s:?}: {v:?} is not a size in 1..=65536"))
    };
    Ok(UVec2::new(side(w)?, side(h)?))
}

/// Parses a positive, finite number of seconds (`--time`, `--checkpoint-every`,
/// `--preview-every`).
fn parse_seconds(s: &str) -> Result<Duration, String> {
    s.parse::<f64>()
        .ok()
        .filter(|t| *t > 0.0)
        .and_then(|t| Duration::try_from_secs_f64(t).ok())
        .ok_or_else(|| format!("{s:?}: must be a positive number of seconds"))
}

/// Parses `--noise-threshold`: a positive, finite relative error.
fn parse_noise_threshold(s: &str) -> Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|t| t.is_finite() && *t > 0.0)
        .ok_or_else(|| format!("{s:?}: must be a positive number, e.g. 0.05"))
}

/// Runs `cirrus render`: one frame, or each of `--frames` in turn.
pub fn run(args: RenderArgs) -> Result<()> {
    let signal = StopSignal::install().context("cannot install the SIGINT/SIGTERM handlers")?;
    let Some(range) = args.frames else {
        return render_frame(args, &signal);
    };
    let frames: Vec<i64> = range.frames().collect();
    if frames.len() > 1 && args.output.as_ref().is_some_and(|o| !has_frame_number(o)) {
        bail!("--frames: -o has no frame token for the frame number (e.g. out/shot.####.exr)");
    }
    if !cirrus::scene::is_usd(&args.scene) {
        bail!(
            "--frames needs a USD scene; {} is exported",
            args.scene.display()
        );
    }
    for (i, &frame) in frames.iter().enumerate() {
        log::info!("frame {frame} ({} of {})", i + 1, frames.len());
        let output = args.output.as_ref().map(|o| frame_output(o, Some(frame)));
        render_frame(
            RenderArgs {
                frame: Some(frame as f64),
                output,
                sequence: frames.len() > 1,
                ..args.clone()
            },
            &signal,
        )?;
    }
    Ok(())
}

/// Renders one frame: `args.frame` to `args.output`.
fn render_frame(args: RenderArgs, signal: &StopSignal) -> Result<()> {
    let budget = match (args.spp, args.time) {
        (_, Some(t)) => Budget::Time(t),
        (Some(0), _) => bail!("--spp 0: at least one sample per pixel"),
        (spp, None) => Budget::Samples(spp.unwrap_or(DEFAULT_SPP)),
    };
    if args.clamp.is_some_and(|c| c.is_nan() || c <= 0.0) {
        bail!("--clamp must be positive");
    }
    let mut settings = RenderSettings {
        budget,
        seed: args.seed,
        sampler: args.sampler,
        filter: args.filter,
        path: PathSettings {
            strategy: args.strategy,
            max_depth: args.max_depth,
            clamp: args.clamp,
            volume_estimator: args.volume_estimator,
            equiangular: !args.no_equiangular,
            camera_ray_transmittance: args.camera_ray_transmittance,
        },
        aovs: AovSet::default(),
        adaptive: args
            .noise_threshold
            .map(|t| AdaptiveSampling::new(t, args.min_spp)),
    };
    let film_output = args.output.as_deref().is_some_and(is_film_output);
    let part = args.part.request();
    if film_output && args.preview_every.is_some() {
        bail!("--preview-every: a film state (-o *.film) has no preview; write an EXR");
    }
    if settings.adaptive.is_some() && part.sample_range.is_some() {
        bail!("--noise-threshold cannot be split by --sample-range: which pixels stop depends on all their samples; split the frame by --tile or --crop instead");
    }
    if part.is_part() && !film_output {
        bail!("--tile, --crop and --sample-range render a part of a frame: write it with -o PART.film and join the parts with cirrus merge");
    }
    let frame_spp = match budget {
        Budget::Samples(n) => n,
        Budget::Time(_) if film_output => bail!("a film state (-o *.film) needs --spp, not --time"),
        Budget::Time(_) => 0,
    };
    let samples = part.samples(frame_spp)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n.into());
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let start = Instant::now();
    let options = cirrus::scene::OpenOptions {
        export: cirrus::scene::ExportOptions {
            frame: args.frame,
            camera: args.camera.as_deref(),
            settings: args.settings.as_deref(),
            shutter: args.shutter,
        },
        refinement: cirrus::scene::Refinement::Level(args.subdiv_level),
    };
    let scene = memory::open(&args.scene, &options, args.memory_limit)?;
    let flags = OutputFlags {
        output: args.output.as_deref(),
        aovs: args.aovs.as_ref(),
        resolution: args.res.is_some(),
        camera: args.camera.is_some(),
        sequence: args.sequence,
    };
    let m = &scene.manifest;
    let plan = plan_outputs(&m.render, m.source.time_code, &flags)?;
    settings.aovs = plan.aovs.clone();
    let Some(files) = plan.claim(args.aov_files, args.skip_existing, args.resume)? else {
        let first = plan.outputs[0].path.display();
        println!("{first} is complete; --skip-existing renders nothing");
        return Ok(());
    };
    let resolution = render_state::resolution_for(&scene, args.res);
    let frame = plan.frame_window(resolution)?;
    let window = part.window(frame, resolution)?;
    let needs = pool.install(|| memory::estimate(&scene, window.size, &settings.aovs))?;
    memory::check(&needs, args.memory_limit)?;
    log::debug!("estimated peak memory: {needs}");
    let options = StateOptions {
        majorant: args.majorant,
        volume_lights: args.volume_light_sampling,
        shutter: args.shutter,
    };
    let state = pool.install(|| RenderState::build(&scene, args.res, options))?;
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
    let resumed = if args.resume {
        let resumed = resume(&files[0].checkpoint, &identity, &fresh, &settings)?;
        log::info!(
            "resuming {} at {} spp",
            files[0].checkpoint.display(),
            resumed.progress.samples_per_pixel()
        );
        resumed
    } else {
        fresh
    };
    log::info!(
        "{}: ready in {:.2} s, {}x{}",
        args.scene.display(),
        start.elapsed().as_secs_f64(),
        window.size.x,
        window.size.y
    );
    let progress = cirrus::progress_bar::ProgressDisplay::new();
    let save = |s: &Snapshot| {
        if let Err(e) = write_snapshot(&files[0].checkpoint, &identity.named(&state, &s.film), s) {
            log::warn!("checkpoint not saved: {e:#}");
        }
    };
    let preview = |s: &Snapshot| {
        if let Err(e) = write_film_preview(&preview_path(files[0].output()), &s.film) {
            log::warn!("preview not written: {e}");
        }
    };
    let periodic: Vec<Periodic> = [
        (args.checkpoint_every, &save as &(dyn Fn(&Snapshot) + Sync)),
        (args.preview_every, &preview),
    ]
    .into_iter()
    .filter_map(|(every, save)| every.map(|every| Periodic { every, save }))
    .collect();
    let control = RenderControl {
        progress: &|f| progress.update(f),
        stop: &|| signal.requested(),
        periodic: &periodic,
    };
    let (end, stats) =
        pool.install(|| integrator::render_from(&state, &settings, resumed, &control));
    progress.finish();
    if !stats.complete {
        let signal = signal.signal().unwrap_or(signal_hook::consts::SIGINT);
        let spp = end.progress.samples_per_pixel();
        let message = if end.progress.is_empty() {
            "interrupted before the first sample; nothing written".into()
        } else {
            let identity = identity.named(&state, &end.film);
            save_interrupted(&files[0], &identity, &end, &stats, args.compression)
                .context("interrupted, and the checkpoint could not be saved")?;
            let (c, p) = (files[0].checkpoint.display(), files[0].partial.display());
            format!("interrupted at {spp} spp: saved {c} and {p}; run the same command with --resume to finish")
        };
        return Err(Interrupted { signal, message }.into());
    }
    let identity = identity.named(&state, &end.film);
    let mut written = Vec::new();
    for (files, product) in files.iter().zip(&plan.outputs) {
        let format = ImageFormat {
            aov_files: args.aov_files,
            compression: args.compression,
            layers: &product.layers,
        };
        written.extend(write_finished(files, &identity, &end, &stats, format)?);
    }
    report(&written, &stats);
    Ok(())
}

/// Prints what was written and how the render went; warns about dropped samples.
fn report(written: &[PathBuf], stats: &RenderStats) {
    stats.log_summary();
    let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    println!("wrote {}", names.join(" and "));
}

/// `on` or `off` as a flag's value.
fn on_off(value: &str) -> Result<bool, String> {
    match value {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("'{value}' is neither on nor off")),
    }
}
