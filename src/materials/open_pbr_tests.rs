//! Tests of the OpenPBR BSDF through [`Bsdf`]: white furnaces per lobe
//! combination, sampling against evaluation (pdf, weight, chi-square per
//! lobe), reciprocity where it holds, and finite values on degenerate
//! inputs. (They live beside, not inside, open_pbr/ so that open_pbr/ never
//! names `Bsdf`, which holds it.)

use glam::{Vec2, Vec3};

use super::bsdf::Bsdf;
use super::open_pbr::{OpenPbrInputs, ShadingFrames};
use super::test_support::{assert_samples_follow_density, directions};
use crate::geometry::Frame;
use crate::sampling::{warp, Pcg32};

/// Frames with normal +z and tangent +x; the coat frame tilted by
/// `coat_tilt` radians about y.
fn frames(coat_tilt: f32, front: bool) -> ShadingFrames {
    let n_c = Vec3::new(coat_tilt.sin(), 0.0, coat_tilt.cos());
    ShadingFrames {
        base: Frame::from_normal_tangent(Vec3::Z, Vec3::X),
        coat: Frame::from_normal_tangent(n_c, Vec3::X),
        ng: Vec3::Z,
        front,
    }
}

/// The spec defaults with `edit` applied.
fn inputs(edit: impl FnOnce(&mut OpenPbrInputs)) -> OpenPbrInputs {
    let mut i = OpenPbrInputs::default();
    edit(&mut i);
    i
}

/// White diffuse of EON roughness `r`, no specular.
fn white_diffuse(r: f32) -> OpenPbrInputs {
    inputs(|i| {
        i.base_color = Vec3::ONE;
        i.base_diffuse_roughness = r;
        i.specular_weight = 0.0;
    })
}

/// White metal (F0 = F82 = 1) of roughness `r`.
fn white_metal(r: f32) -> OpenPbrInputs {
    inputs(|i| {
        i.base_color = Vec3::ONE;
        i.base_metalness = 1.0;
        i.specular_roughness = r;
    })
}

/// White diffuse under a glossy dielectric of roughness `r`.
fn white_plastic(r: f32) -> OpenPbrInputs {
    inputs(|i| {
        i.base_color = Vec3::ONE;
        i.base_diffuse_roughness = 0.5;
        i.specular_roughness = r;
    })
}

