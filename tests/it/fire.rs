//! Emitting volumes as lights (`--volume-light-sampling`, on by default),
//! end to end through `cirrus render`: the irradiance an emitting box puts
//! on a plane against its numerical integral, with and without light
//! sampling; both ways against each other on a fireball; and the default
//! depth against an unbounded one in a dense cloud (defaults never bias).
//! Statistics as in tests/render.rs: per-pixel residuals, 4 sigma.

use crate::common;
use std::f64::consts::PI;

use crate::common::estimate;
use crate::common::render::Render;

/// scenes/tests/volume_light_plane.usda: the box's sigma_a per unit density.
const SIGMA_A: f64 = 0.2;

/// The box's density at box-local point `u` (volume_box.vdb: 1 over index
/// [0, 15]^3 at voxel 1/16, trilinear, so 1 over [0, 15/16] per axis and
/// falling linearly to 0 at -1/16 and 1).
fn box_density(u: [f64; 3]) -> f64 {
    u.iter()
        .map(|&v| {
            ((v + 1.0 / 16.0) * 16.0)
                .min((1.0 - v) * 16.0)
                .clamp(0.0, 1.0)
        })
        .product()
}

/// Irradiance at plane point (x, 0, z), normal +Y, from the box lifted by
/// 1 (world [-1/16, 1] x [15/16, 2] x [-1/16, 1]), per unit Le: the
/// integral of sigma_a T cos / r^2 over the box, by the midpoint rule (40^3
/// cells; each transmittance by a 48-step midpoint march).
fn box_irradiance(x: f64, z: f64) -> f64 {
    const N: usize = 40;
    const STEPS: usize = 48;
    let (lo, width) = (-1.0 / 16.0, 1.0 + 1.0 / 16.0);
    let h = width / N as f64;
    let mut sum = 0.0;
    for i in 0..N {
        for j in 0..N {
            for k in 0..N {
                let u = [
                    lo + (i as f64 + 0.5) * h,
                    lo + (j as f64 + 0.5) * h,
                    lo + (k as f64 + 0.5) * h,
                ];
                let d = box_density(u);
                if d == 0.0 {
                    continue;
                }
                let y = [u[0], u[1] + 1.0, u[2]];
                let v = [y[0] - x, y[1], y[2] - z];
                let r2 = v.iter().map(|c| c * c).sum::<f64>();
                let r = r2.sqrt();
                let mut depth = 0.0;
                for s in 0..STEPS {
                    let f = (s as f64 + 0.5) / STEPS as f64;
                    let p = [x + f * v[0], f * v[1] - 1.0, z + f * v[2]];
                    depth += SIGMA_A * box_density(p) * r / STEPS as f64;
                }
                sum += SIGMA_A * d * (-depth).exp() * (v[1] / r) / r2;
            }
        }
    }
    sum * h * h * h
}

/// Asserts that `d`, a mean of paired differences, is within 4 sigma of 0.
fn assert_zero_within_4_sigma(what: &str, d: common::Estimate) {
    eprintln!("{what}: {:.5} +- {:.5}", d.mean, d.sigma);
    assert!(
        d.mean.abs() < 4.0 * d.sigma,
        "{what}: {} +- {}",
        d.mean,
        d.sigma
    );
}

