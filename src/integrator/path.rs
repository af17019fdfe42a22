//! The unidirectional path tracer: next-event estimation and BSDF (or phase)
//! sampling combined by multiple importance sampling (Veach 1997, ch. 9,
//! power heuristic), Russian roulette, a maximum depth. See the radiance
//! estimator of the path integral in `../shared/seeds/` and pbrt-v4's
//! `PathIntegrator::Li` (§13.4), which this follows for surfaces.
//!
//! Media: along every ray, delta tracking over the merged majorant segments
//! (Woodcock tracking; Novák et al. 2018) walks tentative collisions up to the
//! surface or light the ray would reach, adding volume emission at each and
//! ending in absorption, a real scattering event or nothing (`free_flight`).
//! Real scattering samples the Henyey-Greenstein phase function, with light
//! sampling MIS-combined with phase sampling. Shadow rays multiply the
//! geometric visibility by an unbiased transmittance estimate. Under the
//! default null-scattering MIS (Miller, Georgiev & Jarosz 2019; pbrt-v4's
//! `VolPathIntegrator`) shadow rays use ratio tracking and the MIS weights
//! compare the densities of whole null-scattering paths: each strategy's
//! directional density times its probability of the null collisions along
//! the way (sigma_n / sigma_maj per collision for delta tracking, 1 for ratio
//! tracking), so where a medium is dense light sampling takes over. The other
//! `--volume-estimator`s weight by directional densities alone, which is
//! also unbiased since both strategies estimate the same transmittance.

use glam::{Vec2, Vec3};
use obvhs::ray::Ray;

use super::gathered::{lobe_shares, Gathered, VOLUME_EVENT};
use super::light_lobes::{scaled, LobeSplit};
use super::media::{equiangular_sample, free_flight, EquiangularRay, FlightEnd};
use super::shadow::{visibility, PathCounts};
use super::{PathSettings, Strategy, VolumeEstimator};
use crate::film::{AovSample, CameraHit};
use crate::geometry::{shadow_ray, Hit, SurfacePoint};
use crate::lights::{LightHit, LightSample, Receiver};
use crate::materials::Bsdf;
use crate::render_state::{HitAovs, RenderState};
use crate::sampling::warp::power_heuristic;
use crate::sampling::{Pcg32, Sampler};
use crate::scene::{LightLobes, NO_MATERIAL};
use crate::volumes::{HenyeyGreenstein, MajorantSegment, MediaRay, RaySegments};

/// Depth (bounces) from which Russian roulette may end a path.
const ROULETTE_DEPTH: u32 = 3;

/// Highest survival probability of Russian roulette: even a path whose
/// throughput stays 1 (a white furnace) ends, with 5% chance per bounce.
const MAX_SURVIVAL: f32 = 0.95;

/// What the last bounce knows about how the current ray was chosen, for the
/// MIS weight of emission the ray finds.
#[derive(Clone, Copy)]
struct Bounce {
    /// Solid-angle density of the BSDF or phase sample that made the ray.
    pdf: f32,
    /// The ray left the camera or a Dirac lobe: light sampling could not
    /// have found what it hits, so emission counts in full.
    specular: bool,
    /// The link set of the vertex the ray left: only the lights that light
    /// it are counted and weighed (the camera's sees every light).
    receiver: Receiver,
    /// How the sampled direction's BSDF value splits between the lobes
    /// lights' diffuse and specular factors scale.
    lobes: LobeSplit,
}

/// Per-sample random state beside the sampler: the tracking estimators draw
/// an unbounded number of random numbers, so they use their own generator.
pub struct PathRandom<'a> {
    /// Dimensions of the pixel sample.
    pub sampler: &'a mut Sampler,
    /// The generator for free-flight and transmittance tracking.
    pub tracking: &'a mut Pcg32,
}