/// Mean and standard error of `f` over `n` draws.
fn estimate(n: usize, mut f: impl FnMut() -> Vec3) -> (Vec3, Vec3) {
    let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
    for _ in 0..n {
        let v = f();
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / n as f32;
    let sigma = ((sum2 / n as f32 - mean * mean).max(Vec3::ZERO) / n as f32).sqrt();
    (mean, sigma)
}

/// E(wo) two ways: the mean sample weight (Dirac samples included), and
/// an independent estimate: cosine sampling of eval over the reflection
/// hemisphere, uniform over the transmission one, plus the pass-through's
/// weight.
fn albedos(bsdf: &Bsdf, wo: Vec3, n: usize, rng: &mut Pcg32) -> [(Vec3, Vec3); 2] {
    let sampled = estimate(n, || {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        bsdf.sample(wo, rng.next_f32(), u)
            .map_or(Vec3::ZERO, |s| s.weight)
    });
    // The pass-through is the last lobe: u_lobe just below 1 picks it
    // when it has weight, and weight * pdf is its weight.
    let pass = bsdf
        .sample(wo, 1.0 - f32::EPSILON, Vec2::splat(0.5))
        .filter(|s| s.delta)
        .map_or(Vec3::ZERO, |s| s.weight * s.pdf);
    let (independent, sigma) = estimate(n, || {
        let wi = warp::square_to_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let up = bsdf.eval(wo, wi) / warp::cosine_hemisphere_pdf(wi.z);
        let mut down = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        down.z = -down.z.abs();
        up + bsdf.eval(wo, down) * (2.0 * std::f32::consts::PI)
    });
    [sampled, (independent + pass, sigma)]
}

/// Where the specification's model conserves energy: every combination
/// with white inputs reflects (or transmits) E = 1 within 1% and 4 sigma
/// by BSDF sampling, and within 4 sigma by the independent estimate.
/// Measured values are printed (`--nocapture`).
#[test]
fn white_furnaces_conserve_energy() {
    let mut rng = Pcg32::new(21, 0);
    let coated = |mut i: OpenPbrInputs| {
        i.coat_weight = 1.0;
        i.coat_roughness = 0.3;
        i
    };
    let cases = [
        ("diffuse r0", white_diffuse(0.0)),
        ("diffuse r1", white_diffuse(1.0)),
        ("metal 0.2", white_metal(0.2)),
        ("metal 0.6", white_metal(0.6)),
        ("metal 1.0", white_metal(1.0)),
        ("dielectric 0.3 over diffuse", white_plastic(0.3)),
        ("dielectric 0.8 over diffuse", white_plastic(0.8)),
        ("coat over metal", coated(white_metal(0.4))),
        ("coat over plastic", coated(white_plastic(0.3))),
        (
            "fuzz over diffuse",
            inputs(|i| {
                i.base_color = Vec3::ONE;
                i.specular_weight = 0.0;
                i.fuzz_weight = 1.0;
                i.fuzz_roughness = 0.4;
            }),
        ),
        (
            "thin-walled transmission",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.specular_roughness = 0.3;
                i.geometry_thin_walled = true;
            }),
        ),
        (
            "half-present plastic",
            inputs(|i| {
                i.base_color = Vec3::ONE;
                i.geometry_opacity = 0.5;
            }),
        ),
    ];
    for (name, i) in cases {
        for wo in directions(&[1.0, 0.5, 0.15]) {
            let bsdf = Bsdf::from_open_pbr(&i, &frames(0.0, true), wo);
            let [sampled, independent] = albedos(&bsdf, wo, 20_000, &mut rng);
            for (how, (mean, sigma), cap) in [
                ("sampled", sampled, 0.01),
                ("independent", independent, 1.0),
            ] {
                eprintln!(
                    "{name} cos {:.2} {how}: {:.4} +- {:.4}",
                    wo.z, mean.x, sigma.x
                );
                let bound = (4.0 * sigma.x + 2e-3).min(cap);
                assert!(
                    (mean.x - 1.0).abs() <= bound,
                    "{name} cos {} ({how}): {mean} +- {sigma}",
                    wo.z
                );
            }
        }
    }
}

/// A thin film only moves light between reflection and what the specular
/// layer lets through (OpenPBR 1.1: it "should not violate energy
/// conservation"): over white diffuse, every channel still reads 1 within
/// 3.5% and 4 sigma (the film's directional albedo is approximated by the
/// filmless one scaled by the Fresnel ratio at wo: measured worst 1.030,
/// green, 0.5 um of ior 2 at cos 0.15; 0.3% or less at normal incidence); on a
/// white-ish metal it never exceeds 1. Its colour shows: the channels of
/// the film's specular differ.
#[test]
fn a_thin_film_colours_without_creating_energy() {
    let mut rng = Pcg32::new(25, 0);
    let film = |mut i: OpenPbrInputs, thickness: f32, ior: f32| {
        i.thin_film_weight = 1.0;
        i.thin_film_thickness = thickness;
        i.thin_film_ior = ior;
        i
    };
    for (thickness, ior) in [(0.3, 1.4), (0.5, 2.0), (0.8, 1.6)] {
        for wo in directions(&[1.0, 0.5, 0.15]) {
            let plastic = film(white_plastic(0.3), thickness, ior);
            let bsdf = Bsdf::from_open_pbr(&plastic, &frames(0.0, true), wo);
            let [(mean, sigma), _] = albedos(&bsdf, wo, 20_000, &mut rng);
            eprintln!(
                "film {thickness} um ior {ior} over diffuse, cos {:.2}: {mean} +- {sigma}",
                wo.z
            );
            let bound = 4.0 * sigma + Vec3::splat(0.035);
            assert!(
                (mean - Vec3::ONE).abs().cmple(bound).all(),
                "{mean} +- {sigma}"
            );
            let metal = film(white_metal(0.3), thickness, ior);
            let bsdf = Bsdf::from_open_pbr(&metal, &frames(0.0, true), wo);
            let [(mean, sigma), _] = albedos(&bsdf, wo, 20_000, &mut rng);
            eprintln!(
                "film {thickness} um ior {ior} on metal, cos {:.2}: {mean} +- {sigma}",
                wo.z
            );
            assert!(
                (mean - 4.0 * sigma).cmple(Vec3::ONE).all(),
                "{mean} +- {sigma}"
            );
        }
        let specular_only = film(
            inputs(|i| {
                i.base_color = Vec3::ZERO;
                i.specular_roughness = 0.2;
            }),
            thickness,
            ior,
        );
        let wo = directions(&[0.8])[0];
        let bsdf = Bsdf::from_open_pbr(&specular_only, &frames(0.0, true), wo);
        let [(mean, sigma), _] = albedos(&bsdf, wo, 20_000, &mut rng);
        let spread = mean.max_element() - mean.min_element();
        assert!(
            spread > 8.0 * sigma.max_element(),
            "film {thickness}: {mean} +- {sigma}"
        );
    }
}

