//! End to end: `cirrus render --aovs all` on the depth card
//! (`scenes/tests/aovs_depth_card.usda`) and the Cryptomatte scene, every
//! geometric AOV against the closed forms of the card (depth, albedo, N, P,
//! variance, the camera matrices) and every Cryptomatte layer decoded with
//! the specification's reference algorithm against each object's visible
//! area; and the quick-start CI preset.

use crate::common;
use std::path::Path;
use std::sync::OnceLock;

use crate::common::aovs::*;
use glam::{Mat3, Vec3};

/// scenes/tests/aovs_depth_card.usda, 32 x 32 at 16 spp with every AOV,
/// rendered once per test process.
fn card() -> &'static Exr {
    static CARD: OnceLock<Exr> = OnceLock::new();
    CARD.get_or_init(|| {
        render_and_read(
            "aovs_card",
            "aovs_depth_card",
            "32x32",
            16,
            &["--aovs", "all"],
        )
        .1
    })
}

/// Where pixel (x, y) lies relative to the card (columns 5.6 to 24.8, rows
/// 4.4 to 23.2, see the scene's doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CardPixel {
    Inside,
    Edge,
    Outside,
}

fn card_pixel(x: usize, y: usize) -> CardPixel {
    let inside = |i: usize, lo: f64, hi: f64| (i as f64) >= lo && (i + 1) as f64 <= hi;
    let outside = |i: usize, lo: f64, hi: f64| (i + 1) as f64 <= lo || (i as f64) >= hi;
    if outside(x, 5.6, 24.8) || outside(y, 4.4, 23.2) {
        CardPixel::Outside
    } else if inside(x, 5.6, 24.8) && inside(y, 4.4, 23.2) {
        CardPixel::Inside
    } else {
        CardPixel::Edge
    }
}

/// The rig's rotation rotY(30) rotX(-20): camera to world directions.
fn card_rotation() -> Mat3 {
    Mat3::from_rotation_y(30f32.to_radians()) * Mat3::from_rotation_x((-20f32).to_radians())
}

/// `v` (a point, w = 1) times the 4x4 matrix `m` in OpenEXR's (Imath's)
/// row-vector layout, translation in m[12..15]; returns (x, y, z, w).
fn transform_row_vector(v: Vec3, m: &[f32; 16]) -> [f64; 4] {
    let v = [f64::from(v.x), f64::from(v.y), f64::from(v.z), 1.0];
    std::array::from_fn(|j| (0..4).map(|i| v[i] * f64::from(m[i * 4 + j])).sum())
}

/// Z on a card perpendicular to the view axis at distance 4 of a perspective
/// camera: exactly 4 (1e-5 relative) in every pixel whose samples hit it at
/// all (A > 0), although the ray lengths differ by up to 22%; +inf in every
/// pixel none of whose samples hits it (A = 0), which includes every pixel
/// outside the card.
#[test]
fn depth_is_the_view_axis_distance_on_a_perpendicular_card() {
    let exr = card();
    let mut hit = 0;
    for (x, y) in exr.pixels() {
        let (z, a) = (exr.at("Z", x, y), exr.at("A", x, y));
        match card_pixel(x, y) {
            CardPixel::Inside => assert_eq!(a, 1.0, "({x}, {y}) A"),
            CardPixel::Outside => assert_eq!(a, 0.0, "({x}, {y}) A"),
            CardPixel::Edge => assert!(a > 0.0 && a < 1.0, "({x}, {y}) A = {a}"),
        }
        if a > 0.0 {
            hit += 1;
            assert!((z - 4.0).abs() <= 4e-5, "({x}, {y}) Z = {z}");
        } else {
            assert_eq!(z, f64::INFINITY, "({x}, {y}) Z where nothing is hit");
        }
    }
    assert!(hit > 18 * 18, "{hit} pixels see the card");
}