/// Radiance arriving at the camera along a camera ray at its time (frames,
/// shared by the whole path), W/(m^2 sr): one sample of the path-integral
/// estimator, with what it gives every AOV (the first hit's Cryptomatte
/// ids and primvars only where `hit_aovs` asks for them). The
/// sampler must be positioned at the first path dimension; each bounce
/// consumes the same number of dimensions whether or not it uses them, so
/// dimensions stay aligned between pixel samples.
pub fn radiance(
    state: &RenderState,
    (ray, time): (Ray, f32),
    random: PathRandom,
    (settings, hit_aovs): (&PathSettings, &HitAovs),
    counts: PathCounts,
) -> (Vec3, AovSample) {
    let mut path = Path {
        state,
        settings,
        hit_aovs,
        time,
        sampler: random.sampler,
        rng: random.tracking,
        counts,
        gathered: Gathered::default(),
        throughput: Vec3::ONE,
        bounce: Bounce {
            pdf: 1.0,
            specular: true,
            receiver: Receiver::CAMERA,
            lobes: LobeSplit::Unscaled,
        },
        // Equiangular sampling of point-like lights from media, a third
        // strategy beside distance sampling with NEE or phase sampling.
        equiangular_on: settings.equiangular
            && settings.volume_estimator == VolumeEstimator::NullScatteringMis
            && settings.strategy != Strategy::Bsdf
            && !state.media.is_empty()
            && state.lights.has_equiangular_target(),
        behind: None,
    };
    // `depth` counts the scattering events before the current ray.
    let (mut next, mut depth) = (Some(ray), 0);
    loop {
        while let Some(ray) = next {
            next = path.extend(&ray, depth);
            depth += 1;
        }
        // The camera ray's pass-through, when its flight also scattered.
        let Some(behind) = path.behind.take() else {
            break;
        };
        (path.throughput, path.bounce) = (behind.throughput, behind.bounce);
        next = path.reach(&behind.end, 1.0, behind.depth);
        depth = behind.depth + 1;
    }
    // The camera's exposure scales what it records, after the clamp (which
    // bounds scene radiance).
    let exposure = state.camera.exposure_scale();
    let (radiance, mut aovs) = path.gathered.finish(settings.clamp);
    aovs.scale(Vec3::splat(exposure));
    (radiance * exposure, aovs)
}

/// One path being traced: what it has gathered, its throughput and how its
/// current ray was chosen.
struct Path<'a, 'r> {
    state: &'a RenderState,
    settings: &'a PathSettings,
    hit_aovs: &'a HitAovs,
    /// The camera sample's time, frames: every ray of the path is at it.
    time: f32,
    sampler: &'r mut Sampler,
    rng: &'r mut Pcg32,
    counts: PathCounts<'r>,
    gathered: Gathered,
    throughput: Vec3,
    bounce: Bounce,
    equiangular_on: bool,
    /// What the camera ray reaches behind the media, still to be followed
    /// when its free flight also scattered (`--camera-ray-transmittance`).
    behind: Option<Behind>,
}

/// What a ray reaches after the media on it: an area light, a surface
/// (with its shading point when already computed), or the sky.
#[derive(Clone, Copy)]
struct RayEnd {
    origin: Vec3,
    direction: Vec3,
    hit: Option<Hit>,
    surface: Option<SurfacePoint>,
    /// The analytic area light hit, with its index.
    light: Option<(usize, LightHit)>,
}

impl RayEnd {
    /// Whether the path would go on from there (a surface, not a light or
    /// the sky).
    fn continues(&self) -> bool {
        self.hit.is_some() && self.light.is_none()
    }
}

/// The end of a camera ray, reached through its media with `throughput`
/// (the ratio-tracking transmittance, Russian roulette included), to be
/// followed after the path its real scattering event started.
struct Behind {
    end: RayEnd,
    throughput: Vec3,
    bounce: Bounce,
    depth: u32,
}