/// A lossless film over thick smooth glass only moves light between
/// reflection and transmission: per channel, the reflected E_R plus the
/// transmitted E_T times eta^2 (undoing the radiance scaling of refraction)
/// is 1 within 1% and 4 sigma, from outside and from inside (where cos 0.5
/// and 0.15 are totally reflected), at cos 1, 0.85, 0.5, 0.15. The reflection is the
/// film's over the same glass as on an opaque specular layer (the existing
/// film model) within 4 sigma, at normal incidence and at cos 0.5. A thin
/// wall with the film reflects and passes E = 1 within 1% and 4 sigma.
#[test]
fn a_thin_film_on_glass_conserves_energy() {
    let mut rng = Pcg32::new(26, 0);
    let film = |thickness: f32, ior: f32, transmission: f32| {
        inputs(|i| {
            i.base_color = Vec3::ZERO;
            i.specular_roughness = 0.0;
            i.transmission_weight = transmission;
            i.thin_film_weight = 1.0;
            i.thin_film_thickness = thickness;
            i.thin_film_ior = ior;
        })
    };
    let n = 20_000;
    for (thickness, ior) in [(0.3, 1.4), (0.5, 2.0)] {
        let glass = film(thickness, ior, 1.0);
        for (front, eta) in [(true, 1.5f32), (false, 1.0 / 1.5)] {
            for wo in directions(&[1.0, 0.85, 0.5, 0.15]) {
                let bsdf = Bsdf::from_open_pbr(&glass, &frames(0.0, front), wo);
                let (mut reflected, mut total) = (Vec::new(), Vec::new());
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let s = bsdf.sample(wo, rng.next_f32(), u);
                    let (r, t) = s.map_or((Vec3::ZERO, Vec3::ZERO), |s| {
                        if s.wi.z > 0.0 {
                            (s.weight, Vec3::ZERO)
                        } else {
                            (Vec3::ZERO, s.weight * eta * eta)
                        }
                    });
                    reflected.push(r);
                    total.push(r + t);
                }
                let mut it = total.into_iter();
                assert_unit_energy(
                    &format!("film {thickness} um ior {ior} on glass, front {front}, cos {:.2}: R + eta^2 T", wo.z),
                    estimate(n, || it.next().unwrap()),
                );
                if !front || wo.z < 0.5 {
                    continue;
                }
                let mut it = reflected.into_iter();
                let (r, r_sigma) = estimate(n, || it.next().unwrap());
                let opaque =
                    Bsdf::from_open_pbr(&film(thickness, ior, 0.0), &frames(0.0, true), wo);
                let [(e, e_sigma), _] = albedos(&opaque, wo, n, &mut rng);
                eprintln!("  reflected {r} +- {r_sigma}, on an opaque layer {e} +- {e_sigma}");
                let bound =
                    4.0 * (r_sigma * r_sigma + e_sigma * e_sigma).sqrt() + Vec3::splat(2e-3);
                assert!((r - e).abs().cmple(bound).all(), "{r} vs {e}");
            }
        }
        // A thin wall with the film on the face towards wo: what it does not
        // reflect passes straight through (no eta^2 to undo).
        let mut wall = glass;
        wall.geometry_thin_walled = true;
        for wo in directions(&[1.0, 0.5, 0.15]) {
            let bsdf = Bsdf::from_open_pbr(&wall, &frames(0.0, true), wo);
            let [sampled, _] = albedos(&bsdf, wo, n, &mut rng);
            let what = format!(
                "film {thickness} um ior {ior} on a thin wall, cos {:.2}",
                wo.z
            );
            assert_unit_energy(&what, sampled);
        }
    }
}

