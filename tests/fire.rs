//! Emitting volumes as lights (`--volume-light-sampling`, on by default),
//! end to end through `cirrus render`: the irradiance an emitting box puts
//! on a plane against its numerical integral, with and without light
//! sampling; both ways against each other on a fireball; and the default
//! depth against an unbounded one in a dense cloud (defaults never bias).
//! Statistics as in tests/render.rs: per-pixel residuals, 4 sigma.

mod common;

use std::f64::consts::PI;

use common::estimate;
use common::render::Render;

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
