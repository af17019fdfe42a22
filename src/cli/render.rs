//! `cirrus render SCENE -o OUT.exr`: the renderer's command-line contract.
//! SCENE is a USD file (exported through the cache first) or an exported
//! scene; the beauty (linear, float RGBA) and the chosen AOVs go to OUT.exr
//! (or one file per AOV) and a tone-mapped preview beside it (OUT.png).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use glam::UVec2;
use indicatif::{ProgressBar, ProgressStyle};

use super::checkpoint::{self, Fingerprint, Interrupted, OutputFiles, StopSignal};
use crate::integrator::{
    self, Budget, Checkpointing, FilmState, PathSettings, RenderControl, RenderSettings,
    RenderStats, Strategy, VolumeEstimator,
};
use crate::memory;
use crate::output::aov::{Aov, AovSet};
use crate::output::cryptomatte::CryptoLayer;
use crate::output::film::{Film, Layer};
use crate::output::filter::FilterKind;
use crate::output::{write_exr, write_preview, Channel, Compression, ExrImage, PixelType};
use crate::render_state::{self, RenderState};
use crate::sampling::SamplerKind;
use crate::scene::Scene;
use crate::volumes::MajorantKind;

/// Samples per pixel when neither `--spp` nor `--time` is given.
const DEFAULT_SPP: u32 = 64;

/// `cirrus render` arguments.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// A USD file (.usd/.usda/.usdc/.usdz), a scene folder, or its scene.json.
    scene: PathBuf,
    /// The EXR to write; a tone-mapped PNG preview is written beside it.
    #[arg(short, long)]
    output: PathBuf,
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
    #[arg(long, value_enum, default_value_t = SamplerKind::Sobol)]
    sampler: SamplerKind,
    /// Light transport estimator: MIS of light and BSDF sampling, or one alone.
    #[arg(long, value_enum, default_value_t)]
    strategy: Strategy,
    /// Most bounces per path.
    #[arg(long, default_value_t = 16)]
    max_depth: u32,
    /// Clamp each sample's RGB components to this radiance (biased; off by default).
    #[arg(long)]
    clamp: Option<f32>,
    /// Pixel filter.
    #[arg(long, value_enum, default_value_t)]
    filter: FilterKind,
    /// Majorants of volume extinction: per 8^3-voxel cell (grid) or one per volume (global).
    #[arg(long, value_enum, default_value_t = MajorantKind::Grid)]
    majorant: MajorantKind,
    /// Volume estimator: null-scattering MIS (default) or directional MIS
    /// with ratio, residual-ratio or track-length shadow transmittance.
    #[arg(long, value_enum, default_value_t = VolumeEstimator::NullScatteringMis)]
    volume_estimator: VolumeEstimator,
    /// Turn off equiangular sampling of sphere and point lights in media.
    #[arg(long)]
    no_equiangular: bool,
    /// AOVs beside the beauty: default, all, beauty (none) or a
    /// comma-separated list (emission, diffuse_direct, diffuse_indirect,
    /// specular_direct, specular_indirect, transmission, volume_direct,
    /// volume_indirect, albedo, N, P, Z, sample_count, variance,
    /// CryptoObject, CryptoMaterial).
    #[arg(long, default_value = "default")]
    aovs: AovSet,
    /// One multi-channel EXR, or one file per AOV (OUT.<aov>.exr).
    #[arg(long, value_enum, default_value_t)]
    aov_files: AovFiles,
    /// EXR compression.
    #[arg(long, value_enum, default_value_t)]
    compression: Compression,
    /// USD time code to export (USD input only).
    #[arg(long)]
    frame: Option<f64>,
    /// Overwrite existing outputs (and drop an unfinished render's checkpoint).
    #[arg(long)]
    force: bool,
    /// Save the film state to OUT.checkpoint every this many seconds (it is
    /// always saved when SIGINT or SIGTERM stops the render).
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    checkpoint_every: Option<Duration>,
    /// Continue the render saved in OUT.checkpoint (same scene and settings;
    /// the result is bit-identical to an uninterrupted render).
    #[arg(long)]
    resume: bool,
    /// Refuse to start when the estimated peak memory exceeds this (e.g.
    /// 8G, 512M; default: the memory available to this process).
    #[arg(long, value_parser = memory::parse_bytes)]
    memory_limit: Option<u64>,
}