/// Albedo of the constant-colour card: its diffuseColor (0.25, 0.5, 0.75)
/// (exact in half) where every sample sees it, 0 where none does, and at the
/// edges colour x coverage A (escaped samples add 0), within half precision.
#[test]
fn albedo_is_the_diffuse_colour_where_the_plane_is_seen() {
    let exr = card();
    for (x, y) in exr.pixels() {
        let a = exr.at("A", x, y);
        for (c, colour) in ["R", "G", "B"].into_iter().zip([0.25, 0.5, 0.75]) {
            let albedo = exr.at(&format!("albedo.{c}"), x, y);
            let want = colour * a;
            assert!(
                (albedo - want).abs() <= HALF_EPS * want + HALF_SUBNORMAL_ERROR,
                "({x}, {y}) albedo.{c} = {albedo}, want {want} ({:?}, A = {a})",
                card_pixel(x, y)
            );
        }
    }
}

/// The other geometric AOVs and the header matrices on the card: N is the
/// card's world normal R (0, 0, 1) inside and 0 outside; P lies on the card
/// plane at view depth 4 inside; sample_count is the spp; the variance is 0
/// inside and outside (the card's radiance is noise-free: its bounces
/// escape) and at an edge pixel is that of n samples of which a fraction A
/// see radiance L and the rest 0: A (1 - A) L^2 / (n - 1) for the unbiased
/// sample variance (or / n for the biased one), 1e-3 relative. worldToCamera
/// (row vectors, as Imath) takes the camera's position to the origin and P
/// to depth |z| = Z; worldToNDC, after the perspective divide, takes P to a
/// point affine in the pixel centre (within 0.1 pixel: P is the mean of the
/// pixel's sample positions).
#[test]
fn geometry_variance_and_camera_matrices_agree_on_the_card() {
    let exr = card();
    let r = card_rotation();
    let normal = r * Vec3::Z;
    let forward = r * Vec3::NEG_Z;
    let eye = Vec3::new(1.0, 2.0, 3.0);
    let (cx, cy) = (15, 15);
    let radiance: Vec<f64> = ["R", "G", "B"].iter().map(|c| exr.at(c, cx, cy)).collect();
    assert!(
        radiance.iter().all(|&l| l > 0.0),
        "the card is lit: {radiance:?}"
    );
    let spp = 16.0;

    let to_camera = exr.world_to_camera.expect("worldToCamera");
    let origin = transform_row_vector(eye, &to_camera);
    assert!(
        origin[..3].iter().all(|v| v.abs() <= 1e-5) && (origin[3] - 1.0).abs() <= 1e-6,
        "eye -> {origin:?}"
    );
    let to_ndc = exr.world_to_ndc.expect("worldToNDC");
    let ndc = |x: usize, y: usize| -> [f64; 2] {
        let p = Vec3::new(
            exr.at("P.X", x, y) as f32,
            exr.at("P.Y", x, y) as f32,
            exr.at("P.Z", x, y) as f32,
        );
        let h = transform_row_vector(p, &to_ndc);
        [h[0] / h[3], h[1] / h[3]]
    };
    // The affine map pixel centre -> NDC through three interior pixels.
    let (o, ex, ey) = (ndc(6, 5), ndc(23, 5), ndc(6, 22));
    let du = [(ex[0] - o[0]) / 17.0, (ex[1] - o[1]) / 17.0];
    let dv = [(ey[0] - o[0]) / 17.0, (ey[1] - o[1]) / 17.0];
    let pixel_size = du[0].hypot(du[1]).min(dv[0].hypot(dv[1]));
    assert!(
        pixel_size > 0.0 && (du[0] * dv[1] - du[1] * dv[0]).abs() > 0.5 * pixel_size * pixel_size,
        "degenerate worldToNDC: {to_ndc:?}"
    );

    for (x, y) in exr.pixels() {
        let where_ = card_pixel(x, y);
        assert_eq!(exr.at("sample_count", x, y), spp, "({x}, {y}) sample_count");
        let n = Vec3::new(
            exr.at("N.X", x, y) as f32,
            exr.at("N.Y", x, y) as f32,
            exr.at("N.Z", x, y) as f32,
        );
        match where_ {
            CardPixel::Inside => assert!(
                (n - normal).abs().max_element() <= 1e-5,
                "({x}, {y}) N = {n}, want {normal}"
            ),
            CardPixel::Outside => assert_eq!(n, Vec3::ZERO, "({x}, {y}) N"),
            CardPixel::Edge => {}
        }
        if where_ == CardPixel::Inside {
            let p = Vec3::new(
                exr.at("P.X", x, y) as f32,
                exr.at("P.Y", x, y) as f32,
                exr.at("P.Z", x, y) as f32,
            );
            let depth = (p - eye).dot(forward);
            assert!(
                (depth - 4.0).abs() <= 1e-4,
                "({x}, {y}) P = {p} at view depth {depth}"
            );
            let camera = transform_row_vector(p, &to_camera);
            assert!(
                (camera[2].abs() - exr.at("Z", x, y)).abs() <= 1e-4,
                "({x}, {y}) worldToCamera takes P to {camera:?}"
            );
            let (u, v) = (x as f64 - 6.0, y as f64 - 5.0);
            let want = [o[0] + u * du[0] + v * dv[0], o[1] + u * du[1] + v * dv[1]];
            let got = ndc(x, y);
            let off = (got[0] - want[0]).hypot(got[1] - want[1]) / pixel_size;
            assert!(
                off <= 0.1,
                "({x}, {y}) worldToNDC takes P {off:.3} pixels off the affine map"
            );
        }
        let a = exr.at("A", x, y);
        for (c, l) in ["R", "G", "B"].into_iter().zip(&radiance) {
            let variance = exr.at(&format!("variance.{c}"), x, y);
            let spread = a * (1.0 - a) * l * l;
            let (lo, hi) = (spread / spp, spread / (spp - 1.0));
            assert!(
                variance >= lo * (1.0 - 1e-3) - 1e-9 && variance <= hi * (1.0 + 1e-3) + 1e-9,
                "({x}, {y}) variance.{c} = {variance:.4e}, want {lo:.4e}..{hi:.4e} (A = {a})"
            );
        }
    }
}

