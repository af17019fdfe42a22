//! Light and shadow linking (`collection:lightLink`, `collection:shadowLink`)
//! on `scenes/tests/light_linking.usda` and `shadow_linking.usda`, seen from
//! above by an orthographic camera: regions of two renders compared pixel
//! by pixel (independent seeds), the mean difference against 0 within 4
//! sigma of the differences' own spread, so the image's variation cancels.

use std::path::Path;

use crate::common::render::{Image, Render};
use crate::common::{estimate, export_usda, scratch, Estimate};

/// Width and height of every render, pixels.
const RES: (u32, u32) = (96, 48);

/// A region of the floor plane seen from above: world x and z ranges.
type Region = ((f32, f32), (f32, f32));

/// The stage `scenes/tests/NAME.usda` with each `(from, to)` of `edits`
/// applied (each must match), exported into the test's scratch folder `dir/tag`.
fn edited(name: &str, edits: &[(&str, &str)], dir: &Path, tag: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/tests/{name}.usda"));
    let mut text = std::fs::read_to_string(path).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name}: no {from:?}");
        text = text.replace(from, to);
    }
    let out = dir.join(tag);
    std::fs::create_dir_all(&out).unwrap();
    export_usda(&out, &text).to_string_lossy().into_owned()
}

/// Renders `scene` (an exported folder) with direct light alone unless
/// `extra` says otherwise, `spp` samples, `seed`.
fn render(scene: &str, dir: &Path, (spp, seed): (u32, u64), extra: &[&str]) -> Image {
    let mut flags = vec!["--max-depth", "1"];
    flags.extend_from_slice(extra);
    Render {
        scene,
        res: RES,
        spp,
        seed,
        extra: &flags,
    }
    .run(dir)
}

/// Mean over `region` (world x, z of an orthographic view `width` x
/// `height` units wide, centred on the origin, top = -z) of the luminance-free
/// channel mean of `a - b`, per pixel.
fn difference(a: &Image, b: &Image, (width, height): (f32, f32), region: Region) -> Estimate {
    let ((x0, x1), (z0, z1)) = region;
    let inside = |px: usize, py: usize| {
        let x = -width / 2.0 + (px as f32 + 0.5) * width / a.width as f32;
        let z = -height / 2.0 + (py as f32 + 0.5) * height / a.height as f32;
        (x0..x1).contains(&x) && (z0..z1).contains(&z)
    };
    let mean = |image: &Image| -> Vec<f64> {
        let planes: Vec<Vec<f64>> = (0..3).map(|c| image.pixels(c, inside)).collect();
        (0..planes[0].len())
            .map(|i| planes.iter().map(|p| p[i]).sum::<f64>() / 3.0)
            .collect()
    };
    let (ma, mb) = (mean(a), mean(b));
    assert!(ma.len() >= 8, "region {region:?} holds {} pixels", ma.len());
    estimate(ma.iter().zip(&mb).map(|(x, y)| x - y))
}

/// Asserts the two renders agree over `region` within 4 sigma.
fn assert_same(what: &str, d: Estimate) {
    eprintln!("{what}: difference {:.5} +- {:.1e}", d.mean, d.sigma);
    assert!(
        d.mean.abs() <= 4.0 * d.sigma.max(1e-6),
        "{what}: the renders differ by {} (sigma {})",
        d.mean,
        d.sigma
    );
}

/// Asserts the first render is brighter over `region` by more than 4 sigma.
fn assert_brighter(what: &str, d: Estimate) {
    eprintln!("{what}: difference {:.5} +- {:.1e}", d.mean, d.sigma);
    assert!(
        d.mean > 4.0 * d.sigma,
        "{what}: expected brighter, difference {} (sigma {})",
        d.mean,
        d.sigma
    );
}

/// The light-linking stage's view, world units.
const LIGHT_VIEW: (f32, f32) = (12.0, 6.0);
/// Sphere A's and B's tops, and two floor patches clear of every object.
const SPHERE_A: Region = ((-3.4, -2.6), (-0.4, 0.4));
const SPHERE_B: Region = ((2.6, 3.4), (-0.4, 0.4));
const FLOOR: [Region; 2] = [((-5.8, -4.2), (-2.8, 2.8)), ((1.0, 2.0), (1.5, 2.8))];

/// A key linked to sphere A only, with direct light alone: B's and the
/// floor's pixels equal the render without the key within 4 sigma; A's are
/// brighter with it.
#[test]
fn a_light_linked_to_one_sphere_lights_it_alone() {
    let dir = scratch("linking_light");
    let linked = edited("light_linking", &[], &dir, "linked");
    let keyless = edited(
        "light_linking",
        &[("float inputs:intensity = 300", "float inputs:intensity = 0")],
        &dir,
        "keyless",
    );
    let a = render(&linked, &dir, (32, 1), &[]);
    let b = render(&keyless, &dir, (32, 2), &[]);
    assert_same("sphere B", difference(&a, &b, LIGHT_VIEW, SPHERE_B));
    for (i, floor) in FLOOR.iter().enumerate() {
        assert_same(
            &format!("floor {i}"),
            difference(&a, &b, LIGHT_VIEW, *floor),
        );
    }
    assert_brighter("sphere A", difference(&a, &b, LIGHT_VIEW, SPHERE_A));
}