/// The Cryptomatte layers chosen in `aovs`, named by the scene's Mesh and
/// Material prim paths (indexed like the film's object and material ids).
pub(super) fn cryptomatte_layers(scene: &Scene, aovs: &AovSet) -> [Option<CryptoLayer>; 2] {
    let m = &scene.manifest;
    let layer = |aov: Aov, names: Vec<String>| {
        aovs.contains(aov)
            .then(|| CryptoLayer::new(aov.name(), names))
    };
    [
        layer(
            Aov::CryptoObject,
            m.meshes.iter().map(|x| x.path.clone()).collect(),
        ),
        layer(
            Aov::CryptoMaterial,
            m.materials.iter().map(|x| x.path.clone()).collect(),
        ),
    ]
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

/// Parses a positive, finite number of seconds (`--time`, `--checkpoint-every`).
fn parse_seconds(s: &str) -> Result<Duration, String> {
    s.parse::<f64>()
        .ok()
        .filter(|t| *t > 0.0)
        .and_then(|t| Duration::try_from_secs_f64(t).ok())
        .ok_or_else(|| format!("{s:?}: must be a positive number of seconds"))
}

/// Runs `cirrus render`.
pub fn run(args: RenderArgs) -> Result<()> {
    let budget = match (args.spp, args.time) {
        (_, Some(t)) => Budget::Time(t),
        (Some(0), _) => bail!("--spp 0: at least one sample per pixel"),
        (spp, None) => Budget::Samples(spp.unwrap_or(DEFAULT_SPP)),
    };
    if args.clamp.is_some_and(|c| c.is_nan() || c <= 0.0) {
        bail!("--clamp must be positive");
    }
    let settings = RenderSettings {
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
        },
        aovs: args.aovs,
    };
    let files = OutputFiles::new(&args.output, args.aov_files, &settings);
    files.claim(args.force, args.resume)?;
    let signal = StopSignal::install().context("cannot install the SIGINT/SIGTERM handlers")?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n.into());
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let start = Instant::now();
    let scene = super::load_scene(&args.scene, args.frame)?;
    let resolution = render_state::resolution_for(&scene, args.res);
    let needs = pool.install(|| memory::estimate(&scene, resolution, &settings.aovs))?;
    memory::check(&needs, args.memory_limit)?;
    log::debug!("estimated peak memory: {needs}");
    let state = pool.install(|| RenderState::build(&scene, args.res, args.majorant))?;
    let crypto = cryptomatte_layers(&scene, &settings.aovs);
    let fingerprint = Fingerprint::new(&scene, state.resolution, &settings, args.majorant)?;
    drop(scene);
    let resumed = if args.resume {
        let resumed =
            checkpoint::load(&files.checkpoint, &fingerprint, state.resolution, &settings)?;
        log::info!(
            "resuming {} at {} spp",
            files.checkpoint.display(),
            resumed.progress.samples_per_pixel()
        );
        resumed
    } else {
        FilmState::new(state.resolution, settings.aovs.clone())
    };
    log::info!(
        "{}: ready in {:.2} s, {}x{}",
        args.scene.display(),
        start.elapsed().as_secs_f64(),
        state.resolution.x,
        state.resolution.y
    );
    let progress = Progress::new();
    let save = |s: &FilmState| {
        if let Err(e) = checkpoint::save(&files.checkpoint, s, &fingerprint) {
            log::warn!("checkpoint not saved: {e:#}");
        }
    };
    let control = RenderControl {
        progress: &|f| progress.update(f),
        stop: &|| signal.requested(),
        checkpoint: args
            .checkpoint_every
            .map(|every| Checkpointing { every, save: &save }),
    };
    let (end, stats) =
        pool.install(|| integrator::render_from(&state, &settings, resumed, &control));
    progress.finish();
    let header = Header {
        state: &state,
        settings: &settings,
        stats: &stats,
        compression: args.compression,
    };
    if !stats.complete {
        return Err(interrupted(
            &files,
            &end,
            &fingerprint,
            &crypto,
            &header,
            &signal,
        ));
    }
    write_film(&args.output, args.aov_files, &end.film, &crypto, &header)?;
    let rgb = end.film.rgb();
    let r = state.resolution;
    let preview = args.output.with_extension("png");
    write_preview(&preview, r.x, r.y, &rgb)?;
    files.finish()?;
    report(&args.output, &preview, &stats);
    Ok(())
}

