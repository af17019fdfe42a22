//! The `cirrus` command line: subcommands, logging set-up, and the mapping of
//! errors to exit codes. `anyhow` lives here only; the library uses typed errors.

mod aovs;
mod bench;
mod converge;
mod farm;
mod info;
mod merge;
mod render;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::builder::TypedValueParser as _;
use clap::{Parser, Subcommand};

use cirrus::choice::Choice;

/// Cirrus: a production path tracer for USD scenes and OpenVDB volumes.
#[derive(Parser, Debug)]
#[command(name = "cirrus", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print what a file holds: for a scene (an exported folder, its
    /// scene.json, or a USD file, exported into the cache first) its counts;
    /// for a .vdb, its grid table.
    Info {
        /// The file or scene folder to describe.
        file: PathBuf,
    },
    /// Export a USD file to a Cirrus scene folder (scene.json + scene.bin).
    Export(ExportArgs),
    /// Render a scene to an EXR (and a PNG preview beside it).
    Render(render::RenderArgs),
    /// Join film states of parts of one frame (`cirrus render --tile/--crop/
    /// --sample-range -o PART.film`) into its EXR, checking that they fit.
    Merge(merge::MergeArgs),
    /// Tile every layer of an EXR (beauty, AOVs, Cryptomattes) into one PNG
    /// contact sheet and list the layers.
    Aovs(aovs::AovsArgs),
    /// Split frames over a Slurm cluster: part renders and their merges.
    #[command(subcommand)]
    Farm(farm::Farm),
    /// Run a benchmark and print a Markdown table (machine, date, medians).
    #[command(subcommand)]
    Bench(bench::Bench),
    /// Convergence study: error against a reference at 1, 2, 4, ... spp per
    /// scene, method and seed, as CSVs and log-log SVG charts.
    Converge(converge::ConvergeArgs),
}

/// `cirrus export` arguments.
#[derive(clap::Args, Debug)]
struct ExportArgs {
    /// The USD file (.usd, .usda, .usdc, .usdz).
    input: PathBuf,
    /// The scene folder to write; replaced if it exists.
    #[arg(short, long)]
    output: PathBuf,
    /// USD time code to export (default: the stage's default time).
    #[arg(long)]
    frame: Option<f64>,
    /// Camera prim to export (default: the render settings' camera, else the first).
    #[arg(long)]
    camera: Option<String>,
    /// Shutter OPEN,CLOSE (frames) to key motion over (default: the camera's).
    #[arg(long, value_name = "OPEN,CLOSE", allow_hyphen_values = true)]
    shutter: Option<cirrus::motion::Shutter>,
    /// UsdRender.Settings prim to export (default: renderSettingsPrimPath, else the only one).
    #[arg(long)]
    settings: Option<String>,
}

/// Parses the command line, runs it, and returns the process exit code:
/// 0 on success, 1 on any error (printed with its full cause chain), 2 on bad usage
/// (`cirrus render` stopped by a signal exits with 128 + its number).
pub fn run() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .format_timestamp(None)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info { file } => info::run(&file),
        Command::Export(args) => export(args),
        Command::Render(args) => render::run(args),
        Command::Merge(args) => merge::merge(args),
        Command::Farm(farm::Farm::Submit(args)) => farm::submit(args),
        Command::Aovs(args) => aovs::run(args),
        Command::Bench(b) => bench::run(b),
        Command::Converge(args) => converge::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// A clap value parser offering `T`'s names (one table per enum, in the
/// library: [`Choice`]), so the library's types carry no parser.
fn choice<T: Choice + Send + Sync>() -> impl clap::builder::TypedValueParser<Value = T> {
    clap::builder::PossibleValuesParser::new(T::NAMES.iter().map(|&(_, name)| name))
        .map(|name| T::from_name(&name).expect("only offered names reach here"))
}

/// `cirrus export`: exports and checks the scene ([`cirrus::job::export`]),
/// then prints its counts.
fn export(args: ExportArgs) -> Result<()> {
    let options = cirrus::scene::ExportOptions {
        frame: args.frame,
        camera: args.camera.as_deref(),
        settings: args.settings.as_deref(),
        shutter: args.shutter,
    };
    let scene = cirrus::job::export(&args.input, &args.output, &options)?;
    let m = &scene.manifest;
    println!(
        "{}: {} prototype(s), {} instance(s), {} warning(s)",
        args.output.display(),
        m.prototypes.len(),
        m.instances.count,
        m.warnings.len()
    );
    Ok(())
}