/// Every channel of the estimate `(mean, sigma)` is 1 within 1% and 4
/// sigma (printed with `what`).
fn assert_unit_energy(what: &str, (mean, sigma): (Vec3, Vec3)) {
    eprintln!("{what}: {mean} +- {sigma}");
    let bound = (4.0 * sigma + Vec3::splat(2e-3)).min(Vec3::splat(0.01));
    assert!(
        (mean - Vec3::ONE).abs().cmple(bound).all(),
        "{what}: {mean} +- {sigma}"
    );
}

/// Where energy is lost on purpose, E stays below 1 (4 sigma) and above a
/// floor: coat absorption (coat_color 0.5), coat darkening over a grey
/// base, a tinted specular (specular_color 0.2: the spec tints reflection
/// only) and thick rough glass: refracted radiance is scaled by 1/eta^2
/// (Veach 1997), so E is about F + (1 - F)/eta^2 = 0.47 for smooth glass
/// of ior 1.5, less the single-scattering loss when rough.
#[test]
fn deliberate_losses_stay_below_one() {
    let mut rng = Pcg32::new(22, 0);
    let cases = [
        (
            "absorbing coat",
            inputs(|i| {
                i.base_color = Vec3::ONE;
                i.coat_weight = 1.0;
                i.coat_color = Vec3::splat(0.5);
            }),
            0.3,
        ),
        (
            "tinted specular",
            inputs(|i| {
                i.base_color = Vec3::ONE;
                i.specular_color = Vec3::splat(0.2);
            }),
            0.9,
        ),
        (
            "thick rough glass",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.specular_roughness = 0.8;
            }),
            0.3,
        ),
    ];
    for (name, i, floor) in cases {
        for wo in directions(&[0.9, 0.4]) {
            let bsdf = Bsdf::from_open_pbr(&i, &frames(0.0, true), wo);
            let [(mean, sigma), _] = albedos(&bsdf, wo, 20_000, &mut rng);
            eprintln!("{name} cos {:.2}: {:.4} +- {:.4}", wo.z, mean.x, sigma.x);
            assert!(
                mean.x <= 1.0 + 4.0 * sigma.x && mean.x < 0.999,
                "{name}: {mean}"
            );
            assert!(mean.x >= floor, "{name}: {mean} below {floor}");
        }
    }
    // Darkening: a grey base under a clear coat is darker with
    // coat_darkening 1 than 0, and 0 keeps the uncoated albedo's Fresnel
    // blend lerp(F0, 1, E_b) at normal incidence within 2%.
    let grey = |darkening: f32| {
        inputs(|i| {
            i.base_color = Vec3::splat(0.5);
            i.specular_weight = 0.0;
            i.coat_weight = 1.0;
            i.coat_darkening = darkening;
        })
    };
    let wo = Vec3::Z;
    let e = |i: &OpenPbrInputs, rng: &mut Pcg32| {
        albedos(
            &Bsdf::from_open_pbr(i, &frames(0.0, true), wo),
            wo,
            40_000,
            rng,
        )[0]
        .0
        .x
    };
    let (dark, bright) = (e(&grey(1.0), &mut rng), e(&grey(0.0), &mut rng));
    let f0 = super::fresnel::f0_from_ior(1.6);
    eprintln!(
        "darkening 1: {dark:.4}, 0: {bright:.4}, undarkened {:.4}",
        f0 + 0.5 * (1.0 - f0)
    );
    assert!(dark < bright - 0.02, "{dark} vs {bright}");
    assert!((bright - (f0 + 0.5 * (1.0 - f0))).abs() < 0.02, "{bright}");
}