/// Where a ray's free flight through media left the path.
enum AfterMedia {
    /// It reached the surface, light or sky the ray hits; `null_ratio` is
    /// the light strategy's density of the flight's null collisions over
    /// this one's (1 without null-scattering MIS, and for the camera ray's
    /// ratio-tracked pass-through).
    Reached { null_ratio: f32 },
    /// It scattered in the medium and continues along this ray.
    Scattered(Ray),
    /// A camera ray (`--camera-ray-transmittance on`) scattered and
    /// continues along `next`, and also reaches what lies behind the media
    /// with throughput `behind`.
    Both { next: Ray, behind: Vec3 },
    /// It ended in the medium.
    Ended,
}

impl Path<'_, '_> {
    /// Weight of emission found by a BSDF- or phase-sampled ray whose
    /// light-sampling density at that point is `light_pdf`; `null_ratio`
    /// turns that into the light strategy's density of the null-scattering
    /// path relative to this one's (1 without media).
    fn emission_weight(&self, light_pdf: f32, null_ratio: f32) -> f32 {
        emission_weight(self.settings.strategy, self.bounce, light_pdf, null_ratio)
    }

    /// Next-event estimation at `vertex` in link set `receiver`: one sample
    /// of the lights that light it (`u`: selection and position); `None`
    /// when it contributes nothing.
    fn next_event(
        &mut self,
        (vertex, receiver): (&Vertex, Receiver),
        (u_select, u): (f32, Vec2),
    ) -> Option<LightContribution> {
        let (state, settings) = (self.state, self.settings);
        let from = (vertex.position(), receiver);
        let (light, ls) = state
            .lights
            .sample(state.emitters(self.time), from, u_select, u)?;
        let f = vertex.f(ls.wi, state.lights.lobes(light));
        if ls.pdf.is_nan() || ls.pdf <= 0.0 || f == Vec3::ZERO {
            return None;
        }
        let shadow = vertex.shadow_ray(&ls);
        let shadow = (&shadow, self.time);
        let to = (light, receiver);
        let seen = visibility(state, settings, shadow, to, self.rng, &mut self.counts);
        if seen.transmittance == Vec3::ZERO {
            return None;
        }
        let weight = if ls.delta || settings.strategy == Strategy::Nee {
            1.0
        } else {
            power_heuristic(ls.pdf, vertex.pdf(ls.wi) * seen.null_ratio)
        };
        Some(LightContribution {
            light,
            f,
            li: ls.radiance * seen.transmittance * (weight / ls.pdf),
            wi: ls.wi,
        })
    }

    /// Follows `ray` (after `depth` scattering events) to its next
    /// scattering event, adding what it finds; the next ray, or `None`
    /// when the path ends.
    fn extend(&mut self, ray: &Ray, depth: u32) -> Option<Ray> {
        let (geometry, lights) = (&self.state.geometry, &self.state.lights);
        self.counts.rays.closest += 1;
        let hit = self.state.intersect(ray, self.time);
        let (origin, direction) = (Vec3::from(ray.origin), Vec3::from(ray.direction));
        let t_surface = hit.map_or(ray.tmax, |h| h.t);
        let from = (origin, self.bounce.receiver);
        let light_hit = lights.intersect(from, direction, t_surface, self.time);
        let t_end = light_hit.map_or(t_surface, |(_, l)| l.t);
        self.through_unlinked_blockers((origin, direction), t_end, depth);
        // The camera ray's surface hit feeds the geometric AOVs even when
        // the path scatters in a volume before reaching it.
        let mut camera_hit = None;
        if depth == 0 {
            camera_hit = hit.map(|h| geometry.surface_point(&h));
            let (state, wanted) = (self.state, self.hit_aovs);
            let aovs = &mut self.gathered.aovs;
            aovs.opaque = hit.is_some() || light_hit.is_some();
            aovs.hit = hit.zip(camera_hit).map(|(h, sp)| CameraHit {
                normal: sp.ns,
                position: sp.p,
                depth: state.camera.depth(sp.p),
                ids: state.id_names.ids(
                    &h,
                    (sp.material != NO_MATERIAL).then_some(sp.material),
                    wanted.crypto,
                ),
            });
            if let Some(sp) = &camera_hit {
                let site = sp.site();
                for (value, id) in aovs.primvars.iter_mut().zip(&wanted.primvars) {
                    let found = id.and_then(|id| state.materials.primvar(id, &site));
                    *value = found.map_or(Vec3::ZERO, |v| v.truncate());
                }
            }
        }
        let end = RayEnd {
            origin,
            direction,
            hit,
            surface: camera_hit,
            light: light_hit,
        };
        let bounce = self.bounce;
        match self.through_media(ray, depth, t_end, end.continues()) {
            AfterMedia::Reached { null_ratio } => self.reach(&end, null_ratio, depth),
            AfterMedia::Scattered(next) => Some(next),
            AfterMedia::Both { next, behind } => {
                self.behind = Some(Behind {
                    end,
                    throughput: behind,
                    bounce,
                    depth,
                });
                Some(next)
            }
            AfterMedia::Ended => None,
        }
    }

