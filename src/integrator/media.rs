//! The path tracer's work inside media: free flights by delta tracking with
//! absorption, scattering and null events (pbrt-v4's `VolPathIntegrator`),
//! and equiangular sampling of point-like lights (Kulla & Fajardo 2012)
//! MIS-combined with them.

use glam::{Vec2, Vec3};

use super::shadow::{visibility, PathCounts};
use super::{PathSettings, Strategy};
use crate::geometry::shadow_ray;
use crate::lights::{EquiangularTarget, Receiver};
use crate::render_state::RenderState;
use crate::sampling::warp::{power_heuristic, Equiangular};
use crate::sampling::Pcg32;
use crate::volumes::estimators::{
    channel_mean, ratio_tracking_with_null_ratio, walk_tentative_collisions, PassThrough,
    TrackingStats,
};
use crate::volumes::{MajorantSegment, MediaRay, MediumPoint};

/// How a free flight through media ended.
pub(super) enum FlightEnd {
    /// It reached the end of the ray (the surface, light or infinity).
    Left,
    /// A real collision absorbed it.
    Absorbed,
    /// A real collision at ray parameter `t` scattered it; `albedo` =
    /// sigma_s / sigma_t there per channel; `sigma_s` is the channel mean of
    /// sigma_s, for the MIS weights that compare distance sampling with
    /// equiangular sampling.
    Scattered { t: f32, albedo: Vec3, sigma_s: f32 },
}

/// A free flight and what it gathered on the way.
pub(super) struct FreeFlight {
    /// How it ended.
    pub(super) end: FlightEnd,
    /// Emission collected at the tentative collisions, sum of
    /// throughput x sigma_a Le / sigma_maj x its MIS weight, W/(m^2 sr).
    pub(super) emission: Vec3,
    /// The path throughput after the flight's collision weights (unchanged
    /// in mean over channels; equal to the throughput it started with when
    /// extinction and albedo are grey).
    pub(super) throughput: Vec3,
    /// Product of sigma_maj / mean(sigma_n) over the null collisions: the
    /// light strategy's density of these null vertices over delta
    /// tracking's, the same quantity ratio tracking reports for shadow rays.
    pub(super) null_ratio: f32,
    /// With `pass_through`: ratio tracking's estimate of the transmittance
    /// of the whole ray, per channel, from the same tentative collisions
    /// (0 when Russian roulette ended it); 1 otherwise.
    pub(super) pass: Vec3,
}

/// Samples a free flight along `along` over `[t_min, t_max)` by delta
/// tracking with absorption, scattering and null events (pbrt-v4's
/// `VolPathIntegrator`, Miller et al. 2019), for a path arriving with
/// `throughput`: at each tentative collision the emission
/// throughput x sigma_a Le / sigma_maj is added (unbiased: tentative
/// collisions have rate sigma_maj, and each is reached with probability T),
/// then one uniform number picks a real or a null collision with
/// probabilities proportional to mean(throughput x sigma_t) and
/// mean(throughput x sigma_n). A real collision scatters, its throughput
/// taking sigma_s / (sigma_maj P_real) per channel (the albedo when grey):
/// absorption weights the path rather than ending it, and Russian roulette
/// ends it later (ending it here as well, as analog absorption did, cost a
/// roulette kill on top of each absorption: 1.3-1.6x the variance per
/// sample on the benchmark clouds, docs/benchmarks.md "Volumes"); only
/// where nothing scatters (sigma_s = 0) is it absorbed. A null collision
/// takes sigma_n / (sigma_maj P_null). This is spectral tracking (Kutz et
/// al. 2017, history-aware averaged probabilities): the one-sample spectral
/// MIS of a random hero channel with the balance heuristic, its choice
/// averaged out. The majorant is grey, so across a null collision the
/// throughput's channel mean is kept and no channel's weight can grow past
/// 3 times it; with grey extinction the null weights are 1.
///
/// With `pass_through` (camera rays, `--camera-ray-transmittance on`) the
/// walk goes on past the real collision to the end of the ray, and the same
/// tentative collisions give a ratio-tracking estimate of the whole ray's
/// transmittance with each segment's minorant sigma_c as control,
/// [`FreeFlight::pass`]: exp(-integral of sigma_c) times the product of
/// 1 - (sigma_t - sigma_c) / sigma_maj per channel over the collisions
/// (unbiased for any control, since the collisions have rate sigma_maj;
/// each factor lies in [sigma_c / sigma_maj, 1] while the bounds hold, so a
/// constant cell is exact), Russian-rouletted below 0.1 as for shadow rays.
/// Emission is then collected with that running weight (throughput x pass
/// up to t x sigma_a Le / sigma_maj at every tentative collision, whose
/// expectation is the integral of T sigma_a Le) instead of with delta
/// tracking's; the real collision is still the one delta tracking picks
/// (docs/volumes.md, "Camera rays").
///
/// Emission at a collision is weighted by `emission_weight(t, sigma_maj,
/// null_ratio)`: its MIS weight against light sampling of emitting volumes,
/// given the product of sigma_maj / sigma_n over the null collisions before
/// it (1 for the ratio-tracked pass-through, whose null collisions are all
/// taken, as light sampling's are; called only where something emits).
pub(super) fn free_flight(
    along: &MediaRay,
    (segments, pass_through): (impl IntoIterator<Item = MajorantSegment>, bool),
    throughput: Vec3,
    mut emission_weight: impl FnMut(f32, f32, f32) -> f32,
    rng: &mut Pcg32,
    stats: &mut TrackingStats,
) -> FreeFlight {
    let mut flight = FreeFlight {
        end: FlightEnd::Left,
        emission: Vec3::ZERO,
        throughput,
        null_ratio: 1.0,
        pass: Vec3::ONE,
    };
    let mut tracking = true;
    let pass = PassThrough::new();
    let segments = segments.into_iter().inspect(|s| pass.enter(s));
    walk_tentative_collisions(segments, rng, |t, sigma_maj, rng| {
        let point = along.at(t);
        stats.count_lookup(point.sigma_t, sigma_maj);
        if pass_through {
            let weight = pass.collide(t, sigma_maj, point.sigma_t, rng);
            if point.emission != Vec3::ZERO {
                let mis = emission_weight(t, sigma_maj, 1.0);
                flight.emission += throughput * weight * point.emission * (mis / sigma_maj);
            }
        }
        if tracking {
            tracking = delta_step(
                &mut flight,
                (t, sigma_maj, &point),
                pass_through,
                |t, n| emission_weight(t, sigma_maj, n),
                rng,
                stats,
            );
        }
        tracking || (pass_through && pass.alive())
    });
    if pass_through {
        flight.pass = if pass.alive() {
            pass.finish()
        } else {
            Vec3::ZERO
        };
    }
    flight
}

