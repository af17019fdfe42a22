//! Shared pieces of the lights' unit tests: light records, Monte Carlo
//! estimates with their standard error, and the sample/hit agreement check.

use glam::{Vec2, Vec3};

use super::{LightHit, LightSample};
use crate::sampling::Pcg32;
use crate::scene::{Light as LightRecord, LightLobes, LightShape};

/// A white light record of `intensity` at the origin, unrotated.
pub(crate) fn record(shape: LightShape, normalize: bool, intensity: f32) -> LightRecord {
    LightRecord {
        path: "/World/Light".into(),
        transform: translated(Vec3::ZERO),
        color: [1.0, 1.0, 1.0],
        intensity,
        exposure: 0.0,
        normalize,
        color_temperature: None,
        lobes: LightLobes::default(),
        shape,
        motion: None,
        shaping: None,
        links: Default::default(),
    }
}

/// A 3x4 transform translating by `t`.
pub(crate) fn translated(t: Vec3) -> [f32; 12] {
    [1., 0., 0., t.x, 0., 1., 0., t.y, 0., 0., 1., t.z]
}

/// A Monte Carlo mean and its standard error.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Estimate {
    pub mean: f32,
    pub sigma: f32,
}

/// The mean of `f` over `n` uniform points of [0,1)^2 (seeded), `None`
/// counting as 0, with the standard error estimated from the samples.
pub(crate) fn estimate(n: u32, seed: u64, mut f: impl FnMut(Vec2) -> Option<f32>) -> Estimate {
    let mut rng = Pcg32::new(seed, 0);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let v = f64::from(f(Vec2::new(rng.next_f32(), rng.next_f32())).unwrap_or(0.0));
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / f64::from(n);
    let var = (sum2 / f64::from(n) - mean * mean).max(0.0);
    Estimate {
        mean: mean as f32,
        sigma: (var / f64::from(n)).sqrt() as f32,
    }
}

/// The estimate is within 4 standard errors of `exact` (plus 1e-5 relative
/// for f32 rounding, which matters only for zero-variance estimators).
pub(crate) fn assert_within_4_sigma(e: Estimate, exact: f32, what: &str) {
    assert!(
        (e.mean - exact).abs() <= 4.0 * e.sigma + 1e-5 * exact.abs(),
        "{what}: {} vs exact {exact} (sigma {})",
        e.mean,
        e.sigma
    );
}

/// `n` picks made with `pick(u)` (u uniform, seeded), each a light index
/// and its reported probability, report the probability `probabilities` gives their light, and each light is picked
/// as often as that says (binomial, 4 sigma); `what` names the case.
pub(crate) fn assert_picks_follow(
    probabilities: &[f32],
    (n, seed): (u32, u64),
    mut pick: impl FnMut(f32) -> Option<(usize, f32)>,
    what: &str,
) {
    let mut rng = Pcg32::new(seed, 0);
    let mut counts = vec![0u32; probabilities.len()];
    for _ in 0..n {
        let (light, probability) = pick(rng.next_f32()).unwrap();
        assert_eq!(probability, probabilities[light], "{what}");
        counts[light] += 1;
    }
    assert_counts_follow(&counts, probabilities, n, what);
}

/// Each of `n` draws landed in bin i `counts[i]` times, as often as its
/// probability `probabilities[i]` says (binomial, 4 sigma; a bin of
/// probability 0 or 1 exactly).
fn assert_counts_follow(counts: &[u32], probabilities: &[f32], n: u32, what: &str) {
    for (i, (&c, &q)) in counts.iter().zip(probabilities).enumerate() {
        let q = f64::from(q);
        let sigma = (f64::from(n) * q * (1.0 - q)).sqrt();
        assert!(
            (f64::from(c) - f64::from(n) * q).abs() <= 4.0 * sigma,
            "{what}: bin {i}: {c} of {n}, expected p = {q}"
        );
    }
}

fn close(a: f32, b: f32, relative: f32) -> bool {
    (a - b).abs() <= relative * a.abs().max(b.abs())
}

fn radiance_close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-3 * a.abs().max(b.abs()).max_element()
}

/// For samples drawn from `p`, the ray from `p` along `wi` hits the light at
/// the sample's distance with the sample's radiance (relative 1e-3), and the
/// sample's pdf within 1e-3 for at least 99% of them: a ray towards a point
/// within a fraction of a degree of a curved silhouette is ill-conditioned
/// (a 1e-7 change of direction moves its hit cosine by a large fraction).
pub(crate) fn assert_hit_consistent(
    p: Vec3,
    sample: impl Fn(Vec2) -> Option<LightSample>,
    intersect: impl Fn(Vec3, Vec3, f32) -> Option<LightHit>,
) {
    let mut rng = Pcg32::new(99, 3);
    let (mut drawn, mut checked, mut loose) = (0, 0, 0);
    for _ in 0..2000 {
        let Some(s) = sample(Vec2::new(rng.next_f32(), rng.next_f32())) else {
            continue;
        };
        drawn += 1;
        let Some(hit) = intersect(p, s.wi, s.distance * 1.001) else {
            // A sample grazing the silhouette may miss by rounding; few do.
            continue;
        };
        checked += 1;
        assert!(
            radiance_close(hit.radiance, s.radiance),
            "radiance {} vs {}",
            hit.radiance,
            s.radiance
        );
        assert!(
            close(hit.t, s.distance, 1e-3),
            "t {} vs {}",
            hit.t,
            s.distance
        );
        if !close(hit.pdf, s.pdf, 1e-3) {
            loose += 1;
        }
    }
    assert!(drawn > 500, "only {drawn} of 2000 samples drawn");
    assert!(
        checked * 100 >= drawn * 99,
        "only {checked} of {drawn} samples found again"
    );
    assert!(
        loose * 100 <= checked,
        "{loose} of {checked} pdfs differ by over 1e-3"
    );
}