    /// The shadow-linked lights a BSDF- or phase-sampled `ray` (after
    /// `depth` scattering events) meets beyond `t_end`, where it stops, with
    /// nothing but parts transparent to them in between: their emission,
    /// as a dedicated light ray along the same direction finds it (Cycles'
    /// shadow linking), so that BSDF sampling finds what next-event
    /// estimation sees through those parts (docs/how-it-renders.md, "Light
    /// and shadow linking"). Its MIS weight complements next-event
    /// estimation's on every such path: ratio tracking's null ratio on
    /// both sides.
    fn through_unlinked_blockers(
        &mut self,
        (origin, direction): (Vec3, Vec3),
        t_end: f32,
        depth: u32,
    ) {
        let (state, settings, bounce) = (self.state, self.settings, self.bounce);
        if bounce.receiver == Receiver::CAMERA {
            return;
        }
        let mut found = smallvec::SmallVec::<[(usize, LightHit); 2]>::new();
        state.lights.beyond_linked_blockers(
            (origin, bounce.receiver),
            direction,
            (t_end, self.time),
            |light, hit| found.push((light, hit)),
        );
        for (light, hit) in found {
            let shadow = shadow_ray(origin, direction, hit.t);
            let shadow = (&shadow, self.time);
            let to = (light, bounce.receiver);
            let seen = visibility(state, settings, shadow, to, self.rng, &mut self.counts);
            if seen.transmittance == Vec3::ZERO {
                continue;
            }
            let weight = match settings.strategy {
                _ if bounce.specular || hit.pdf <= 0.0 => 1.0,
                Strategy::Mis => power_heuristic(bounce.pdf * seen.null_ratio, hit.pdf),
                Strategy::Bsdf => 1.0,
                Strategy::Nee => 0.0,
            };
            let factor = bounce.lobes.factor(state.lights.lobes(light));
            let c = self.throughput * hit.radiance * factor * seen.transmittance * weight;
            self.gathered.add(c, depth);
        }
    }