/// A spread of materials exercising every lobe (and anisotropy, a tilted
/// coat frame, thick glass from inside).
fn configurations() -> Vec<(&'static str, OpenPbrInputs, ShadingFrames)> {
    vec![
        (
            "rough diffuse",
            inputs(|i| i.base_diffuse_roughness = 0.8),
            frames(0.0, true),
        ),
        (
            "anisotropic metal",
            inputs(|i| {
                i.base_metalness = 1.0;
                i.base_color = Vec3::new(0.9, 0.6, 0.3);
                i.specular_color = Vec3::new(0.8, 0.9, 1.0);
                i.specular_roughness = 0.5;
                i.specular_roughness_anisotropy = 0.7;
            }),
            frames(0.0, true),
        ),
        (
            "coated plastic, tilted coat",
            inputs(|i| {
                i.coat_weight = 0.7;
                i.coat_roughness = 0.2;
                i.coat_color = Vec3::new(0.9, 0.7, 0.5);
                i.fuzz_weight = 0.5;
            }),
            frames(0.3, true),
        ),
        (
            "thick glass",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.transmission_color = Vec3::new(0.9, 0.8, 0.7);
                i.specular_roughness = 0.4;
            }),
            frames(0.0, true),
        ),
        (
            "thick glass from inside",
            inputs(|i| {
                i.transmission_weight = 0.8;
                i.specular_roughness = 0.5;
            }),
            frames(0.0, false),
        ),
        (
            "thick glass with a film",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.specular_roughness = 0.3;
                i.thin_film_weight = 0.8;
                i.thin_film_ior = 2.0;
            }),
            frames(0.0, true),
        ),
        (
            "thick glass with a film, from inside",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.specular_roughness = 0.3;
                i.thin_film_weight = 1.0;
                i.thin_film_thickness = 0.3;
            }),
            frames(0.0, false),
        ),
        (
            "thin wall with a film",
            inputs(|i| {
                i.transmission_weight = 0.7;
                i.specular_roughness = 0.4;
                i.geometry_thin_walled = true;
                i.thin_film_weight = 1.0;
            }),
            frames(0.0, true),
        ),
        (
            "thin wall, half present",
            inputs(|i| {
                i.transmission_weight = 0.6;
                i.geometry_thin_walled = true;
                i.geometry_opacity = 0.5;
            }),
            frames(0.0, true),
        ),
    ]
}

#[test]
fn sampled_pdf_and_weight_match_pdf_and_eval() {
    let mut rng = Pcg32::new(23, 0);
    for (name, i, f) in configurations() {
        for wo in directions(&[0.9, 0.4, 0.1]) {
            let bsdf = Bsdf::from_open_pbr(&i, &f, wo);
            for _ in 0..2000 {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let Some(s) = bsdf.sample(wo, rng.next_f32(), u) else {
                    continue;
                };
                assert!((s.wi.length() - 1.0).abs() < 1e-4, "{name}");
                if s.delta {
                    assert!((s.wi + wo).length() < 1e-6, "{name}");
                    continue;
                }
                let (pdf, f) = (bsdf.pdf(wo, s.wi), bsdf.eval(wo, s.wi));
                let close = |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.abs().max(b.abs());
                assert!(close(s.pdf, pdf), "{name} {wo}: {} vs {pdf}", s.pdf);
                for c in 0..3 {
                    assert!(
                        close(s.weight[c], f[c] / pdf),
                        "{name}: {} vs {}",
                        s.weight,
                        f / pdf
                    );
                }
                let split = bsdf.eval_split(wo, s.wi);
                assert!((split.total() - f).abs().max_element() <= 1e-6 * f.max_element());
            }
        }
    }
}