/// One tentative collision of delta tracking at `t` (see [`free_flight`]):
/// emission with delta tracking's weight unless `pass_through` collects it,
/// then absorption, scattering or a null collision; false once a real
/// collision ended the flight.
fn delta_step(
    flight: &mut FreeFlight,
    (t, sigma_maj, point): (f32, f32, &MediumPoint),
    pass_through: bool,
    mut emission_weight: impl FnMut(f32, f32) -> f32,
    rng: &mut Pcg32,
    stats: &mut TrackingStats,
) -> bool {
    let beta = flight.throughput;
    if point.emission != Vec3::ZERO && !pass_through {
        let weight = emission_weight(t, flight.null_ratio);
        flight.emission += beta * point.emission * (weight / sigma_maj);
    }
    let sigma_s = point.sigma_s.min(point.sigma_t);
    let sigma_a = point.sigma_t - sigma_s;
    let sigma_n = (Vec3::splat(sigma_maj) - point.sigma_t).max(Vec3::ZERO);
    let (ws, wa) = (channel_mean(beta * sigma_s), channel_mean(beta * sigma_a));
    let total = ws + wa + channel_mean(beta * sigma_n);
    let u = rng.next_f32() * total;
    if u < ws + wa || total <= 0.0 {
        stats.real_collisions += 1;
        // Absorption as a weight (see `free_flight`): E = P_real x weight = sigma_s / sigma_maj.
        flight.end = if ws > 0.0 {
            flight.throughput = beta * sigma_s * (total / (sigma_maj * (ws + wa)));
            FlightEnd::Scattered {
                t,
                albedo: sigma_s / point.sigma_t.max(Vec3::splat(f32::MIN_POSITIVE)),
                sigma_s: channel_mean(sigma_s),
            }
        } else {
            FlightEnd::Absorbed
        };
        return false;
    }
    stats.null_collisions += 1;
    flight.throughput = beta * sigma_n * (total / (sigma_maj * (total - ws - wa)));
    let grey_null = sigma_maj - channel_mean(point.sigma_t);
    flight.null_ratio *= sigma_maj / grey_null.max(1e-6 * sigma_maj);
    true
}

/// Equiangular sampling's view of one ray through media: the stretch
/// [a, b] of the ray inside them, and the point from which it picks a light.
pub(super) struct EquiangularRay {
    origin: Vec3,
    direction: Vec3,
    a: f32,
    b: f32,
    reference: Vec3,
}

impl EquiangularRay {
    /// Over the span of `segments`; `None` when they are empty.
    pub(super) fn new(origin: Vec3, direction: Vec3, segments: &[MajorantSegment]) -> Option<Self> {
        let (a, b) = (segments.first()?.t_min, segments.last()?.t_max);
        (b > a).then(|| Self {
            origin,
            direction,
            a,
            b,
            reference: origin + direction * (0.5 * (a + b)),
        })
    }

