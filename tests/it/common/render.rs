//! `cirrus render` on the exported test scenes of `scenes/tests/` (or on a
//! stage a test wrote into its scratch folder), as the
//! statistical tests run it: box filter (a pixel is the plain average of
//! its area), fixed seed, one worker thread (the test harness runs tests in
//! parallel); the EXR read back as float RGB planes, and the render log
//! parsed for its counters.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};

/// Every `--sampler`: the furnace runs through each with each strategy.
pub const SAMPLERS: [&str; 2] = ["sobol", "independent"];

/// Every `--strategy`: MIS, BSDF sampling only, light sampling only.
pub const STRATEGIES: [&str; 3] = ["mis", "bsdf", "nee"];

/// Deep enough that paths end by Russian roulette (unbiased), not by depth.
pub const UNBOUNDED_DEPTH: &str = "1000";

/// Relative f32 rounding of a pixel mean (sums of f32 samples), counted in
/// the sigma of [`super::assert_within_4_sigma`].
pub const PIXEL_ROUNDING: f64 = 1e-5;

/// `scenes/tests/NAME.usda` exported once per test process (see
/// [`super::exported_test_scene`]) into the scratch folder
/// `CRATE_scenes/NAME`, CRATE being the test binary's name, so that two
/// test binaries running at once never write one export folder.
pub fn exported(name: &str) -> PathBuf {
    super::exported_test_scene(name, concat!(env!("CARGO_CRATE_NAME"), "_scenes"))
}

/// One render's settings: the scene (a name under `scenes/tests/`, e.g.
/// `furnace_diffuse` or `stability/furnace_forward`), resolution in pixels,
/// samples per pixel, seed, and any further `cirrus render` flags.
pub struct Render<'a> {
    /// The scene, `scenes/tests/SCENE.usda` (exported first), or the
    /// absolute path of a stage rendered as it is (one a test wrote into its
    /// scratch folder next to the VDBs it generated).
    pub scene: &'a str,
    /// Width and height in pixels.
    pub res: (u32, u32),
    /// Samples per pixel.
    pub spp: u32,
    /// The sampler seed.
    pub seed: u64,
    /// Further flags, appended last (`--threads` here replaces the default 1).
    pub extra: &'a [&'a str],
}

impl Render<'_> {
    /// Renders into `dir` with the default AOVs and reads the EXR back.
    pub fn run(&self, dir: &Path) -> Image {
        let exr = self.output(dir, "exr");
        self.cirrus(&exr, &[]);
        Image::read(&exr, self.res)
    }

    /// Renders into `dir` as the stability suite measures it (the beauty
    /// alone, replacing any earlier output) and returns the parsed log and,
    /// unless `extra` has `--crop` (whose output is a film state, not an
    /// image), the image.
    pub fn run_logged(&self, dir: &Path) -> (RenderLog, Option<Image>) {
        let cropped = self.extra.contains(&"--crop");
        let out = self.output(dir, if cropped { "film" } else { "exr" });
        let log = self.cirrus(&out, &["--aovs", "beauty"]);
        let image = (!cropped).then(|| Image::read(&out, self.res));
        (RenderLog::parse(log), image)
    }

    /// [`Self::run_logged`] for a whole image, asserting no density lookup
    /// exceeded its majorant.
    pub fn run_within_majorants(&self, dir: &Path) -> (RenderLog, Image) {
        let (log, image) = self.run_logged(dir);
        assert!(
            !log.text.contains("exceeded their majorant"),
            "{}",
            log.text
        );
        (log, image.expect("a whole image, not a crop"))
    }

    /// The output file in `dir`, named after every setting, with extension
    /// `ext`.
    fn output(&self, dir: &Path, ext: &str) -> PathBuf {
        let scene = Path::new(self.scene);
        let name = if scene.is_absolute() {
            scene.file_stem().unwrap().to_string_lossy().into_owned()
        } else {
            self.scene.replace('/', "_")
        };
        dir.join(format!(
            "{}-{}x{}-{}spp-seed{}-{}.{ext}",
            name,
            self.res.0,
            self.res.1,
            self.spp,
            self.seed,
            self.extra.join("").replace(['-', ','], "")
        ))
    }

    /// Runs `cirrus render` into `out` with these settings, then `flags`,
    /// then `extra`; returns its log (stderr), panicking with it when the
    /// render fails.
    fn cirrus(&self, out: &Path, flags: &[&str]) -> String {
        let threads: &[&str] = if self.extra.contains(&"--threads") {
            &[]
        } else {
            &["--threads", "1"]
        };
        let (res, spp, seed) = (
            format!("{}x{}", self.res.0, self.res.1),
            self.spp.to_string(),
            self.seed.to_string(),
        );
        let scene = if Path::new(self.scene).is_absolute() {
            PathBuf::from(self.scene)
        } else {
            exported(self.scene)
        };
        let mut args: Vec<&OsStr> = vec!["render".as_ref(), scene.as_os_str()];
        args.extend(["-o".as_ref(), out.as_os_str()]);
        for arg in [
            "--res", &res, "--spp", &spp, "--seed", &seed, "--filter", "box",
        ]
        .into_iter()
        .chain(threads.iter().copied())
        .chain(flags.iter().copied())
        .chain(self.extra.iter().copied())
        {
            args.push(arg.as_ref());
        }
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
            .args(&args)
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "cirrus {args:?} failed:\n{log}");
        log
    }
}