/// The pdf integrates (uniform-sphere estimate) to the fraction of
/// `sample` calls that return a non-Dirac direction, and eval_split's
/// categories land where they belong: no transmission on the reflection
/// side, nothing but transmission across.
#[test]
fn pdf_integrates_to_the_sampled_fraction() {
    let mut rng = Pcg32::new(27, 0);
    let n = 100_000;
    for (name, i, f) in configurations() {
        let wo = directions(&[0.7])[0];
        let bsdf = Bsdf::from_open_pbr(&i, &f, wo);
        let (mut sum, mut sum2, mut hits) = (0.0f64, 0.0f64, 0usize);
        for _ in 0..n {
            let wi = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let v = f64::from(bsdf.pdf(wo, wi)) * 4.0 * std::f64::consts::PI;
            sum += v;
            sum2 += v * v;
            let split = bsdf.eval_split(wo, wi);
            if wi.z > 0.0 {
                assert_eq!(split.transmission, Vec3::ZERO, "{name}");
            } else {
                assert_eq!(split.diffuse + split.specular, Vec3::ZERO, "{name}");
            }
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            hits += usize::from(bsdf.sample(wo, rng.next_f32(), u).is_some_and(|s| !s.delta));
        }
        let integral = sum / n as f64;
        let sigma_i = ((sum2 / n as f64 - integral * integral) / n as f64).sqrt();
        let fraction = hits as f64 / n as f64;
        let sigma = (sigma_i * sigma_i + fraction * (1.0 - fraction) / n as f64).sqrt();
        assert!(
            (integral - fraction).abs() <= 4.0 * sigma + 1e-4,
            "{name}: integral {integral} +- {sigma_i}, sampled {fraction}"
        );
    }
}

/// Each lobe's sampling against its density, by a chi-square test
/// ([`assert_samples_follow_density`]).
#[test]
fn each_lobe_samples_its_density() {
    let mut rng = Pcg32::new(24, 0);
    let lobes = [
        (
            "eon",
            inputs(|i| {
                i.specular_weight = 0.0;
                i.base_diffuse_roughness = 1.0;
            }),
        ),
        (
            "anisotropic ggx",
            inputs(|i| {
                i.base_metalness = 1.0;
                i.specular_roughness = 0.6;
                i.specular_roughness_anisotropy = 0.5;
            }),
        ),
        (
            "walter",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.specular_roughness = 0.6;
            }),
        ),
        (
            "walter under a film",
            inputs(|i| {
                i.transmission_weight = 1.0;
                i.specular_roughness = 0.6;
                i.thin_film_weight = 1.0;
                i.thin_film_ior = 2.0;
            }),
        ),
        (
            "coat",
            inputs(|i| {
                i.base_color = Vec3::ZERO;
                i.specular_weight = 0.0;
                i.coat_weight = 1.0;
                i.coat_roughness = 0.5;
            }),
        ),
        (
            "fuzz",
            inputs(|i| {
                i.base_color = Vec3::ZERO;
                i.specular_weight = 0.0;
                i.fuzz_weight = 1.0;
                i.fuzz_roughness = 0.6;
            }),
        ),
    ];
    for (name, i) in lobes {
        let wo = directions(&[0.6])[0];
        let bsdf = Bsdf::from_open_pbr(&i, &frames(0.0, true), wo);
        assert_samples_follow_density(
            name,
            |u_lobe, u| bsdf.sample(wo, u_lobe, u).map(|s| (s.wi, s.delta)),
            |wi| bsdf.pdf(wo, wi),
            &mut rng,
        );
    }
}