/// After a stop by signal: saves the checkpoint and a partial EXR (when any
/// sample was taken) and returns the [`Interrupted`] error saying how to resume.
fn interrupted(
    files: &OutputFiles,
    end: &FilmState,
    fingerprint: &Fingerprint,
    crypto: &[Option<CryptoLayer>; 2],
    header: &Header,
    signal: &StopSignal,
) -> anyhow::Error {
    let signal = signal.signal().unwrap_or(signal_hook::consts::SIGINT);
    if end.progress.tile_samples.iter().all(|&s| s == 0) {
        return Interrupted {
            signal,
            message: "interrupted before the first sample; nothing written".into(),
        }
        .into();
    }
    let saved = checkpoint::save(&files.checkpoint, end, fingerprint)
        .and_then(|()| write_film(&files.partial, AovFiles::Single, &end.film, crypto, header));
    if let Err(e) = saved {
        return e.context("interrupted, and the checkpoint could not be saved");
    }
    Interrupted {
        signal,
        message: format!(
            "interrupted at {} spp: saved {} and {}; run the same command with --resume to finish",
            end.progress.samples_per_pixel(),
            files.checkpoint.display(),
            files.partial.display()
        ),
    }
    .into()
}

/// How AOVs are split over files (`--aov-files`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum AovFiles {
    /// One multi-channel EXR: beauty in the base layer, AOVs as layers.
    #[default]
    Single,
    /// The beauty in OUT.exr and each AOV in OUT.<aov>.exr.
    Separate,
}

/// Writes the film: the beauty layer and every chosen AOV, in one EXR or
/// one per AOV, each with the render's metadata (and a Cryptomatte's own).
pub(super) fn write_film(
    output: &Path,
    files: AovFiles,
    film: &Film,
    crypto: &[Option<CryptoLayer>; 2],
    header: &Header,
) -> Result<()> {
    let crypto_of = |aov| match aov {
        Aov::CryptoObject => crypto[0].as_ref(),
        Aov::CryptoMaterial => crypto[1].as_ref(),
        _ => None,
    };
    let layers: Vec<(Aov, Layer)> = film
        .aov_set()
        .aovs()
        .iter()
        .map(|&aov| (aov, film.aov_layer(aov, crypto_of(aov))))
        .collect();
    let beauty = film.beauty_layer();
    match files {
        AovFiles::Single => {
            let mut all = vec![&beauty];
            all.extend(layers.iter().map(|(_, l)| l));
            let crypto_metadata = crypto.iter().flatten().flat_map(CryptoLayer::metadata);
            write_layers(output, &all, crypto_metadata.collect(), header)
        }
        AovFiles::Separate => {
            write_layers(output, &[&beauty], Vec::new(), header)?;
            for (aov, layer) in &layers {
                let path = output.with_extension(format!("{}.exr", aov.name()));
                let metadata = crypto_of(*aov).map(CryptoLayer::metadata);
                write_layers(&path, &[layer], metadata.unwrap_or_default(), header)?;
            }
            Ok(())
        }
    }
}

/// What every EXR of a render carries in its header.
pub(super) struct Header<'a> {
    /// The camera, for `worldToCamera` and `worldToNDC`.
    pub state: &'a RenderState,
    /// How it was rendered.
    pub settings: &'a RenderSettings,
    /// What the render did.
    pub stats: &'a RenderStats,
    /// EXR compression.
    pub compression: Compression,
}