    /// The light, sky or surface at `end` of a ray after `depth` scattering
    /// events, reached through its media (`null_ratio` as in
    /// [`AfterMedia::Reached`]): its emission, and at a surface the next
    /// ray (`None` when the path ends).
    fn reach(&mut self, end: &RayEnd, null_ratio: f32, depth: u32) -> Option<Ray> {
        let (geometry, lights) = (&self.state.geometry, &self.state.lights);
        let (origin, direction) = (end.origin, end.direction);
        if let Some((index, light)) = end.light {
            let weight = self.emission_weight(light.pdf, null_ratio);
            let factor = self.bounce.lobes.factor(lights.lobes(index));
            self.gathered
                .add(self.throughput * light.radiance * factor * weight, depth);
            return None;
        }
        let Some(hit) = end.hit else {
            let (strategy, bounce, throughput) =
                (self.settings.strategy, self.bounce, self.throughput);
            let gathered = &mut self.gathered;
            let from = (origin, bounce.receiver);
            lights.escaped(from, direction, self.time, |index, le, pdf| {
                let factor = bounce.lobes.factor(lights.lobes(index));
                gathered.add(
                    throughput * le * factor * emission_weight(strategy, bounce, pdf, null_ratio),
                    depth,
                );
            });
            return None;
        };
        let sp = end.surface.unwrap_or_else(|| geometry.surface_point(&hit));
        // Leaving a thick dielectric through its back face: Beer-Lambert
        // over the segment just travelled inside it (docs/materials.md,
        // "Interior absorption").
        if direction.dot(sp.ng) > 0.0 {
            let materials = &self.state.materials;
            if let Some(sigma_a) = materials.interior_absorption(sp.material, &sp.site()) {
                self.throughput *= (-sigma_a * sp.p.distance(origin)).exp();
            }
        }
        self.at_surface(&sp, origin, -direction, null_ratio, depth)
    }

    /// The free flight along `ray` through media up to `t_end` (the surface
    /// or light it reaches; `continues` when the path would go on from
    /// there): volume emission on the way, equiangular sampling of
    /// point-like lights, and a real scattering event with next-event
    /// estimation and phase sampling when the flight ends in one. A camera
    /// ray under `--camera-ray-transmittance on` reaches its end with
    /// ratio tracking's transmittance instead of delta tracking's 0 or 1,
    /// whether or not it also scattered (docs/volumes.md, "Camera rays").
    fn through_media(&mut self, ray: &Ray, depth: u32, t_end: f32, continues: bool) -> AfterMedia {
        let (state, settings) = (self.state, self.settings);
        let lights = &state.lights;
        let (origin, direction) = (Vec3::from(ray.origin), Vec3::from(ray.direction));
        let along = (!state.media.is_empty())
            .then(|| state.media.along(origin, direction, t_end, self.time))
            .filter(|along| !along.is_empty());
        let Some(along) = along else {
            return AfterMedia::Reached { null_ratio: 1.0 };
        };
        // Free flights walk the majorant cells lazily; equiangular
        // sampling needs the ray's whole span in media first.
        let mut segments = along.segments(ray.tmin, t_end);
        let mut equiangular = None;
        if self.equiangular_on {
            let listed: Vec<MajorantSegment> = segments.collect();
            equiangular = EquiangularRay::new(origin, direction, &listed);
            if let Some(eq) = &equiangular {
                let sample = (&along, listed.as_slice(), eq, self.time);
                if let Some(c) =
                    equiangular_sample(state, settings, sample, self.rng, &mut self.counts)
                {
                    let c = self.throughput * c;
                    if depth == 0 {
                        self.gathered.add_first(c, &VOLUME_EVENT);
                    } else {
                        self.gathered.add(c, depth + 1);
                    }
                }
            }
            segments = RaySegments::Listed(listed.into_iter());
        }
        // Volume emission found by tracking against light sampling of
        // emitting volumes from this ray's origin (the measure is in
        // `lights/volume.rs`); their pick probabilities are looked up at
        // the first collision that emits, not for every ray in media.
        let bounce = self.bounce;
        let weigh_volume_lights = lights.has_volume_lights() && !bounce.specular;
        let mut volume_lights = None;
        let null_scattering = settings.volume_estimator == VolumeEstimator::NullScatteringMis;
        let weigh_emission = |t: f32, sigma_maj: f32, null_ratio: f32| {
            if !weigh_volume_lights {
                return 1.0;
            }
            let from = volume_lights
                .get_or_insert_with(|| lights.volume_lights_from((origin, bounce.receiver)));
            let light_pdf = from.pdf(&state.media, origin + direction * t, sigma_maj);
            let null_ratio = if null_scattering { null_ratio } else { 1.0 };
            emission_weight(settings.strategy, bounce, light_pdf, null_ratio)
        };
        let pass_through = depth == 0 && settings.camera_ray_transmittance;
        let before = (self.throughput, self.bounce);
        let flight = free_flight(
            &along,
            (segments, pass_through),
            self.throughput,
            weigh_emission,
            self.rng,
            self.counts.tracking,
        );
        self.gathered.add(flight.emission, depth);
        self.throughput = flight.throughput;
        let scattered = match flight.end {
            FlightEnd::Left => None,
            FlightEnd::Absorbed => {
                self.gathered.aovs.opaque |= depth == 0;
                None
            }
            FlightEnd::Scattered { t, albedo, sigma_s } => {
                // Alpha as when absorption ended camera paths: opaque with
                // the absorption probability (1 - albedo when grey).
                let absorbed = 1.0 - albedo.element_sum() / 3.0;
                self.gathered.aovs.opaque |= depth == 0 && self.rng.next_f32() < absorbed;
                let event = (t, albedo, sigma_s, flight.null_ratio);
                self.scatter(
                    &along,
                    (origin, direction),
                    event,
                    depth,
                    equiangular.as_ref(),
                )
            }
        };
        if !pass_through {
            return match (scattered, flight.end) {
                (Some(next), _) => AfterMedia::Scattered(next),
                (None, FlightEnd::Left) => AfterMedia::Reached {
                    null_ratio: if null_scattering {
                        flight.null_ratio
                    } else {
                        1.0
                    },
                },
                (None, _) => AfterMedia::Ended,
            };
        }
        let mut pass = flight.pass;
        if scattered.is_some() && continues {
            // Both continue: the surface behind is followed with
            // probability min(1, largest channel of pass), so a camera
            // ray costs at most about what delta tracking's did.
            let q = pass.abs().max_element().min(1.0);
            pass = if self.rng.next_f32() < q {
                pass / q
            } else {
                Vec3::ZERO
            };
        }
        let behind = before.0 * pass;
        match (scattered, pass != Vec3::ZERO) {
            (Some(next), true) => AfterMedia::Both { next, behind },
            (Some(next), false) => AfterMedia::Scattered(next),
            (None, true) => {
                (self.throughput, self.bounce) = (behind, before.1);
                AfterMedia::Reached { null_ratio: 1.0 }
            }
            (None, false) => AfterMedia::Ended,
        }
    }