/// EON (any colour and roughness) and a smooth metal (compensation
/// factor 1) are reciprocal; the compensated rough lobes and albedo-scaled
/// layers are not, as the specification's albedo scaling is not.
#[test]
fn reciprocal_where_the_model_is() {
    let mut rng = Pcg32::new(25, 0);
    let cases = [
        inputs(|i| {
            i.base_color = Vec3::new(0.7, 0.3, 0.9);
            i.base_diffuse_roughness = 0.6;
            i.specular_weight = 0.0;
        }),
        inputs(|i| {
            i.base_metalness = 1.0;
            i.base_color = Vec3::new(0.9, 0.5, 0.2);
            i.specular_roughness = 0.05;
        }),
    ];
    for i in cases {
        for _ in 0..300 {
            let mut a = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let mut b = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            a.z = a.z.abs().max(0.05);
            b.z = b.z.abs().max(0.05);
            let (a, b) = (a.normalize(), b.normalize());
            let ab = Bsdf::from_open_pbr(&i, &frames(0.0, true), a).eval(a, b) / b.z;
            let ba = Bsdf::from_open_pbr(&i, &frames(0.0, true), b).eval(b, a) / a.z;
            assert!(
                (ab - ba).abs().max_element() <= 2e-3 * ab.max_element().max(1e-2),
                "{ab} vs {ba}"
            );
        }
    }
}

/// Out-of-range, zero and degenerate inputs and grazing directions give
/// finite, non-negative values everywhere.
#[test]
fn degenerate_inputs_stay_finite() {
    let mut rng = Pcg32::new(26, 0);
    let mut cases: Vec<OpenPbrInputs> = vec![
        inputs(|i| {
            i.specular_roughness = 0.0;
            i.coat_weight = 1.0;
            i.coat_roughness = 0.0;
            i.specular_ior = 1.0;
            i.coat_ior = 1.0;
        }),
        inputs(|i| {
            i.base_color = Vec3::ZERO;
            i.specular_color = Vec3::ZERO;
            i.transmission_weight = 1.0;
            i.transmission_color = Vec3::ZERO;
            i.specular_ior = 1.0;
        }),
        inputs(|i| {
            i.geometry_opacity = 0.0;
        }),
    ];
    for _ in 0..40 {
        let mut v = || rng.next_f32() * 3.0 - 1.0;
        cases.push(inputs(|i| {
            i.base_weight = v();
            i.base_color = Vec3::new(v(), v(), v());
            i.base_diffuse_roughness = v();
            i.base_metalness = v();
            i.specular_weight = v() * 3.0;
            i.specular_roughness = v();
            i.specular_roughness_anisotropy = v();
            i.specular_ior = v() * 2.0;
            i.transmission_weight = v();
            i.subsurface_weight = v();
            i.fuzz_weight = v();
            i.fuzz_roughness = v();
            i.coat_weight = v();
            i.coat_roughness = v();
            i.coat_color = Vec3::new(v(), v(), v());
            i.coat_ior = v() * 2.0;
            i.coat_darkening = v();
            i.geometry_opacity = v();
            i.geometry_thin_walled = v() > 0.5;
        }));
    }
    for i in &cases {
        for wo in directions(&[1.0, 0.3, 1e-4]) {
            let bsdf = Bsdf::from_open_pbr(i, &frames(0.2, wo.z > 0.1), wo);
            assert!(bsdf.albedo().is_finite());
            for _ in 0..100 {
                let wi = warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let (f, pdf) = (bsdf.eval(wo, wi), bsdf.pdf(wo, wi));
                assert!(f.is_finite() && f.min_element() >= 0.0, "{i:?}: {f}");
                assert!(pdf.is_finite() && pdf >= 0.0, "{i:?}: {pdf}");
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                if let Some(s) = bsdf.sample(wo, rng.next_f32(), u) {
                    assert!(s.weight.is_finite() && s.pdf > 0.0, "{i:?}: {s:?}");
                }
            }
        }
    }
    let gone = Bsdf::from_open_pbr(&cases[2], &frames(0.0, true), Vec3::Z);
    assert!(gone.is_delta());
}