/// An optically thin emitting box beside the camera's view of a Lambert
/// plane (scenes/tests/volume_light_plane.usda): each pixel's radiance is
/// albedo / pi x E x Le, E integrated numerically at the pixel centre,
/// with light sampling on (the default) and off; the red channel within
/// 4 sigma, the quadrature error
/// (below 0.2%) counted in the bound. Light sampling must also cut the
/// noise: at equal samples its standard error is at least 3x lower.
#[test]
fn emitting_box_lights_a_plane_as_integrated_with_and_without_light_sampling() {
    let dir = common::scratch("fire_box_plane");
    let le = cirrus::color::blackbody_rgb(1500.0) * 2.0;
    let (res, spp) = (8usize, 256);
    // Pixel (col, row) centre: the 0.4 x 0.4 view around (2, 0.5), row 0 at -Z.
    let expected: Vec<f64> = (0..res * res)
        .map(|i| {
            let (col, row) = (i % res, i / res);
            let x = 1.8 + (col as f64 + 0.5) * 0.4 / res as f64;
            let z = 0.3 + (row as f64 + 0.5) * 0.4 / res as f64;
            0.5 / PI * box_irradiance(x, z)
        })
        .collect();
    let mut sigmas = Vec::new();
    for (seed, sampling) in [(1, "on"), (2, "off")] {
        let image = Render {
            scene: "volume_light_plane",
            res: (res as u32, res as u32),
            spp,
            seed,
            extra: &["--volume-light-sampling", sampling],
        }
        .run(&dir);
        // Red, where 1500 K is brightest; green and blue follow the same paths.
        {
            let residuals =
                (0..res * res).map(|i| f64::from(image.rgb[0][i]) / f64::from(le.x) - expected[i]);
            let e = estimate(residuals);
            let what = format!("light sampling {sampling}: red / Le - E albedo / pi");
            let mean_expected = expected.iter().sum::<f64>() / expected.len() as f64;
            eprintln!(
                "{what}: {:.3e} +- {:.3e} (mean expected {mean_expected:.6})",
                e.mean, e.sigma
            );
            assert!(
                e.mean.abs() <= 4.0 * e.sigma + 2e-3 * mean_expected,
                "{what}: {} +- {}",
                e.mean,
                e.sigma
            );
            sigmas.push(e.sigma);
        }
    }
    assert!(
        sigmas[0] * 3.0 < sigmas[1],
        "light sampling should cut the noise: sigma on {} vs off {}",
        sigmas[0],
        sigmas[1]
    );
}

/// Defaults never bias (scenes/tests/dense_cloud.usda: max sigma_t 25,
/// albedo 0.95): at the default `--max-depth` the cloud matches an
/// effectively unbounded `--max-depth 100000` render within 4 sigma (paired
/// per-pixel differences of independent renders), while `--max-depth 16`,
/// the old default, reads measurably darker: the test can tell.
#[test]
fn default_depth_renders_a_dense_cloud_without_darkening_it() {
    needs_shared!();
    let dir = common::scratch("fire_dense_cloud");
    let render = |seed: u64, extra: &'static [&'static str]| {
        Render {
            scene: "dense_cloud",
            res: (48, 24),
            spp: 64,
            seed,
            extra,
        }
        .run(&dir)
    };
    let default = render(1, &[]);
    let difference = |other: &common::render::Image| {
        estimate((0..48 * 24).map(|i| {
            (0..3)
                .map(|c| f64::from(default.rgb[c][i]) - f64::from(other.rgb[c][i]))
                .sum::<f64>()
                / 3.0
        }))
    };
    let unbounded = difference(&render(2, &["--max-depth", "100000"]));
    assert_zero_within_4_sigma("default - unbounded depth", unbounded);
    let capped = difference(&render(3, &["--max-depth", "16"]));
    eprintln!(
        "default - depth 16: {:.5} +- {:.5}",
        capped.mean, capped.sigma
    );
    assert!(
        capped.mean > 4.0 * capped.sigma,
        "depth 16 should read darker than the default: {} +- {}",
        capped.mean,
        capped.sigma
    );
}

/// Light sampling on and off estimate the same image of the demo
/// explosion (scenes/demo/explosion.usda over the fireball of
/// scenes/make_explosion.py at 48^3 voxels): per channel, the mean of the
/// paired per-pixel differences of two independent renders within 4 sigma,
/// and the difference's sigma below 2% of the image mean, so that a bias of
/// a few percent would show.
/// The demo's explosion stage over a 48^3 fireball (scenes/make_explosion.py)
/// written into the scratch folder `name`: the folder and the stage.
fn explosion_stage(name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = common::scratch(name);
    let vdb = dir.join("explosion.vdb");
    common::run_python(
        std::path::Path::new(common::SYSTEM_PYTHON),
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/make_explosion.py"),
        &[&vdb.to_string_lossy(), "--res", "48"],
    );
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/demo/explosion.usda");
    let stage = std::fs::read_to_string(demo)
        .unwrap()
        .replace("../../out/explosion.vdb", &vdb.to_string_lossy());
    let usda = dir.join("explosion.usda");
    std::fs::write(&usda, stage).unwrap();
    (dir, usda)
}

