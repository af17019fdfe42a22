//! `cirrus converge`: the convergence study's flags, mapped to one call
//! into [`cirrus::lab`].

use std::path::PathBuf;

use anyhow::Result;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use glam::UVec2;

use cirrus::job::parse_resolution;
use cirrus::lab::{self, parse_method, ConvergeOptions, Method, Peer};

/// `cirrus converge` arguments.
#[derive(clap::Args, Debug)]
pub struct ConvergeArgs {
    /// Scenes (USD or exported); default: scenes/bench/smoke.usda.
    scenes: Vec<PathBuf>,
    /// Comma-separated methods: default, sampler-independent, strategy-bsdf,
    /// strategy-nee, majorant-global, majorant-adaptive, estimator-ratio,
    /// estimator-residual-ratio, estimator-track-length, no-equiangular,
    /// camera-ray-transmittance
    /// [all that apply to each scene: the volume ones where it has volumes,
    /// no-equiangular where it also has lights that equiangular sampling
    /// targets].
    #[arg(long, value_delimiter = ',', value_parser = parse_method)]
    methods: Vec<Method>,
    /// Largest budget: renders at 1, 2, 4, ... spp up to this (itself last
    /// when not a power of two).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp_max: u32,
    /// Seeds per budget (at least 2: the bias interval needs a spread).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(2..))]
    seeds: u32,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "160x90", value_parser = parse_resolution)]
    res: UVec2,
    /// Samples per pixel of each scene's reference (default method, kept in
    /// --out by scene, size and spp: delete it after changing the renderer).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..))]
    reference_spp: u32,
    /// Worker threads (Cirrus' and each peer's).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Comma-separated peer renderers, rendered at the same budgets and
    /// seeds through scenes/peers/render_peer.py (installed by
    /// scenes/peers/install [--cycles]); each also renders its own
    /// reference.
    #[arg(long, value_delimiter = ',', value_parser = peer_parser())]
    peers: Vec<Peer>,
    /// Samples per pixel of each peer's own reference [default:
    /// --reference-spp].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    peer_reference_spp: Option<u32>,
    /// Folder for the CSVs, the charts and the references.
    #[arg(long, default_value = "out/converge")]
    out: PathBuf,
}

/// `--peers` values: every [`Peer`] by name, described in `--help`.
fn peer_parser() -> impl TypedValueParser<Value = Peer> {
    let values = Peer::ALL.map(|p| PossibleValue::new(p.name()).help(p.about()));
    PossibleValuesParser::new(values).map(|name| name.parse::<Peer>().expect("a peer's name"))
}

/// Runs the study: its flags as the lab's options.
pub fn run(args: ConvergeArgs) -> Result<()> {
    lab::converge(&ConvergeOptions {
        scenes: args.scenes,
        methods: args.methods,
        spp_max: args.spp_max,
        seeds: args.seeds,
        resolution: args.res,
        reference_spp: args.reference_spp,
        threads: args.threads,
        peers: args.peers,
        peer_reference_spp: args.peer_reference_spp,
        out: args.out,
    })?;
    Ok(())
}