/// Light sampling alone and BSDF sampling alone estimate the same linked
/// image: the selection picks only linked lights, and a BSDF-sampled ray
/// counts only what light sampling could have picked (light linking), and
/// finds a light through the parts its shadow link leaves out (shadow
/// linking), both within 4 sigma everywhere that matters.
#[test]
fn light_and_bsdf_sampling_agree_on_linked_scenes() {
    let dir = scratch("linking_strategies");
    let light = edited("light_linking", &[], &dir, "light");
    let nee = render(&light, &dir, (16, 3), &["--strategy", "nee"]);
    let bsdf = render(&light, &dir, (256, 4), &["--strategy", "bsdf"]);
    for (what, region) in [
        ("sphere A", SPHERE_A),
        ("sphere B", SPHERE_B),
        ("floor", FLOOR[0]),
    ] {
        assert_same(what, difference(&nee, &bsdf, LIGHT_VIEW, region));
    }
    let shadow = edited("shadow_linking", &[], &dir, "shadow");
    let nee = render(&shadow, &dir, (16, 5), &["--strategy", "nee"]);
    let bsdf = render(&shadow, &dir, (256, 6), &["--strategy", "bsdf"]);
    for (what, region) in [
        ("under the cube, key side", KEY_CUBE_SHADOW),
        ("under B, key side", KEY_B_SHADOW),
        ("under the cube, fill side", FILL_CUBE_SHADOW),
    ] {
        assert_same(what, difference(&nee, &bsdf, SHADOW_VIEW, region));
    }
}

/// The shadow-linking stage's view, world units.
const SHADOW_VIEW: (f32, f32) = (16.0, 8.0);
/// Where the key's shadow of the cube would fall, of sphere B falls, and
/// the fill's shadow of the cube falls.
const KEY_CUBE_SHADOW: Region = ((-0.3, 0.3), (-2.5, -0.5));
const KEY_B_SHADOW: Region = ((6.0, 6.8), (-1.2, -0.4));
const FILL_CUBE_SHADOW: Region = ((-0.3, 0.3), (2.5, 3.8));

/// The key's shadowLink leaves the cube out: with direct light alone and
/// the key alone, the floor where the cube's shadow would be equals the
/// render without the cube, while sphere B (in the set) still casts the
/// key's shadow; with the fill alone, the cube's shadow stays.
#[test]
fn a_blocker_left_out_of_a_shadow_link_casts_no_shadow_of_that_light() {
    let dir = scratch("linking_shadow");
    let fill_off = ("float inputs:intensity = 300", "float inputs:intensity = 0");
    let key_off = ("float inputs:intensity = 600", "float inputs:intensity = 0");
    let hidden = |prim: &str| {
        (
            format!("def {prim}\n    {{"),
            format!("def {prim}\n    {{\n        token visibility = \"invisible\""),
        )
    };
    let (no_cube, no_b) = (hidden("Cube \"Blocker\""), hidden("Sphere \"B\""));
    let run = |edits: &[(&str, &str)], tag: &str, seed: u64| {
        render(
            &edited("shadow_linking", edits, &dir, tag),
            &dir,
            (16, seed),
            &[],
        )
    };
    let key = run(&[fill_off], "key", 11);
    let key_no_cube = run(&[fill_off, (&no_cube.0, &no_cube.1)], "key_no_cube", 12);
    let key_no_b = run(&[fill_off, (&no_b.0, &no_b.1)], "key_no_b", 13);
    let d = |a: &Image, b: &Image, region| difference(a, b, SHADOW_VIEW, region);
    assert_same(
        "key, under the cube",
        d(&key, &key_no_cube, KEY_CUBE_SHADOW),
    );
    assert_brighter("key, under B", d(&key_no_b, &key, KEY_B_SHADOW));
    let fill = run(&[key_off], "fill", 14);
    let fill_no_cube = run(&[key_off, (&no_cube.0, &no_cube.1)], "fill_no_cube", 15);
    assert_brighter(
        "fill, under the cube",
        d(&fill_no_cube, &fill, FILL_CUBE_SHADOW),
    );
}

/// A lightLink that names a prim not on the stage: one warning naming it,
/// and the rest of the collection (sphere A) honoured.
#[test]
fn a_collection_naming_a_missing_prim_warns_once_and_keeps_the_rest() {
    let dir = scratch("linking_missing");
    let out = edited(
        "light_linking",
        &[(
            "rel collection:lightLink:includes = </World/A>",
            "rel collection:lightLink:includes = [</World/A>, </World/Nowhere>]",
        )],
        &dir,
        "missing",
    );
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(&out).join("scene.json")).unwrap())
            .unwrap();
    let warnings: Vec<&str> = manifest["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w.as_str())
        .filter(|w| w.contains("/World/Nowhere"))
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("/World/Key"), "{}", warnings[0]);
    let key = &manifest["lights"][0];
    assert_eq!(key["path"], "/World/Key");
    let sets = key["light_link"].as_array().unwrap();
    assert_eq!(sets.len(), 1, "the key lights sphere A's set alone: {key}");
}