#[test]
fn light_sampling_on_and_off_render_the_same_explosion() {
    let (dir, usda) = explosion_stage("fire_explosion");
    let (w, h) = (40usize, 24usize);
    let render = |sampling: &str, seed: &str| {
        let exr = dir.join(format!("explosion_{sampling}.exr"));
        let (usda, exr_arg, res) = (
            usda.to_string_lossy(),
            exr.to_string_lossy(),
            format!("{w}x{h}"),
        );
        let args = [
            "render",
            &usda,
            "-o",
            &exr_arg,
            "--res",
            &res,
            "--spp",
            "256",
            "--seed",
            seed,
            "--volume-light-sampling",
            sampling,
            "--filter",
            "box",
            "--aovs",
            "beauty",
        ];
        let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
        common::cirrus_ok(&args);
        common::render::Image::read(&exr, (w as u32, h as u32))
    };
    let (on, off) = (render("on", "1"), render("off", "2"));
    for c in 0..3 {
        let d = estimate((0..w * h).map(|i| f64::from(on.rgb[c][i]) - f64::from(off.rgb[c][i])));
        let mean = estimate(on.pixels(c, |_, _| true)).mean;
        assert_zero_within_4_sigma(&format!("channel {c} (mean {mean:.4}): on - off"), d);
        assert!(
            d.sigma < 0.02 * mean,
            "channel {c}: too noisy to tell: sigma {} vs mean {mean}",
            d.sigma
        );
    }
}

/// The memory preflight's estimates of the explosion's grids
/// (`Media::field_bytes_for`: the sparse layouts, majorant grids and the
/// emission cells of its light, from the VDB grid table alone) against what
/// the built media hold: never less, and within 2.5x (measured 2.1x: on so
/// small a grid the leaf bound from OpenVDB's tree size, mostly internal
/// nodes, counts every leaf the active box touches) once the near picks'
/// region tables are set aside: they are counted at their bound, 12^3
/// regions x 512 clusters x 12-byte alias bins (`src/volumes/near_picks.rs`),
/// since how many clusters a fire has is known only once its cells are
/// weighed (this one holds fewer); and the whole volume estimate, which
/// adds reading the largest grid, covers them too.
#[test]
fn the_memory_estimate_covers_the_built_explosion() {
    let (dir, usda) = explosion_stage("fire_memory");
    let scene = cirrus::scene::Scene::open(&usda, &Default::default()).unwrap();
    let vdb = cirrus::volumes::grid::VdbFile::open(dir.join("explosion.vdb")).unwrap();
    let field = |name: &str, emits: bool| {
        let info = &vdb.grids()[vdb.find(name, 0).unwrap()];
        cirrus::volumes::Media::field_bytes_for(info, emits)
    };
    let estimated = field("density", false) + field("temperature", true);
    let res = glam::UVec2::new(8, 8);
    let state =
        cirrus::render_state::RenderState::build(&scene, Some(res), Default::default()).unwrap();
    assert_eq!(state.media.emitters().count(), 1, "the fireball emits");
    let held = state.media.memory_bytes();
    println!("grids: estimate {estimated} B, held {held} B");
    let region_tables = 12u64.pow(3) * 512 * 12;
    assert!(
        estimated >= held && 2 * estimated.saturating_sub(region_tables) <= 5 * held,
        "grids: estimate {estimated} B, held {held} B"
    );
    let aovs = "beauty".parse().unwrap();
    let volumes = cirrus::memory::estimate(&scene, res, &aovs)
        .unwrap()
        .volumes;
    assert!(volumes >= estimated, "volume estimate {volumes} B");
}