    /// The real scattering event `(t, albedo, mean sigma_s, null ratio)` of
    /// the free flight along the ray `(origin, direction)` after `depth`
    /// events: next-event estimation (its share against equiangular
    /// sampling `equiangular`) and phase sampling of the next ray, `None`
    /// when the path ends there.
    fn scatter(
        &mut self,
        along: &MediaRay,
        (origin, direction): (Vec3, Vec3),
        (t, albedo, sigma_s, null_ratio): (f32, Vec3, f32, f32),
        depth: u32,
        equiangular: Option<&EquiangularRay>,
    ) -> Option<Ray> {
        let (state, settings) = (self.state, self.settings);
        if depth == 0 {
            self.gathered.first_event(VOLUME_EVENT);
        }
        self.gathered.set_albedo(albedo);
        if depth >= settings.max_depth {
            return None;
        }
        let phase = along.phase(t, self.rng.next_f32());
        let p = origin + direction * t;
        let wo = -direction;
        let u_light = (self.sampler.next_1d(), self.sampler.next_2d());
        if settings.strategy != Strategy::Bsdf {
            let vertex = Vertex::Medium { p, phase, wo };
            if let Some(light) = self.next_event((&vertex, Receiver::UNNAMED), u_light) {
                // Equiangular sampling could have made this path too: its
                // share of the NEE weight.
                let share = equiangular.map_or(1.0, |eq| {
                    eq.distance_share(state, light.light, (t, sigma_s, null_ratio))
                });
                self.gathered
                    .add(self.throughput * light.f * light.li * share, depth + 1);
            }
        }
        let (_, u_phase, u_roulette) = (
            self.sampler.next_1d(),
            self.sampler.next_2d(),
            self.sampler.next_1d(),
        );
        let ps = phase.sample(wo, u_phase);
        self.bounce = Bounce {
            pdf: ps.pdf,
            specular: false,
            receiver: Receiver::UNNAMED,
            lobes: LobeSplit::Unscaled,
        };
        if !roulette(&mut self.throughput, depth, u_roulette) {
            return None;
        }
        Some(Ray::new(p.into(), ps.wi.into(), 0.0, f32::INFINITY))
    }

