//! `cirrus bench ...`: the benchmarks' flags, each mapped to one call into
//! [`cirrus::lab`], which runs it and prints its Markdown table.

use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;

use cirrus::job::parse_resolution;
use cirrus::lab::{self, EqualTimeBench, EqualTimeDefaults};

#[derive(Subcommand, Debug)]
pub enum Bench {
    /// AOV cost: render time with the default AOV set against the beauty
    /// alone, EXR write time and file size.
    Aovs {
        /// Scenes (USD or exported); default: scenes/bench/smoke.usda.
        scenes: Vec<PathBuf>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "640x360", value_parser = parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of every render.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Renders per AOV set; the table shows medians.
        #[arg(long, default_value_t = 5)]
        repeats: u32,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Folder for the written EXRs.
        #[arg(long, default_value = "out/bench-aovs")]
        out: PathBuf,
    },
    /// Sparse grid layout: load time, memory next to OpenVDB's own tree, and
    /// single-thread trilinear lookups per second (random points, independent
    /// ray marches, and tiles of neighbouring ray marches).
    Vdb {
        /// VDB files to measure.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Float grid to read from each file.
        #[arg(long, default_value = "density")]
        grid: String,
        /// Timed repeats; the table shows medians.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Lookups per timed repeat.
        #[arg(long, default_value_t = 4_000_000)]
        lookups: usize,
    },
    /// Instancing ingest: export, load and BVH build time and memory of a
    /// PointInstancer stage, beyond a 1-instance baseline.
    Instances {
        /// PointInstancer instances in the measured stage.
        #[arg(long, default_value_t = 1_000_000)]
        instances: usize,
        /// Approximate triangles of the prototype sphere.
        #[arg(long, default_value_t = 100_000)]
        triangles: usize,
        /// Timed repeats of load and build; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
    /// Points and curves: build time, memory and ray rates of a million
    /// spheres and of 100k cubic hairs.
    PointsCurves {
        /// Points (spheres) of the first stage.
        #[arg(long, default_value_t = 1_000_000)]
        points: usize,
        /// Cubic bspline hairs of the second stage.
        #[arg(long, default_value_t = 100_000)]
        curves: usize,
        /// Random rays per rate.
        #[arg(long, default_value_t = 1_000_000)]
        rays: usize,
        /// Timed repeats; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
    /// Subdivision at load: refinement time and memory, samples/s of cages and refined surfaces.
    Subdivision {
        /// Scenes (USD or exported).
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Subdivision level.
        #[arg(long, default_value_t = cirrus::subdivision::DEFAULT_LEVEL)]
        level: u32,
    },
    /// Rendering core: camera-ray, path-ray and sample rates, and the
    /// equal-time MSE of BSDF-only, NEE-only and MIS with Sobol and
    /// independent samples against a high-spp reference (table + SVG chart).
    Render {
        /// Scenes (USD or exported); docs/benchmarks.md gives the
        /// StandardShaderBall and the intent-vfx layout from ../shared/assets.
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        #[command(flatten)]
        equal_time: EqualTimeArgs,
        /// Instead: the seconds adaptive sampling (--noise-threshold) takes
        /// to reach uniform sampling's relMSE at each budget.
        #[arg(long)]
        adaptive: bool,
    },
    /// Participating media: density lookups per camera ray, null-collision
    /// share, majorant violations and the equal-time relative MSE against a
    /// long reference, for the grid and global majorants with every volume
    /// estimator, and their global / grid ratios (table + SVG chart).
    Volumes {
        /// Scenes (USD or exported); default: the teapot cloud and smoke.vdb
        /// of scenes/bench.
        scenes: Vec<PathBuf>,
        #[command(flatten)]
        equal_time: EqualTimeArgs,
        /// Smoke check in under a minute: budgets 0.1,0.2 s, one seed, a
        /// 32-spp reference (numbers are noisy).
        #[arg(long, conflicts_with_all = ["reference_spp", "times", "repeats"])]
        quick: bool,
        /// Also write each chart as DIR/volumes-<scene>-equal-time.svg (the
        /// README's charts live in docs/bench).
        #[arg(long, value_name = "DIR")]
        charts: Option<PathBuf>,
    },
    /// Emitting volumes as lights: the equal-time relative MSE against a
    /// long reference with `--volume-light-sampling` on and off, time per
    /// sample and density lookups per camera ray (table + SVG chart).
    Fire {
        /// Scenes (USD or exported); default: scenes/bench/fire_lit.usda
        /// and scenes/bench/canyon_fire.usda (docs/benchmarks.md says how to
        /// write the VDB and the canyon they read).
        scenes: Vec<PathBuf>,
        #[command(flatten)]
        equal_time: EqualTimeArgs,
        /// Smoke check in about a minute: budgets 0.2,0.5 s, one seed, a
        /// 64-spp reference (numbers are noisy).
        #[arg(long, conflicts_with_all = ["reference_spp", "times", "repeats"])]
        quick: bool,
        /// Also write each chart as DIR/fire-<scene>-equal-time.svg.
        #[arg(long, value_name = "DIR")]
        charts: Option<PathBuf>,
    },
    /// Motion blur cost: BVH build time, transform-track memory and
    /// samples/s of moving instances with the shutter closed and open.
    Motion {
        /// Moving instances.
        #[arg(long, default_value_t = 1000)]
        instances: usize,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "320x180", value_parser = parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of each timed render.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Timed repeats of the build and the render; the table shows medians.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Also a volume advected by its velocity: a VDB with `density`,
        /// `temperature` and `vel` grids (scenes/make_explosion.py writes one).
        #[arg(long, value_name = "FILE.vdb")]
        volume: Option<PathBuf>,
    },
    /// Material cost: the shader ball's samples/s and the chess set's
    /// export, load and build time and memory with its textures.
    Looks {
        /// The StandardShaderBall stage (docs/benchmarks.md, "Looks").
        #[arg(long)]
        shader_ball: PathBuf,
        /// The OpenChessSet stage.
        #[arg(long)]
        chess_set: PathBuf,
        /// Shader ball image size WIDTHxHEIGHT.
        #[arg(long, default_value = "160x120", value_parser = parse_resolution)]
        res: glam::UVec2,
        /// Samples per pixel of each shader ball render.
        #[arg(long, default_value_t = 8)]
        spp: u32,
        /// Timed repeats; the tables show medians.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
    },
    /// Internal to `bench looks`: loads one exported scene, builds its
    /// render state and prints the resident bytes added.
    #[command(hide = true)]
    LooksMemory {
        /// The exported scene folder.
        scene: PathBuf,
        /// Worker threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
    },
    /// Internal to `bench instances`: loads one exported scene and builds its
    /// BVHs in this fresh process, and prints the resident bytes added.
    #[command(hide = true)]
    InstancesMemory {
        /// The exported scene folder.
        scene: PathBuf,
    },
}

/// The flags `bench render`, `bench volumes` and `bench fire` share; each
/// benchmark's defaults are the lab's ([`EqualTimeDefaults`]).
#[derive(clap::Args, Debug)]
pub struct EqualTimeArgs {
    /// Image size WIDTHxHEIGHT [default: 160x120 (render, volumes), 160x90 (fire)].
    #[arg(long, value_parser = parse_resolution)]
    res: Option<glam::UVec2>,
    /// Samples per pixel of the reference: MIS + Sobol (render),
    /// null-scattering MIS with the grid majorant (volumes), light sampling
    /// on (fire) [default: 4096 (render, fire), 1024 (volumes)].
    #[arg(long)]
    reference_spp: Option<u32>,
    /// Equal-time budgets in seconds [default: 0.5,1,2,4,8 (render),
    /// 0.5,1,2,4 (volumes), 5,10,20,30 (fire)].
    #[arg(long, value_delimiter = ',')]
    times: Option<Vec<f64>>,
    /// Seeds per measurement; the table shows medians.
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Folder for the reference EXRs and the charts [default:
    /// out/bench-render, out/bench-volumes, out/bench-fire].
    #[arg(long)]
    out: Option<PathBuf>,
}

impl EqualTimeArgs {
    /// The benchmark these flags, `scenes`, `--quick` and `--charts` describe.
    fn bench(
        self,
        defaults: &EqualTimeDefaults,
        scenes: Vec<PathBuf>,
        quick: bool,
        charts: Option<PathBuf>,
    ) -> EqualTimeBench {
        let settings = (self.reference_spp, self.times, self.repeats);
        let (threads, folders) = (self.threads, (self.out, charts));
        EqualTimeBench::new(
            defaults, scenes, self.res, settings, quick, threads, folders,
        )
    }
}

/// Runs one benchmark: its flags as the lab's options.
pub fn run(bench: Bench) -> Result<()> {
    match bench {
        Bench::Aovs {
            scenes,
            res,
            spp,
            repeats,
            threads,
            out,
        } => lab::bench_aovs(&lab::AovsBench {
            scenes,
            resolution: res,
            spp,
            repeats,
            threads,
            out,
        }),
        Bench::Vdb {
            files,
            grid,
            repeats,
            lookups,
        } => lab::bench_vdb(&lab::VdbBench {
            files,
            grid,
            repeats,
            lookups,
        }),
        Bench::Instances {
            instances,
            triangles,
            repeats,
        } => lab::bench_instances(&lab::InstancesBench {
            instances,
            triangles,
            repeats,
        }),
        Bench::Render {
            scenes,
            equal_time,
            adaptive,
        } => {
            let bench = equal_time.bench(&lab::RENDER_DEFAULTS, scenes, false, None);
            match adaptive {
                true => lab::bench_adaptive(&bench),
                false => lab::bench_render(&bench),
            }
        }
        Bench::Volumes {
            scenes,
            equal_time,
            quick,
            charts,
        } => lab::bench_volumes(&equal_time.bench(&lab::VOLUMES_DEFAULTS, scenes, quick, charts)),
        Bench::Fire {
            scenes,
            equal_time,
            quick,
            charts,
        } => lab::bench_fire(&equal_time.bench(&lab::FIRE_DEFAULTS, scenes, quick, charts)),
        Bench::PointsCurves {
            points,
            curves,
            rays,
            repeats,
        } => lab::bench_points_curves(&lab::PointsCurvesBench {
            points,
            curves,
            rays,
            repeats,
        }),
        Bench::Subdivision { scenes, level } => lab::bench_subdivision(&scenes, level),
        Bench::Motion {
            instances,
            res,
            spp,
            repeats,
            volume,
        } => lab::bench_motion(&lab::MotionBench {
            instances,
            resolution: res,
            spp,
            repeats,
            volume,
        }),
        Bench::Looks {
            shader_ball,
            chess_set,
            res,
            spp,
            repeats,
            threads,
        } => lab::bench_looks(&lab::LooksBench {
            shader_ball,
            chess_set,
            resolution: res,
            spp,
            repeats,
            threads,
        }),
        Bench::LooksMemory { scene, threads } => lab::looks_memory(&scene, threads),
        Bench::InstancesMemory { scene } => lab::instances_memory(&scene),
    }?;
    Ok(())
}