/// `cirrus render` of a box of fire (tests/python/make_fire_box.py in
/// `mode`) whose Volume prim /World/Fire reads field `field` with
/// `primvars` (USD lines), over a ground, 8x8 at 4 spp; the command's output.
fn render_fire_box(name: &str, mode: &str, field: &str, primvars: &str) -> std::process::Output {
    let dir = common::scratch(&format!("fire_bad_{name}"));
    let vdb = dir.join("fire.vdb");
    common::run_python(
        std::path::Path::new(common::SYSTEM_PYTHON),
        &common::python_script("make_fire_box.py"),
        &[&vdb.to_string_lossy(), mode],
    );
    let usda = dir.join("fire.usda");
    std::fs::write(
        &usda,
        format!(
            r#"#usda 1.0
(
    defaultPrim = "World"
)
def Xform "World"
{{
    def Volume "Fire"
    {{
        rel field:density = </World/Fire/density>
        rel field:{field} = </World/Fire/{field}>
        color3f primvars:albedo = (0.2, 0.2, 0.2)
        {primvars}
        def OpenVDBAsset "density"
        {{
            asset filePath = @{vdb}@
            token fieldName = "density"
        }}
        def OpenVDBAsset "{field}"
        {{
            asset filePath = @{vdb}@
            token fieldName = "{field}"
        }}
    }}
    def Mesh "Ground"
    {{
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-5, -1, 5), (5, -1, 5), (5, -1, -5), (-5, -1, -5)]
    }}
}}
"#,
            vdb = vdb.display()
        ),
    )
    .unwrap();
    common::render_tiny(&usda, &dir)
}

/// Bad fire input, each end to end: NaN, infinite and negative
/// temperatures are read as 0 with one warning naming the volume, grid and
/// file, and no sample goes non-finite; a negative heatScale or
/// emissionScale is an error naming the prim and the value; an emission
/// field that is not a float grid is an error naming the grid; a volume
/// whose emission is zero everywhere renders (no light entry, no division
/// by zero) with a warning.
#[test]
fn bad_fire_input_is_reported_by_name() {
    let text = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).into_owned();
    let hot = "float primvars:heatScale = 1";
    let out = render_fire_box("nan", "bad_temperature", "temperature", hot);
    let log = text(&out);
    assert!(out.status.success(), "{log}");
    assert!(
        log.contains("volume /World/Fire: grid temperature of")
            && log.contains("has 2 NaN or infinite values and a smallest value of -5"),
        "no bad-temperature warning in:\n{log}"
    );
    assert!(!log.contains("NaN/Inf sample"), "{log}");

    for (name, primvar) in [
        ("heatScale", hot.replace('1', "-1")),
        (
            "emissionScale",
            format!("{hot}\n        float primvars:emissionScale = -2"),
        ),
    ] {
        let out = render_fire_box(
            &format!("negative_{name}"),
            "bad_temperature",
            "temperature",
            &primvar,
        );
        let log = text(&out);
        assert_eq!(out.status.code(), Some(1), "{log}");
        assert!(
            log.contains("volume /World/Fire: primvars:") && log.contains(&format!("{name} is -")),
            "no error naming the prim and {name} in:\n{log}"
        );
    }

    let out = render_fire_box("vector", "vector_emission", "emission", "");
    let log = text(&out);
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(
        log.contains("grid 'emission' holds 'vec3s' values"),
        "no error naming the grid in:\n{log}"
    );

    let out = render_fire_box("cold", "cold", "temperature", hot);
    let log = text(&out);
    assert!(out.status.success(), "{log}");
    assert!(
        log.contains("volume /World/Fire: its emission fields emit nothing"),
        "{log}"
    );
    assert!(!log.contains("NaN/Inf sample"), "{log}");
}
