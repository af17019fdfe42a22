//! The unidirectional path tracer for surfaces: next-event estimation and
//! BSDF sampling combined by multiple importance sampling (Veach 1997, ch. 9,
//! power heuristic), Russian roulette, a maximum depth. See the radiance
//! estimator of the path integral in `../shared/seeds/` and pbrt-v4's
//! `PathIntegrator::Li` (§13.4), which this follows.

use glam::Vec3;

use super::{PathSettings, RayCounts, Strategy};
use crate::render_state::RenderState;
use crate::sampling::warp::power_heuristic;
use crate::sampling::Sampler;

/// Depth (bounces) from which Russian roulette may end a path.
const ROULETTE_DEPTH: u32 = 3;

/// Highest survival probability of Russian roulette: even a path whose
/// throughput stays 1 (a white furnace) ends, with 5% chance per bounce.
const MAX_SURVIVAL: f32 = 0.95;

/// What the last bounce knows about how the current ray was chosen, for the
/// MIS weight of emission the ray finds.
#[derive(Clone, Copy)]
struct Bounce {
    /// Solid-angle density of the BSDF sample that made the ray.
    pdf: f32,
    /// The ray left the camera or a Dirac lobe: light sampling could not
    /// have found what it hits, so emission counts in full.
    specular: bool,
}

/// Radiance arriving at the camera along a camera ray, W/(m^2 sr): one
/// sample of the path-integral estimator. The sampler must be positioned at
/// the first path dimension; each bounce consumes the same number of
/// dimensions whether or not it uses them, so dimensions stay aligned
/// between pixel samples.
pub fn radiance(
    state: &RenderState,
    mut ray: obvhs::ray::Ray,
    sampler: &mut Sampler,
    settings: &PathSettings,
    counts: &mut RayCounts,
) -> Vec3 {
    let (geometry, materials, lights) = (&state.geometry, &state.materials, &state.lights);
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    let mut bounce = Bounce {
        pdf: 1.0,
        specular: true,
    };
    // Weight of emission found by a BSDF-sampled ray whose light-sampling
    // density at that point is `light_pdf`.
    let emission_weight = |bounce: Bounce, light_pdf: f32| {
        if bounce.specular {
            return 1.0;
        }
        match settings.strategy {
            Strategy::Mis => power_heuristic(bounce.pdf, light_pdf),
            Strategy::Bsdf => 1.0,
            Strategy::Nee => 0.0,
        }
    };
    for depth in 0.. {
        counts.closest += 1;
        let hit = geometry.intersect(&ray);
        let (origin, direction) = (Vec3::from(ray.origin), Vec3::from(ray.direction));
        let t_surface = hit.map_or(ray.tmax, |h| h.t);
        if let Some(light) = lights.intersect(origin, direction, t_surface) {
            radiance += throughput * light.radiance * emission_weight(bounce, light.pdf);
            break;
        }
        let Some(hit) = hit else {
            lights.escaped(direction, |le, pdf| {
                radiance += throughput * le * emission_weight(bounce, pdf);
            });
            break;
        };
        let sp = geometry.surface_point(&hit);
        let wo = -direction;
        if materials.is_emissive(sp.material) && (sp.double_sided || wo.dot(sp.ng) > 0.0) {
            let weight = emission_weight(bounce, lights.mesh_pdf(&sp, origin));
            radiance += throughput * materials.emission(sp.material, sp.uv) * weight;
        }
        if depth >= settings.max_depth {
            break;
        }
        let bsdf = materials.bsdf(&sp, wo);
        // Next-event estimation: one light sample.
        let (u_light, u_light_2d) = (sampler.next_1d(), sampler.next_2d());
        if settings.strategy != Strategy::Bsdf && !bsdf.is_delta() {
            if let Some(ls) = lights.sample(materials, sp.p, u_light, u_light_2d) {
                let f = bsdf.eval(wo, ls.wi);
                if ls.pdf > 0.0 && f != Vec3::ZERO {
                    counts.shadow += 1;
                    if !geometry.occluded(&sp.shadow_ray(ls.wi, ls.distance)) {
                        let weight = if ls.delta || settings.strategy == Strategy::Nee {
                            1.0
                        } else {
                            power_heuristic(ls.pdf, bsdf.pdf(wo, ls.wi))
                        };
                        radiance += throughput * f * ls.radiance * (weight / ls.pdf);
                    }
                }
            }
        }
        // BSDF sampling continues the path.
        let (u_lobe, u_bsdf, u_roulette) =
            (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
        let Some(bs) = bsdf.sample(wo, u_lobe, u_bsdf) else {
            break;
        };
        throughput *= bs.weight;
        bounce = Bounce {
            pdf: bs.pdf,
            specular: bs.delta,
        };
        if depth + 1 >= ROULETTE_DEPTH {
            let survival = throughput.max_element().min(MAX_SURVIVAL);
            if u_roulette >= survival {
                break;
            }
            throughput /= survival;
        }
        ray = sp.spawn_ray(bs.wi);
    }
    // Clamping would hide a NaN (f32::min drops it): non-finite samples
    // pass through for the film to count.
    match settings.clamp {
        Some(max) if radiance.is_finite() => radiance.min(Vec3::splat(max)),
        _ => radiance,
    }
}
