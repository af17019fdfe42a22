//! Tests of [`super::Lights`] (`container.rs`): selection, sampling and
//! hit probabilities agree, linked and unlinked.

use super::*;
use crate::lights::test_support::{
    assert_within_4_sigma, estimate, scene_with, sphere_json, translated,
};
use crate::sampling::Pcg32;

/// No volumes: these tests light with UsdLux lights and meshes.
static NO_MEDIA: std::sync::LazyLock<Media> = std::sync::LazyLock::new(Media::default);

fn emitters(materials: &Materials) -> Emitters<'_> {
    Emitters {
        materials,
        media: &NO_MEDIA,
        time: 0.0,
    }
}

/// Two spheres of equal size on either side of the origin, the one on +X
/// nine times brighter, plus an emissive quad far below: the share of
/// samples towards each light follows its selection probability, the
/// two equidistant spheres' probabilities are in proportion to their
/// power, and each sample's pdf is what `intersect` reports.
#[test]
fn selection_picks_lights_by_power_and_distance() {
    let far = translated(Vec3::new(-0.5, -0.5, -50.0));
    let scene = scene_with(
        "selection",
        serde_json::json!([
            sphere_json("/Dim", Vec3::new(-3.0, 0.0, 0.0), 0.5, 1.0),
            sphere_json("/Bright", Vec3::new(3.0, 0.0, 0.0), 0.5, 9.0),
        ]),
        [1.0, 1.0, 1.0],
        &[far],
    );
    let materials = Materials::build(&scene).unwrap();
    let lights = Lights::build(&scene, &materials, &NO_MEDIA, true, Shutter::CLOSED).unwrap();
    assert_eq!(lights.lights.len(), 3);
    let probabilities: Vec<f32> = (0..3)
        .map(|i| lights.probability(Vec3::ZERO, i, Receiver::UNNAMED))
        .collect();
    assert!((probabilities.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    assert!(
        (probabilities[1] / probabilities[0] - 9.0).abs() < 1e-3,
        "{probabilities:?}"
    );
    // The quad, 50 units away, is picked far less than its power share
    // (power pi x 0.5 against pi^2 x 10): the BVH weighs distance.
    assert!(probabilities[2] < 1e-3, "{probabilities:?}");
    let mut rng = Pcg32::new(21, 0);
    let n = 20_000;
    let mut counts = [0u32; 3];
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let Some((_, s)) = lights.sample(
            emitters(&materials),
            (Vec3::ZERO, Receiver::UNNAMED),
            rng.next_f32(),
            u,
        ) else {
            continue;
        };
        let which = if s.wi.x > 0.5 {
            1
        } else if s.wi.x < -0.5 {
            0
        } else {
            2
        };
        counts[which] += 1;
        if which < 2 {
            let (_, hit) = lights
                .intersect((Vec3::ZERO, Receiver::UNNAMED), s.wi, f32::INFINITY, 0.0)
                .unwrap();
            assert!((hit.pdf - s.pdf).abs() <= 1e-3 * s.pdf);
        }
    }
    for (i, &c) in counts.iter().enumerate() {
        let p = f64::from(probabilities[i]);
        let sigma = (f64::from(n) * p * (1.0 - p)).sqrt();
        assert!(
            (f64::from(c) - f64::from(n) * p).abs() < 4.0 * sigma,
            "light {i}: {c} of {n}, expected p = {p}"
        );
    }
}

/// Irradiance at the origin (normal +Z) from the emissive triangle of a
/// quad turned to face down at height 1, against Lambert's exact formula
/// for a polygon; `mesh_pdf` at each sampled point equals the sample's pdf.
#[test]
fn emissive_mesh_irradiance_and_pdf() {
    // Rotation by pi about X (front +z -> -z), then translation.
    let placed = [1., 0., 0., -0.5, 0., -1., 0., 0.5, 0., 0., -1., 1.];
    let scene = scene_with("mesh", serde_json::json!([]), [2.0, 2.0, 2.0], &[placed]);
    let materials = Materials::build(&scene).unwrap();
    let lights = Lights::build(&scene, &materials, &NO_MEDIA, true, Shutter::CLOSED).unwrap();
    let e = estimate(20_000, 22, |u| {
        let (_, s) = lights.sample(
            emitters(&materials),
            (Vec3::ZERO, Receiver::UNNAMED),
            0.5,
            u,
        )?;
        let p = s.wi * s.distance;
        // Triangle 0 of the quad is mesh-space x > y: world x + 0.5 > 0.5 - y.
        let sp = SurfacePoint {
            p,
            offset: 0.0,
            ng: -Vec3::Z,
            ns: -Vec3::Z,
            dpdu: Vec3::X,
            uv: Vec2::ZERO,
            barycentrics: Vec2::ZERO,
            material: 0,
            double_sided: false,
            instance: 0,
            prototype_mesh: 0,
            mesh: 0,
            triangle: if p.x > -p.y { 0 } else { 1 },
        };
        assert_eq!(sp.triangle, 0);
        let pdf = lights.mesh_pdf(&sp, (Vec3::ZERO, Receiver::UNNAMED));
        assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{pdf} vs {}", s.pdf);
        Some(s.radiance.x * s.wi.z.max(0.0) / s.pdf)
    });
    // World vertices of triangle 0: mesh (0,0),(1,0),(1,1) placed.
    let v = [
        Vec3::new(-0.5, 0.5, 1.0),
        Vec3::new(0.5, 0.5, 1.0),
        Vec3::new(0.5, -0.5, 1.0),
    ];
    let lambert: f32 = (0..3)
        .map(|i| {
            let (a, b) = (v[i].normalize(), v[(i + 1) % 3].normalize());
            a.dot(b).acos() * a.cross(b).normalize().z
        })
        .sum::<f32>()
        .abs()
        / 2.0;
    assert_within_4_sigma(e, 2.0 * lambert, "emissive triangle");
    // From above, the single-sided quad shows its back: nothing.
    let above = Vec3::new(0.0, 0.0, 3.0);
    assert!(lights
        .sample(
            emitters(&materials),
            (above, Receiver::UNNAMED),
            0.5,
            Vec2::splat(0.4)
        )
        .is_none());
}

#[test]
fn unusable_lights_are_errors_naming_the_prim() {
    let mut bad = sphere_json("/World/Bad", Vec3::ZERO, 0.0, 1.0);
    bad["normalize"] = true.into();
    let scene = scene_with("bad", serde_json::json!([bad]), [0.0; 3], &[]);
    let materials = Materials::build(&scene).unwrap();
    let err = Lights::build(&scene, &materials, &NO_MEDIA, true, Shutter::CLOSED)
        .err()
        .unwrap();
    assert!(err.to_string().contains("/World/Bad"), "{err}");
}

/// A scene without lights is lit by a white dome of radiance 1: every
/// escaping direction sees radiance 1. Being constant, it is left to
/// BSDF and phase sampling: light sampling never picks it, and the pdf
/// escaping rays report for it is 0 (their MIS weight 1).
#[test]
fn a_scene_without_lights_gets_the_default_dome() {
    let empty = scene_with("empty", serde_json::json!([]), [0.0; 3], &[]);
    let materials = Materials::build(&empty).unwrap();
    let lights = Lights::build(&empty, &materials, &NO_MEDIA, true, Shutter::CLOSED).unwrap();
    let mut seen = Vec::new();
    lights.escaped(
        (Vec3::ZERO, Receiver::UNNAMED),
        Vec3::new(0.3, -0.2, 0.9).normalize(),
        0.0,
        |_, radiance, pdf| seen.push((radiance, pdf)),
    );
    assert_eq!(seen, [(Vec3::ONE, 0.0)]);
    assert!(lights
        .sample(
            emitters(&materials),
            (Vec3::ZERO, Receiver::UNNAMED),
            0.5,
            Vec2::splat(0.3)
        )
        .is_none());
}

/// A constant dome, a distant light with a cone and a sphere: the dome
/// is never picked (its escaping rays report pdf 0), distant samples
/// have the pdf `escaped` reports for their direction, sphere samples
/// the one `intersect` reports, and the distant light's share of samples
/// is its selection probability.
#[test]
fn infinite_and_bounded_lights_share_the_selection() {
    let infinite = |shape: serde_json::Value, intensity: f32| {
        let mut light = serde_json::json!({
            "path": "/Sky", "transform": translated(Vec3::ZERO),
            "color": [1, 1, 1], "intensity": intensity, "exposure": 0.0,
            "normalize": false, "color_temperature": null
        });
        light
            .as_object_mut()
            .unwrap()
            .extend(shape.as_object().unwrap().clone());
        light
    };
    let scene = scene_with(
        "infinite",
        serde_json::json!([
            infinite(serde_json::json!({"type": "dome", "texture": null}), 0.2),
            infinite(
                serde_json::json!({"type": "distant", "angle_deg": 20.0}),
                50.0
            ),
            sphere_json("/Bulb", Vec3::new(0.0, 0.0, 4.0), 0.5, 5.0)
        ]),
        [0.0; 3],
        &[],
    );
    let materials = Materials::build(&scene).unwrap();
    let lights = Lights::build(&scene, &materials, &NO_MEDIA, true, Shutter::CLOSED).unwrap();
    assert_eq!(lights.probability(Vec3::ZERO, 0, Receiver::UNNAMED), 0.0);
    let p_distant = lights.probability(Vec3::ZERO, 1, Receiver::UNNAMED);
    assert!(p_distant > 0.0 && p_distant < 1.0);
    assert!((p_distant + lights.probability(Vec3::ZERO, 2, Receiver::UNNAMED) - 1.0).abs() < 1e-6);
    let mut rng = Pcg32::new(23, 0);
    let n = 20_000;
    let mut distants = 0u32;
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let (light, s) = lights
            .sample(
                emitters(&materials),
                (Vec3::ZERO, Receiver::UNNAMED),
                rng.next_f32(),
                u,
            )
            .unwrap();
        assert_ne!(light, 0, "the constant dome is never picked");
        if s.distance.is_infinite() {
            distants += 1;
            let mut seen = Vec::new();
            lights.escaped(
                (Vec3::ZERO, Receiver::UNNAMED),
                s.wi,
                0.0,
                |_, radiance, pdf| seen.push((radiance, pdf)),
            );
            // The dome (pdf 0) and the distant light.
            assert_eq!(seen.len(), 2);
            assert_eq!(seen[0], (Vec3::splat(0.2), 0.0));
            assert_eq!(seen[1].0, s.radiance);
            assert!((seen[1].1 - s.pdf).abs() <= 1e-5 * s.pdf);
        } else {
            let (_, hit) = lights
                .intersect((Vec3::ZERO, Receiver::UNNAMED), s.wi, f32::INFINITY, 0.0)
                .unwrap();
            assert!((hit.pdf - s.pdf).abs() <= 1e-3 * s.pdf);
        }
    }
    let q = f64::from(p_distant);
    let sigma = (f64::from(n) * q * (1.0 - q)).sqrt();
    assert!(
        (f64::from(distants) - f64::from(n) * q).abs() < 4.0 * sigma,
        "{distants} of {n}"
    );
}