    /// The surface point `sp` reached from `origin` (`wo` pointing back):
    /// its emission, next-event estimation, and BSDF sampling of the next
    /// ray (`None` when the path ends here).
    fn at_surface(
        &mut self,
        sp: &SurfacePoint,
        origin: Vec3,
        wo: Vec3,
        null_ratio: f32,
        depth: u32,
    ) -> Option<Ray> {
        let (state, settings) = (self.state, self.settings);
        let materials = &state.materials;
        if materials.is_emissive(sp.material) && (sp.double_sided || wo.dot(sp.ng) > 0.0) {
            let from = (origin, self.bounce.receiver);
            let weight = self.emission_weight(state.lights.mesh_pdf(sp, from), null_ratio);
            let factor = self.bounce.lobes.factor(materials.light_lobes(sp.material));
            self.gathered.add(
                self.throughput * materials.emission(sp.material, &sp.site()) * factor * weight,
                depth,
            );
        }
        if depth >= settings.max_depth {
            return None;
        }
        let bsdf = materials.bsdf(sp, wo);
        if !bsdf.is_delta() {
            self.gathered.set_albedo(bsdf.albedo());
        }
        // Next-event estimation: one light sample.
        let u_light = (self.sampler.next_1d(), self.sampler.next_2d());
        let receiver = state.lights.receiver(sp.instance, sp.prototype_mesh);
        if settings.strategy != Strategy::Bsdf && !bsdf.is_delta() {
            let vertex = Vertex::Surface {
                sp,
                bsdf: &bsdf,
                wo,
            };
            if let Some(light) = self.next_event((&vertex, receiver), u_light) {
                let contribution = self.throughput * light.f * light.li;
                if depth == 0 {
                    // The first event: split the light by lobe.
                    let lobes = state.lights.lobes(light.light);
                    let shares = lobe_shares(scaled(bsdf.eval_split(wo, light.wi), lobes));
                    self.gathered.add_first(contribution, &shares);
                } else {
                    self.gathered.add(contribution, depth + 1);
                }
            }
        }
        // BSDF sampling continues the path.
        let (u_lobe, u_bsdf, u_roulette) = (
            self.sampler.next_1d(),
            self.sampler.next_2d(),
            self.sampler.next_1d(),
        );
        let bs = bsdf.sample(wo, u_lobe, u_bsdf)?;
        // Lights' factors need the split only where some light has them.
        let scales_lobes = state.lights.scales_lobes();
        let split = (!bs.delta && (depth == 0 || scales_lobes)).then(|| bsdf.eval_split(wo, bs.wi));
        if depth == 0 {
            let shares = match split {
                Some(split) => lobe_shares(split),
                None => [Vec3::ZERO, Vec3::ZERO, Vec3::ONE, Vec3::ZERO],
            };
            self.gathered.first_event(shares);
        }
        self.throughput *= bs.weight;
        self.bounce = Bounce {
            pdf: bs.pdf,
            specular: bs.delta,
            receiver,
            lobes: split
                .filter(|_| scales_lobes)
                .map_or(LobeSplit::Unscaled, LobeSplit::of),
        };
        if !roulette(&mut self.throughput, depth, u_roulette) {
            return None;
        }
        Some(sp.spawn_ray(bs.wi))
    }
}