    /// The distribution of distances towards `centre`.
    fn towards(&self, centre: Vec3) -> Option<Equiangular> {
        Equiangular::new(self.origin, self.direction, centre, self.a, self.b)
    }

    /// Distance sampling's share of the NEE weight at a real scattering
    /// event it found at `t` (with mean sigma_s and the free flight's product
    /// of sigma_maj / sigma_n over its null collisions), when NEE there
    /// picked `light`: p1^2 / (p1^2 + p3^2), p3 / p1 = null ratio x
    /// P_eq(light) pdf_eq(t) / (sigma_s P_nee(light)) being equiangular
    /// sampling's density of the same null-scattering path over distance
    /// sampling's (the light point's density is common to both).
    pub(super) fn distance_share(
        &self,
        state: &RenderState,
        light: usize,
        (t, sigma_s, null_ratio): (f32, f32, f32),
    ) -> f32 {
        let lights = &state.lights;
        let Some(eq) = lights.centre(light).and_then(|c| self.towards(c)) else {
            return 1.0;
        };
        let p = self.origin + self.direction * t;
        let p3 =
            null_ratio * lights.probability(self.reference, light, Receiver::UNNAMED) * eq.pdf(t);
        let p1 = sigma_s * lights.probability(p, light, Receiver::UNNAMED);
        power_heuristic(p1, p3)
    }
}

/// One equiangular sample of single scattering along a ray through media
/// (Kulla & Fajardo 2012), to be multiplied by the path throughput: a
/// light equiangular sampling targets (sphere, point, rect, disk) picked
/// from the ray's midpoint, a distance t towards it, the transmittance up to t by ratio tracking, the medium's
/// sigma_s and phase function at t, and next-event estimation of that light
/// from there. It joins the two strategies of [`next_event`] and phase
/// sampling by a nested power heuristic: the light-sampled weight
/// p1^2 / (p1^2 + p2^2) of distance sampling with NEE (p1) against phase
/// sampling (p2), split between distance (p1) and equiangular (p3)
/// sampling as p1^2 / (p1^2 + p3^2) and p3^2 / (p1^2 + p3^2); the weights of
/// every path still sum to one.
pub(super) fn equiangular_sample(
    state: &RenderState,
    settings: &PathSettings,
    (along, segments, eq, time): (&MediaRay, &[MajorantSegment], &EquiangularRay, f32),
    rng: &mut Pcg32,
    counts: &mut PathCounts,
) -> Option<Vec3> {
    let lights = &state.lights;
    let EquiangularTarget {
        light,
        centre,
        probability: p_pick,
    } = lights.pick_equiangular_target(eq.reference, rng.next_f32())?;
    let distances = eq.towards(centre)?;
    let t = distances.sample(rng.next_f32()).clamp(eq.a, eq.b);
    let p_t = distances.pdf(t);
    let prefix = segments
        .iter()
        .filter(|s| s.t_min < t)
        .map(|s| MajorantSegment {
            t_max: s.t_max.min(t),
            ..*s
        });
    let (tr, null_prefix) =
        ratio_tracking_with_null_ratio(prefix, |x| along.sigma_t(x), rng, counts.tracking);
    if tr == Vec3::ZERO {
        return None;
    }
    let point = along.at(t);
    counts.tracking.density_lookups += 1;
    let sigma_s = channel_mean(point.sigma_s.min(point.sigma_t));
    if sigma_s <= 0.0 {
        return None;
    }
    let p = eq.origin + eq.direction * t;
    let wo = -eq.direction;
    let phase = along.phase(t, rng.next_f32());
    let u = Vec2::new(rng.next_f32(), rng.next_f32());
    let ls = lights.sample_light(state.emitters(time), light, p, u)?;
    let p_select = lights.probability(p, light, Receiver::UNNAMED);
    if ls.pdf.is_nan() || ls.pdf <= 0.0 || p_select <= 0.0 {
        return None;
    }
    let shadow = shadow_ray(p, ls.wi, ls.distance);
    let to = (light, Receiver::UNNAMED);
    let seen = visibility(state, settings, (&shadow, time), to, rng, counts);
    if seen.transmittance == Vec3::ZERO {
        return None;
    }
    let f = phase.eval(wo, ls.wi);
    let light_weight = if ls.delta || settings.strategy == Strategy::Nee {
        1.0
    } else {
        power_heuristic(p_select * ls.pdf, f * seen.null_ratio)
    };
    let p1 = null_prefix * sigma_s * p_select;
    let weight = light_weight * power_heuristic(p_pick * p_t, p1);
    Some(
        point.sigma_s
            * f
            * ls.radiance
            * (tr * seen.transmittance * weight / (p_pick * p_t * ls.pdf)),
    )
}
