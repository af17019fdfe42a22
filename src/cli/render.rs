//! `cirrus render SCENE -o OUT.exr`: the renderer's command-line contract.
//! SCENE is a USD file (exported through the cache first) or an exported
//! scene; the beauty (linear, float RGBA) and the chosen AOVs go to OUT.exr
//! (or one file per AOV) and a tone-mapped preview beside it (OUT.png).

use std::ops::Range;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use glam::UVec2;

use cirrus::film::{AdaptiveSampling, AovSet, FilterKind};
use cirrus::image::Compression;
use cirrus::integrator::{PathSettings, Strategy, VolumeEstimator, DEFAULT_MAX_DEPTH};
use cirrus::job::{
    self, FrameOutcome, FrameRange, JobControl, JobError, PartRequest, RenderJob, StopSignal,
};
use cirrus::memory;
use cirrus::output::AovFiles;
use cirrus::sampling::SamplerKind;
use cirrus::volumes::majorant::MajorantKind;

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
    #[arg(long, value_parser = job::parse_seconds)]
    time: Option<Duration>,
    /// Image size WIDTHxHEIGHT (default: the stage's render settings, else 960 wide).
    #[arg(long, value_parser = job::parse_resolution)]
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
    #[arg(long, default_value = "on", value_parser = job::parse_on_off, value_name = "on|off", action = clap::ArgAction::Set)]
    volume_light_sampling: bool,
    /// Camera rays see what lies behind media through a ratio-tracking
    /// transmittance estimate, real scattering still sampled by delta
    /// tracking: on, or off (default: delta tracking's 0-or-1 survival,
    /// which measured level or better at equal time on the benchmark
    /// scenes; docs/volumes.md). Both unbiased.
    #[arg(long, default_value = "off", value_parser = job::parse_on_off, value_name = "on|off", action = clap::ArgAction::Set)]
    camera_ray_transmittance: bool,
    /// Adaptive sampling: a pixel stops once its relative noise estimate is
    /// under this (e.g. 0.05), checked between passes; --spp stays the cap.
    /// Off by default (it is slightly biased: docs/rendering.md).
    #[arg(long, value_name = "T", value_parser = job::parse_noise_threshold, allow_hyphen_values = true)]
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
    /// Subdivision level of meshes that do not author primvars:cirrus:subdivisionLevel.
    #[arg(long, default_value_t = cirrus::subdivision::DEFAULT_LEVEL)]
    subdiv_level: u32,
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
    /// Render nothing when the output is complete (it exists, no checkpoint beside it).
    #[arg(long)]
    skip_existing: bool,
    /// Accepted for old scripts; outputs are always overwritten.
    #[arg(long = "force", hide = true)]
    _force: bool,
    /// Save the film state to OUT.checkpoint every this many seconds (it is
    /// always saved when SIGINT or SIGTERM stops the render).
    #[arg(long, value_name = "SECONDS", value_parser = job::parse_seconds)]
    checkpoint_every: Option<Duration>,
    /// Rewrite the PNG preview (OUT.png) every this many seconds while rendering.
    #[arg(long, value_name = "SECONDS", value_parser = job::parse_seconds)]
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

/// Runs `cirrus render`: the flags as a [`RenderJob`], run until done or
/// stopped by SIGINT or SIGTERM ([`StopSignal`]; the process then exits with
/// 128 + the signal number); prints what each frame wrote.
pub fn run(args: RenderArgs) -> Result<()> {
    let signal = StopSignal::install().context("cannot install the SIGINT/SIGTERM handlers")?;
    let done = |outcome: &FrameOutcome| match outcome {
        FrameOutcome::Complete(output) => {
            println!(
                "{} is complete; --skip-existing renders nothing",
                output.display()
            )
        }
        FrameOutcome::Written(files) => {
            let names: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
            println!("wrote {}", names.join(" and "));
        }
    };
    let control = JobControl {
        stop: &|| signal.requested(),
        done: &done,
    };
    match job::render(&args.job(), &control) {
        Err(JobError::Interrupted(message)) => {
            // Stopped by a signal, its checkpoint saved: the exit code a
            // shell reports for it.
            eprintln!("{message}");
            std::process::exit(128 + signal.signal())
        }
        result => Ok(result?),
    }
}

impl RenderArgs {
    /// The job these flags describe.
    fn job(self) -> RenderJob {
        RenderJob {
            scene: self.scene,
            output: self.output,
            spp: self.spp,
            time: self.time,
            resolution: self.res,
            seed: self.seed,
            threads: self.threads,
            sampler: self.sampler,
            filter: self.filter,
            path: PathSettings {
                strategy: self.strategy,
                max_depth: self.max_depth,
                clamp: self.clamp,
                volume_estimator: self.volume_estimator,
                equiangular: !self.no_equiangular,
                camera_ray_transmittance: self.camera_ray_transmittance,
            },
            adaptive: (self.noise_threshold).map(|t| AdaptiveSampling::new(t, self.min_spp)),
            majorant: self.majorant,
            volume_light_sampling: self.volume_light_sampling,
            aovs: self.aovs,
            aov_files: self.aov_files,
            compression: self.compression,
            shutter: self.shutter,
            frame: self.frame,
            frames: self.frames,
            camera: self.camera,
            settings: self.settings,
            subdiv_level: self.subdiv_level,
            part: PartRequest {
                tile: self.tile,
                crop: self.crop,
                sample_range: self.sample_range,
            },
            skip_existing: self.skip_existing,
            checkpoint_every: self.checkpoint_every,
            preview_every: self.preview_every,
            resume: self.resume,
            memory_limit: self.memory_limit,
        }
    }
}