/// Writes `layers` (interleaved into one image) with `strings` and the
/// header's metadata: `software`, the camera matrices (Imath's row-vector
/// layout, which is glam's column-major array of the column-vector matrix)
/// and the settings as `cirrus/*` strings.
fn write_layers(
    path: &Path,
    layers: &[&Layer],
    mut strings: Vec<(String, String)>,
    header: &Header,
) -> Result<()> {
    let r = header.state.resolution;
    let pixel_count = r.x as usize * r.y as usize;
    let channels: Vec<Channel> = layers.iter().flat_map(|l| l.channels.clone()).collect();
    let mut pixels = Vec::with_capacity(channels.len() * pixel_count);
    for i in 0..pixel_count {
        for layer in layers {
            let n = layer.channels.len();
            pixels.extend_from_slice(&layer.pixels[i * n..(i + 1) * n]);
        }
    }
    let (settings, stats) = (header.settings, header.stats);
    let attribute = |k: &str, v: String| (format!("cirrus/{k}"), v);
    strings.extend([
        (
            "software".to_string(),
            format!("Cirrus {}", env!("CARGO_PKG_VERSION")),
        ),
        attribute("version", env!("CARGO_PKG_VERSION").into()),
        attribute("spp", stats.samples_per_pixel.to_string()),
        attribute("complete", stats.complete.to_string()),
        attribute(
            "render_seconds",
            format!("{:.3}", stats.elapsed.as_secs_f64()),
        ),
        attribute("seed", settings.seed.to_string()),
        attribute("sampler", format!("{:?}", settings.sampler)),
        attribute("strategy", format!("{:?}", settings.path.strategy)),
        attribute("max_depth", settings.path.max_depth.to_string()),
        attribute(
            "volume_estimator",
            format!("{:?}", settings.path.volume_estimator),
        ),
        attribute("equiangular", settings.path.equiangular.to_string()),
        attribute("aovs", settings.aovs.to_string()),
    ]);
    let camera = &header.state.camera;
    write_exr(
        path,
        &ExrImage {
            width: r.x,
            height: r.y,
            channels,
            pixels: &pixels,
            compression: header.compression,
            strings,
            matrices: vec![
                (
                    "worldToCamera".into(),
                    camera.world_to_camera().to_cols_array(),
                ),
                ("worldToNDC".into(), camera.world_to_ndc().to_cols_array()),
            ],
        },
    )?;
    Ok(())
}

/// Writes a beauty-only EXR (float R, G, B) with the render's metadata: the
/// benchmarks' references.
pub(super) fn write_beauty(path: &Path, rgb: &[f32], header: &Header) -> Result<()> {
    let layer = Layer {
        channels: ["R", "G", "B"]
            .map(|name| Channel {
                name: name.into(),
                pixel_type: PixelType::Float,
            })
            .to_vec(),
        pixels: rgb.to_vec(),
    };
    write_layers(path, &[&layer], Vec::new(), header)
}

/// Prints what was written and how the render went; warns about dropped samples.
fn report(exr: &Path, preview: &Path, stats: &RenderStats) {
    let secs = stats.elapsed.as_secs_f64();
    let rays = stats.rays.closest + stats.rays.shadow;
    log::info!(
        "{} spp in {secs:.2} s: {:.2} M rays/s ({} camera, {} closest-hit, {} shadow)",
        stats.samples_per_pixel,
        rays as f64 / secs.max(1e-9) / 1e6,
        stats.rays.camera,
        stats.rays.closest,
        stats.rays.shadow,
    );
    let t = &stats.tracking;
    if t.density_lookups > 0 {
        let collisions = (t.real_collisions + t.null_collisions).max(1);
        log::info!(
            "volumes: {:.1} density lookups per camera ray; {:.0}% of collisions null",
            t.density_lookups as f64 / stats.rays.camera.max(1) as f64,
            100.0 * t.null_collisions as f64 / collisions as f64,
        );
    }
    if t.majorant_violations > 0 {
        log::warn!(
            "{} density lookups exceeded their majorant: delta tracking is biased there",
            t.majorant_violations
        );
    }
    if let Some((pixel, sample)) = stats.non_finite.first {
        log::warn!(
            "{} NaN/Inf sample(s) dropped; the first at pixel ({}, {}), sample {sample}",
            stats.non_finite.count,
            pixel.x,
            pixel.y
        );
    }
    println!("wrote {} and {}", exr.display(), preview.display());
}

/// A progress bar with ETA on a terminal; on anything else, a log line
/// every 10%.
struct Progress {
    bar: Option<ProgressBar>,
    logged: Mutex<u32>,
}

impl Progress {
    fn new() -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(1000);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise} ETA {eta}")
                    .expect("valid template"),
            );
            bar
        });
        Self {
            bar,
            logged: Mutex::new(0),
        }
    }

    fn update(&self, fraction: f64) {
        let fraction = fraction.clamp(0.0, 1.0);
        match &self.bar {
            Some(bar) => bar.set_position((fraction * 1000.0) as u64),
            None => {
                let tenth = (fraction * 10.0) as u32;
                let mut logged = self.logged.lock().expect("progress lock");
                if tenth > *logged {
                    *logged = tenth;
                    log::info!("{}% rendered", tenth * 10);
                }
            }
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
