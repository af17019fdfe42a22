//! The lighting artist's controls of UsdLux (issue 45, parts 4 and 5): a
//! gprim with `MeshLightAPI` lights as the analytic light of its shape does,
//! a light's `inputs:diffuse` / `inputs:specular` scale its light through
//! the diffuse and specular lobes alone, and a `PortalLight` is named in a
//! warning and leaves the image as it is.
//!
//! Each stage is scenes/tests/sphere_light_plane.usda (a Lambert plane of
//! albedo 0.5, a SphereLight of radius 0.1 and radiance 100 centred 1 above
//! it, an orthographic camera between them that sees the plane only) with
//! `overrides` of its /World.

use std::path::Path;

use crate::common::render::{Image, Render};
use crate::common::{self, estimate};

/// The test scene with `overrides` (prims and overs inside /World).
fn stage(overrides: &str) -> String {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/sphere_light_plane.usda");
    format!(
        "#usda 1.0\n(\n    subLayers = [@{}@]\n)\n\nover \"World\"\n{{\n{overrides}\n}}\n",
        base.display()
    )
}

/// The plane a white mirror (no diffuse lobe).
const MIRROR: &str = r#"    over "Looks"
    {
        over "GreyLambert"
        {
            over "Surface"
            {
                color3f inputs:diffuseColor = (0, 0, 0)
                color3f inputs:specularColor = (1, 1, 1)
                float inputs:roughness = 0
            }
        }
    }"#;

/// The light with `inputs` added.
fn light(inputs: &str) -> String {
    format!("    over \"Bulb\"\n    {{\n        {inputs}\n    }}")
}

/// The stage `text` exported into `dir/name` and rendered at `res` x `res`
/// pixels, `spp` samples, seed 7; returns the image and the export's
/// warnings (its stderr).
fn render(dir: &Path, name: &str, text: &str, (res, spp): (u32, u32)) -> (Image, String) {
    let dir = dir.join(name);
    std::fs::create_dir_all(&dir).unwrap();
    let usda = dir.join("stage.usda");
    std::fs::write(&usda, text).unwrap();
    let out = dir.join("out");
    let export = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args([
            "export".as_ref(),
            usda.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ])
        .output()
        .unwrap();
    let warnings = String::from_utf8_lossy(&export.stderr).into_owned();
    assert!(export.status.success(), "export failed:\n{warnings}");
    let scene = out.to_str().unwrap();
    let render = Render {
        scene,
        res: (res, res),
        spp,
        seed: 7,
        extra: &[],
    };
    (render.run(&dir), warnings)
}