/// The visible area of each object of scenes/tests/aovs_cryptomatte.usda in
/// pixel (x, y) of the 20 x 20 image, as a fraction of the pixel:
/// (backdrop, CardA, CardB); CardB hides CardA where they overlap.
fn analytic_coverage(x: usize, y: usize) -> [f64; 3] {
    // Pixel (x, y) spans world x in [-1 + 0.1 x, -1 + 0.1 (x + 1)], y in [1 - 0.1 (y + 1), 1 - 0.1 y].
    let pixel = [
        -1.0 + 0.1 * x as f64,
        -1.0 + 0.1 * (x + 1) as f64,
        1.0 - 0.1 * (y + 1) as f64,
        1.0 - 0.1 * y as f64,
    ];
    let card_a = [-0.83, -0.07, -0.52, 0.61];
    let card_b = [-0.35, 0.77, -0.74, 0.35];
    let overlap = |r: [f64; 4], s: [f64; 4]| {
        [
            r[0].max(s[0]),
            r[1].min(s[1]),
            r[2].max(s[2]),
            r[3].min(s[3]),
        ]
    };
    let area = |r: [f64; 4]| ((r[1] - r[0]).max(0.0) * (r[3] - r[2]).max(0.0)) / 0.01;
    let a = area(overlap(card_a, pixel));
    let b = area(overlap(card_b, pixel));
    let ab = area(overlap(overlap(card_a, card_b), pixel));
    [1.0 - a - b + ab, a - ab, b]
}