/// The MIS weight, under `strategy`, of emission found by a ray sampled as
/// `bounce` says, against light sampling with density `light_pdf` there
/// times `null_ratio` (see [`Path::emission_weight`]).
fn emission_weight(strategy: Strategy, bounce: Bounce, light_pdf: f32, null_ratio: f32) -> f32 {
    if bounce.specular || light_pdf <= 0.0 {
        return 1.0;
    }
    match strategy {
        Strategy::Mis => power_heuristic(bounce.pdf, light_pdf * null_ratio),
        Strategy::Bsdf => 1.0,
        Strategy::Nee => 0.0,
    }
}

/// A scattering vertex of a path, where next-event estimation samples a
/// light: a surface point with its BSDF, or a real collision in a medium
/// with its phase function; `wo` points back along the path.
enum Vertex<'a> {
    Surface {
        sp: &'a SurfacePoint,
        bsdf: &'a Bsdf,
        wo: Vec3,
    },
    Medium {
        p: Vec3,
        phase: HenyeyGreenstein,
        wo: Vec3,
    },
}

impl Vertex<'_> {
    fn position(&self) -> Vec3 {
        match self {
            Self::Surface { sp, .. } => sp.p,
            Self::Medium { p, .. } => *p,
        }
    }

    /// The BSDF (cosine included; its diffuse and specular parts scaled by
    /// the light's `lobes`) or phase function towards `wi`.
    fn f(&self, wi: Vec3, lobes: LightLobes) -> Vec3 {
        match self {
            Self::Surface { bsdf, wo, .. } if lobes.scales() => {
                scaled(bsdf.eval_split(*wo, wi), lobes).total()
            }
            Self::Surface { bsdf, wo, .. } => bsdf.eval(*wo, wi),
            Self::Medium { phase, wo, .. } => Vec3::splat(phase.eval(*wo, wi)),
        }
    }

    /// The density with which this vertex samples `wi` itself.
    fn pdf(&self, wi: Vec3) -> f32 {
        match self {
            Self::Surface { bsdf, wo, .. } => bsdf.pdf(*wo, wi),
            Self::Medium { phase, wo, .. } => phase.eval(*wo, wi),
        }
    }

    /// The shadow ray towards a light sample: off the surface (see
    /// `SurfacePoint::shadow_ray`), or straight from a point in a medium.
    fn shadow_ray(&self, ls: &LightSample) -> Ray {
        match self {
            Self::Surface { sp, .. } => sp.shadow_ray(ls.wi, ls.distance),
            Self::Medium { p, .. } => shadow_ray(*p, ls.wi, ls.distance),
        }
    }
}

/// One light sample's contribution at a vertex: `f * li` is to be
/// multiplied by the path throughput.
struct LightContribution {
    /// Index of the sampled light.
    light: usize,
    /// The BSDF (cosine included) or phase function towards the light.
    f: Vec3,
    /// Le tr w / pdf: the light's radiance through the media, MIS-weighted
    /// against the vertex's own sampling (1 for delta lights and in
    /// NEE-only mode), over the light sample's density.
    li: Vec3,
    /// Unit direction towards the light.
    wi: Vec3,
}

/// Russian roulette from [`ROULETTE_DEPTH`]: false ends the path; a
/// surviving path's throughput is divided by its survival probability,
/// the square root of the throughput's largest channel (Cycles'
/// `path_state_continuation_probability`), at most [`MAX_SURVIVAL`]. The
/// root ends dim paths later than the throughput itself would: 1.1-1.25x
/// lower relMSE per sample on the volume benchmarks and the shader ball
/// for 0-5% more time (docs/benchmarks.md, "Volumes").
fn roulette(throughput: &mut Vec3, depth: u32, u: f32) -> bool {
    if depth + 1 < ROULETTE_DEPTH {
        return true;
    }
    let survival = throughput.max_element().sqrt().min(MAX_SURVIVAL);
    if u >= survival {
        return false;
    }
    *throughput /= survival;
    true
}