/// A linear RGB image as written by `cirrus render`, row 0 at the top.
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Channel planes R, G, B, each `width * height` values in row order.
    pub rgb: [Vec<f32>; 3],
}

impl Image {
    /// The float R, G, B channels of the EXR at `path`, checked to be `res`
    /// pixels and finite.
    pub fn read(path: &Path, res: (u32, u32)) -> Self {
        let exr = read_all_flat_layers_from_file(path).unwrap();
        let layer = &exr.layer_data[0];
        let plane = |name: &str| -> Vec<f32> {
            let channel = layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name.to_string() == name)
                .unwrap_or_else(|| panic!("{}: no channel {name}", path.display()));
            match &channel.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => panic!("{}: channel {name} is not float: {other:?}", path.display()),
            }
        };
        let image = Image {
            width: layer.size.0,
            height: layer.size.1,
            rgb: [plane("R"), plane("G"), plane("B")],
        };
        assert_eq!(
            (image.width, image.height),
            (res.0 as usize, res.1 as usize),
            "{}: size",
            path.display()
        );
        assert!(
            image.rgb.iter().flatten().all(|v| v.is_finite()),
            "{}: a pixel is not finite",
            path.display()
        );
        image
    }

    /// Channel `c` (0 R, 1 G, 2 B) of the pixels `(x, y)` that `keep`
    /// accepts, in row order.
    pub fn pixels(&self, c: usize, keep: impl Fn(usize, usize) -> bool) -> Vec<f64> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .filter(|&(x, y)| keep(x, y))
            .map(|(x, y)| f64::from(self.rgb[c][y * self.width + x]))
            .collect()
    }
}

/// What one `cirrus render` reported: its counters, parsed from the log.
pub struct RenderLog {
    /// The whole log.
    pub text: String,
    /// Camera rays traced.
    camera_rays: f64,
    /// Closest-hit rays traced, one per path segment.
    closest_hit_rays: f64,
    /// Shadow rays traced: one per light sample that may carry light (a
    /// point picked where a fire emits nothing is dropped before one).
    shadow_rays: f64,
    /// Density lookups per camera ray, 0 when the log has no volume line.
    pub lookups_per_camera_ray: f64,
}

impl RenderLog {
    /// Parses the log `text` of a finished render, asserting it reports no
    /// non-finite sample.
    fn parse(text: String) -> Self {
        let rays = text
            .lines()
            .find_map(|l| l.split_once(" M rays/s ("))
            .unwrap_or_else(|| panic!("no ray counts in:\n{text}"))
            .1;
        let words: Vec<f64> = rays
            .split([' ', ','])
            .filter_map(|w| w.parse().ok())
            .collect();
        let lookups = text
            .lines()
            .find_map(|l| l.split_once("volumes: "))
            .map_or(0.0, |(_, rest)| {
                rest.split(' ').next().unwrap().parse().unwrap()
            });
        assert!(
            !text.contains("NaN/Inf sample"),
            "a sample was not finite:\n{text}"
        );
        Self {
            camera_rays: words[0],
            closest_hit_rays: words[1],
            shadow_rays: words[2],
            lookups_per_camera_ray: lookups,
            text,
        }
    }

    /// Closest-hit rays per camera ray: path segments per sample.
    pub fn segments_per_path(&self) -> f64 {
        self.closest_hit_rays / self.camera_rays
    }

    /// Shadow rays per camera ray.
    pub fn shadow_rays_per_path(&self) -> f64 {
        self.shadow_rays / self.camera_rays
    }
}