/// Cryptomatte, decoded with the manifest by the reference algorithm: the
/// manifests name exactly the three mesh and two material prim paths; the
/// object coverages sum to 1 (1e-3) in every pixel (the backdrop fills the
/// view); each object's coverage is exactly 1 where it alone is seen and 0
/// where it is not seen, and at an edge the visible area within 3/64: the
/// 64 box-filtered samples of a pixel are an Owen-scrambled Sobol (0, 6,
/// 2)-net, whose count in a strip along one side of the pixel is within 1
/// of 64 times its area (each of the 64 elementary slabs holds one sample),
/// and within a few in a corner rectangle (measured: 0.0144 at worst); each
/// material's coverage is the sum of its objects'.
#[test]
fn cryptomatte_decodes_to_each_objects_visible_area() {
    let (_, exr) = render_and_read(
        "aovs_cryptomatte",
        "aovs_cryptomatte",
        "20x20",
        64,
        &["--aovs", "CryptoObject,CryptoMaterial"],
    );
    let objects = decode_cryptomatte(&exr, "CryptoObject");
    let materials = decode_cryptomatte(&exr, "CryptoMaterial");
    let object_names = ["/World/Backdrop", "/World/CardA", "/World/CardB"];
    assert_eq!(
        objects
            .manifest
            .keys()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        object_names
    );
    assert_eq!(
        materials
            .manifest
            .keys()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        ["/World/Looks/Grey", "/World/Looks/Red"]
    );

    let (mut fractional, mut worst) = (0, 0.0f64);
    for (x, y) in exr.pixels() {
        let p = y * exr.width + x;
        let decoded: Vec<f64> = object_names
            .iter()
            .map(|n| objects.coverage[*n][p])
            .collect();
        let sum: f64 = decoded.iter().sum();
        assert!(
            (sum - 1.0).abs() <= 1e-3,
            "({x}, {y}) object coverages sum to {sum}: {decoded:?}"
        );
        for ((name, &got), want) in object_names
            .iter()
            .zip(&decoded)
            .zip(analytic_coverage(x, y))
        {
            if want > 1.0 - 1e-9 {
                assert!(
                    (got - 1.0).abs() <= 1e-6,
                    "({x}, {y}) {name} covers {got}, not 1"
                );
            } else if want < 1e-9 {
                assert_eq!(got, 0.0, "({x}, {y}) {name} covers {got}, not 0");
            } else {
                fractional += 1;
                worst = worst.max((got - want).abs());
                assert!(
                    (got - want).abs() <= 3.0 / 64.0,
                    "({x}, {y}) {name} covers {got}, visible area {want:.4}"
                );
            }
        }
        let grey = materials.coverage["/World/Looks/Grey"][p];
        let red = materials.coverage["/World/Looks/Red"][p];
        assert!(
            (grey - decoded[0]).abs() <= 1e-6,
            "({x}, {y}) Grey {grey} vs Backdrop {}",
            decoded[0]
        );
        assert!(
            (red - decoded[1] - decoded[2]).abs() <= 1e-6,
            "({x}, {y}) Red {red} vs the cards {decoded:?}"
        );
    }
    eprintln!("{fractional} fractional coverages, worst error {worst:.4}");
    assert!(fractional >= 40, "only {fractional} edge coverages");
}

/// The README's first command at its CI preset (`.ci/quickstart --preset ci`,
/// the whole script: set-up, explosion VDB, demo stage, render, contact
/// sheet) ends with the demo's EXR holding exactly the default AOV contract,
/// every value finite (Z: +inf on the sky), most pixels lit in the beauty, and the PNG and contact
/// sheet beside it.
#[test]
fn quickstart_ci_preset_renders_the_demo_with_the_default_aovs() {
    needs_shared!();
    let out = common::scratch("quickstart_ci");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run = std::process::Command::new(root.join(".ci/quickstart"))
        .args(["--preset", "ci", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        ".ci/quickstart --preset ci failed:\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let exr = Exr::read(&out.join("canyon.exr"));
    assert_eq!(exr.formats(), expected_channels(&DEFAULT));
    assert_eq!((exr.width, exr.height), (256, 144));
    for (name, (_, values)) in &exr.channels {
        // Z is +inf where nothing is hit (the sky): the contract.
        let ok = |v: &f32| v.is_finite() || (name == "Z" && *v == f32::INFINITY);
        assert!(values.iter().all(ok), "{name}: NaN or -inf");
    }
    let lit = exr.plane("R").iter().filter(|&&v| v > 0.01).count();
    assert!(lit > exr.width * exr.height / 2, "{lit} lit pixels");
    for png in ["canyon.png", "canyon.aovs.png"] {
        let bytes = std::fs::metadata(out.join(png))
            .map(|m| m.len())
            .unwrap_or(0);
        assert!(bytes > 1000, "{png}: {bytes} bytes");
    }
}