/// For directions drawn by `sample`, `escaped` gives the same radiance and pdf.
pub(crate) fn assert_escape_consistent(
    sample: impl Fn(Vec2) -> Option<LightSample>,
    escaped: impl Fn(Vec3) -> Option<LightHit>,
) {
    let mut rng = Pcg32::new(98, 4);
    let mut checked = 0;
    for _ in 0..2000 {
        let Some(s) = sample(Vec2::new(rng.next_f32(), rng.next_f32())) else {
            continue;
        };
        let hit = escaped(s.wi).expect("a sampled direction escapes to the light");
        checked += 1;
        assert!(
            close(hit.pdf, s.pdf, 1e-3),
            "pdf {} vs {} along {}",
            hit.pdf,
            s.pdf,
            s.wi
        );
        assert!(
            radiance_close(hit.radiance, s.radiance),
            "radiance {} vs {} along {}",
            hit.radiance,
            s.radiance,
            s.wi
        );
    }
    assert!(checked > 1900, "only {checked} of 2000 samples were drawn");
}

/// A scene written to a scratch folder and loaded: the given light records
/// (JSON, as in `scene.json`), and one mesh, a unit quad in z = 0 (CCW from
/// +z; triangle 0 = (0,0),(1,0),(1,1) has the emissive material 0 of
/// `emissive` radiance, triangle 1 the black material 1), placed by each of
/// `instances` (world-from-prototype transforms).
pub(crate) fn scene_with(
    name: &str,
    lights: serde_json::Value,
    emissive: [f32; 3],
    instances: &[[f32; 12]],
) -> crate::scene::Scene {
    use serde_json::json;
    let mut blob: Vec<u8> = Vec::new();
    let mut array = |scalar: &str, width: usize, bytes: &[u8]| {
        blob.resize(blob.len().next_multiple_of(16), 0);
        let offset = blob.len();
        blob.extend_from_slice(bytes);
        json!({"offset": offset, "count": bytes.len() / (4 * width), "type": scalar, "width": width})
    };
    let points: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    let triangles: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];
    let mesh = json!({
        "path": "/World/Quad/Mesh",
        "points": array("f32", 3, bytemuck::cast_slice(&points)),
        "triangles": array("u32", 3, bytemuck::cast_slice(&triangles)),
        "normals": null,
        "uvs": null,
        "triangle_materials": array("u32", 1, bytemuck::cast_slice(&[0u32, 1])),
        "double_sided": false,
    });
    let n = instances.len();
    let instances_json = json!({
        "count": n,
        "prototype": array("u32", 1, bytemuck::cast_slice(&vec![0u32; n])),
        "transform": array("f32", 12, bytemuck::cast_slice(instances)),
        "source": array("u32", 1, bytemuck::cast_slice(&vec![0u32; n])),
        "source_index": array("u32", 1, bytemuck::cast_slice(&(0..n as u32).collect::<Vec<_>>())),
        "instance_sources": ["/World/Quad"],
    });
    let material = |name: &str, emission: [f32; 3]| {
        json!({
            "path": name, "fallback": false, "diffuse_color": [0.5, 0.5, 0.5],
            "emissive_color": emission, "metallic": 0.0, "roughness": 0.5,
            "specular_color": [0, 0, 0], "use_specular_workflow": false, "ior": 1.5,
            "opacity": 1.0, "clearcoat": 0.0, "clearcoat_roughness": 0.01, "normal": null
        })
    };
    let manifest = json!({
        "format": "cirrus-scene",
        "version": 1,
        "source": {"path": "/abs/in.usda", "mtime": 0.0, "time_code": null},
        "stage": {"meters_per_unit": 0.01, "up_axis": "Y"},
        "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]},
        "meshes": [mesh],
        "prototypes": [{"path": "/World/Quad", "meshes": [{"mesh": 0, "transform": translated(Vec3::ZERO)}], "volumes": []}],
        "instances": instances_json,
        "materials": [material("/Looks/Glow", emissive), material("/Looks/Black", [0.0; 3])],
        "textures": [],
        "lights": lights,
        "camera": {
            "path": null, "transform": translated(Vec3::ZERO), "projection": "perspective",
            "focal_length": 50.0, "horizontal_aperture": 20.955, "vertical_aperture": 15.2908,
            "horizontal_aperture_offset": 0.0, "vertical_aperture_offset": 0.0,
            "clipping_range": [1, 1000000], "f_stop": 0.0, "focus_distance": 0.0
        },
        "volumes": [],
        "render": {"resolution": null},
        "warnings": []
    });
    let dir = std::env::temp_dir().join(format!("cirrus-lights-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scene.json"), manifest.to_string()).unwrap();
    std::fs::write(dir.join("scene.bin"), &blob).unwrap();
    let scene = crate::scene::Scene::load(&dir).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    scene
}

/// A sphere light record as `scene.json` writes it.
pub(crate) fn sphere_json(path: &str, at: Vec3, radius: f32, intensity: f32) -> serde_json::Value {
    serde_json::json!({
        "type": "sphere", "path": path, "transform": translated(at), "color": [1, 1, 1],
        "intensity": intensity, "exposure": 0.0, "normalize": false,
        "color_temperature": null, "radius": radius, "treat_as_point": false
    })
}