/// A `Sphere` with `MeshLightAPI` (intensity 100, normalize off, no
/// material: a pure light) lights the Lambert plane as a `SphereLight` of the
/// same radius and intensity does: the mean over the image of the pixel
/// differences (each render its own noise; the expected plane radiance is
/// the same in both) against the tessellation's deficit. The exported sphere
/// is a 32-segment lathe inscribed in the sphere: seen from the plane, its
/// silhouette is close to a regular 32-gon inscribed in the circle, whose
/// area is 32 sin(2 pi / 32) / (2 pi) = 0.99359 of the disc's, so the mesh
/// light's irradiance is that fraction of the sphere's, within 0.5% (the
/// silhouette seen obliquely is a slightly different polygon), plus 4 sigma.
#[test]
fn a_sphere_with_mesh_light_api_lights_as_a_sphere_light() {
    let dir = common::scratch("light_controls_mesh_light");
    let mesh = r#"    over "Bulb" (active = false) {}
    def Sphere "MeshBulb" (
        prepend apiSchemas = ["MeshLightAPI"]
    )
    {
        double3 xformOp:translate = (0, 1, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        double radius = 0.1
        float inputs:intensity = 100
    }"#;
    let budget = (48, 64);
    let (mesh_image, warnings) = render(&dir, "mesh", &stage(mesh), budget);
    assert!(!warnings.contains("no lights"), "{warnings}");
    let (sphere_image, _) = render(&dir, "sphere", &stage(""), budget);
    let all = |_, _| true;
    let mesh_pixels = mesh_image.pixels(0, all);
    let sphere_pixels = sphere_image.pixels(0, all);
    let sphere_mean = estimate(&sphere_pixels).mean;
    // Under the light the plane's radiance is 0.5 x 100 x 0.1^2 = 0.5.
    assert!(
        sphere_mean > 0.05,
        "the sphere light lights the plane: {sphere_mean}"
    );
    let polygon = 32.0 * (2.0 * std::f64::consts::PI / 32.0).sin() / (2.0 * std::f64::consts::PI);
    let differences = estimate(
        mesh_pixels
            .iter()
            .zip(&sphere_pixels)
            .map(|(m, s)| m - polygon * s),
    );
    let tolerance = 4.0 * differences.sigma + 0.005 * sphere_mean;
    eprintln!(
        "mesh light - {polygon:.5} x sphere light: {:.3e} +- {:.2e} (1 sigma), sphere light mean {sphere_mean:.5}",
        differences.mean, differences.sigma
    );
    assert!(
        differences.mean.abs() <= tolerance,
        "mesh light {:.5}, sphere light {sphere_mean:.5} (x {polygon:.5}): differ by {:.3e} > {tolerance:.3e}",
        estimate(&mesh_pixels).mean,
        differences.mean
    );
}

/// `inputs:diffuse = 0` takes a light out of a Lambert plane's image (every
/// pixel exactly 0) and leaves a mirror's image exactly as without it;
/// `inputs:specular = 0` the reverse. Same seed, so the unchanged images are
/// bit-identical: the factors only scale, never change the sampling.
#[test]
fn diffuse_and_specular_factors_scale_their_lobes_only() {
    let dir = common::scratch("light_controls_lobes");
    let budget = (16, 4);
    let image = |name: &str, surface: &str, inputs: &str| {
        render(
            &dir,
            name,
            &stage(&format!("{surface}\n{}", light(inputs))),
            budget,
        )
        .0
    };
    let lambert = image("lambert", "", "");
    let mirror = image("mirror", MIRROR, "");
    let lit = |image: &Image| image.pixels(0, |_, _| true).iter().sum::<f64>();
    assert!(
        lit(&lambert) > 0.0 && lit(&mirror) > 0.0,
        "both surfaces are lit"
    );
    let dark = |image: &Image| image.rgb.iter().flatten().all(|&v| v == 0.0);
    let diffuse_off = "float inputs:diffuse = 0";
    let specular_off = "float inputs:specular = 0";
    assert!(dark(&image("lambert_diffuse_0", "", diffuse_off)));
    assert_eq!(
        image("lambert_specular_0", "", specular_off).rgb,
        lambert.rgb
    );
    assert_eq!(
        image("mirror_diffuse_0", MIRROR, diffuse_off).rgb,
        mirror.rgb
    );
    assert!(dark(&image("mirror_specular_0", MIRROR, specular_off)));
}

/// A `PortalLight` in front of a dome is named in a warning and left out:
/// the image is bit-identical to the one without it.
#[test]
fn a_portal_light_is_warned_about_and_changes_nothing() {
    let dir = common::scratch("light_controls_portal");
    let dome = r#"    def DomeLight "Sky"
    {
        float inputs:intensity = 0.5
    }"#;
    let portal = format!(
        r#"{dome}
    def PortalLight "Window"
    {{
        double3 xformOp:translate = (0, 2, 0)
    }}"#
    );
    let budget = (16, 4);
    let (with_portal, warnings) = render(&dir, "portal", &stage(&portal), budget);
    assert!(
        warnings.contains("PortalLight /World/Window: portals do not guide dome sampling"),
        "{warnings}"
    );
    let (without, _) = render(&dir, "no_portal", &stage(dome), budget);
    assert_eq!(with_portal.rgb, without.rgb);
}

/// A mesh light's colour temperature that is not a positive number is a
/// render error naming the light prim, as for any UsdLux light.
#[test]
fn a_mesh_light_with_a_bad_colour_temperature_is_an_error_naming_it() {
    let dir = common::scratch("light_controls_bad_temperature");
    let mesh = r#"    def Sphere "MeshBulb" (
        prepend apiSchemas = ["MeshLightAPI"]
    )
    {
        double radius = 0.1
        bool inputs:enableColorTemperature = 1
        float inputs:colorTemperature = -100
    }"#;
    let usda = dir.join("stage.usda");
    std::fs::write(&usda, stage(mesh)).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(["render".as_ref(), usda.as_os_str(), "-o".as_ref()])
        .arg(dir.join("out.exr"))
        .args(["--res", "8x8", "--spp", "1"])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{log}");
    assert!(
        log.contains("light /World/MeshBulb: colorTemperature -100 K is not a positive number"),
        "{log}"
    );
}
