//! [`Lights`]: every light of a scene with the structure that picks one per
//! sample, built from the scene's UsdLux records, emissive meshes and
//! emitting volumes (a white dome when there are none), and the API through
//! which the integrator samples lights, finds them along rays and weighs
//! them for MIS.

use std::collections::{BTreeSet, HashMap, HashSet};

use glam::{Vec2, Vec3};

use super::linking::{self, Linking, Receiver};
use super::mesh::MeshLight;
use super::moving::MovingLight;
use super::select::{self, LightSelection};
use super::volume::VolumeLight;
use super::{Emitters, Light, LightError, LightHit, LightSample, LOG_TARGET};
use crate::geometry::SurfacePoint;
use crate::materials::Materials;
use crate::motion::Shutter;
use crate::scene::{Light as LightRecord, LightLobes, LightShape, Scene};
use crate::volumes::Media;

/// Every light of a scene with the structure that picks one per sample.
pub struct Lights {
    /// UsdLux lights first (in manifest order, those with power), then
    /// emissive meshes.
    lights: Vec<Light>,
    /// Picks a light per sample, one per link set (index: [`Receiver`]'s
    /// set) among the lights that light it; empty when there are none.
    selections: Vec<LightSelection>,
    /// Light and shadow linking; `None` when no light links (the default).
    linking: Option<Linking>,
    /// Indices of the analytic area lights (sphere, rect, disk, cylinder).
    area: Vec<usize>,
    /// Indices of the lights an escaping ray can see (dome, distant with a
    /// cone, still or turning).
    infinite: Vec<usize>,
    /// Light index of each emissive placed mesh, by (instance, prototype mesh).
    meshes: HashMap<(u32, u32), usize>,
    /// Indices of the emitting volumes' lights.
    volumes: Vec<usize>,
    /// Each light's diffuse and specular factors (`inputs:diffuse`,
    /// `inputs:specular`; a mesh light's from its material).
    lobes: Vec<LightLobes>,
    /// Whether some light's (or mesh light material's) factors differ from
    /// 1 (else the integrator never splits a BSDF value for them).
    scales_lobes: bool,
}

/// The light equiangular sampling aims at from one point (see
/// [`Lights::pick_equiangular_target`]).
#[derive(Clone, Copy, Debug)]
pub struct EquiangularTarget {
    /// Index of the picked light.
    pub light: usize,
    /// The light's centre, world space.
    pub centre: Vec3,
    /// Probability of having picked the light from that point.
    pub probability: f32,
}

impl Lights {
    /// Picks a light with `u_select` (by power, and for bounded lights by
    /// distance and orientation from `p` too), then a point or direction on
    /// it with `u`, as seen from `p`. `None` when there is no light or the
    /// sample carries nothing (the light faces away, `p` is inside a sphere).
    /// The picked light's index comes with the sample; only lights that
    /// light `receiver` are picked.
    pub fn sample(
        &self,
        emitters: Emitters,
        (p, receiver): (Vec3, Receiver),
        u_select: f32,
        u: Vec2,
    ) -> Option<(usize, LightSample)> {
        let pick = self.selections.get(receiver.set())?.pick(p, u_select)?;
        let mut s = self.lights[pick.light].sample(emitters, p, u)?;
        s.pdf *= pick.probability;
        Some((pick.light, s))
    }

    /// A sample of light `index` seen from `p`, its pdf without selection
    /// (equiangular sampling picks the light before the point).
    pub fn sample_light(
        &self,
        emitters: Emitters,
        index: usize,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        self.lights[index].sample(emitters, p, u)
    }

    /// Whether any light is one equiangular sampling targets (see
    /// [`Lights::centre`]; all of them are analytic area lights, so only
    /// those are looked at, not every emissive triangle: this runs per path).
    pub fn has_equiangular_target(&self) -> bool {
        self.area.iter().any(|&i| self.centre(i).is_some())
    }

    /// Picks a light from `p` with `u` as [`Lights::sample`] does, and keeps
    /// the pick when equiangular sampling targets it: its index, centre and
    /// pick probability (Kulla & Fajardo 2012 sample distances towards it).
    /// Points in media are in [`Receiver::UNNAMED`]'s set.
    pub fn pick_equiangular_target(&self, p: Vec3, u: f32) -> Option<EquiangularTarget> {
        let pick = self.selections.first()?.pick(p, u)?;
        let centre = self.centre(pick.light)?;
        Some(EquiangularTarget {
            light: pick.light,
            centre,
            probability: pick.probability,
        })
    }

    /// The centre of light `index` when equiangular sampling targets it: a
    /// sphere or point light, or a rect or disk light (Kulla & Fajardo 2012
    /// aim at a point; for an area light its centre serves, exactly so for a
    /// small one, and MIS with distance sampling covers a large one).
    pub fn centre(&self, index: usize) -> Option<Vec3> {
        match &self.lights[index] {
            Light::Sphere(l) => Some(l.centre()),
            Light::Rect(l) => Some(l.centre()),
            Light::Disk(l) => Some(l.centre()),
            Light::Moving(l) => l.centre(),
            // The box centre: a sphere's, rect's or disk's own centre.
            Light::Shaped(l) if !matches!(l.unshaped(), Light::Cylinder(_)) => {
                l.bounds().map(|b| b.centroid())
            }
            _ => None,
        }
    }

    /// Light `index`'s diffuse and specular factors.
    pub fn lobes(&self, index: usize) -> LightLobes {
        self.lobes[index]
    }

    /// Whether some light (or mesh light material) has a diffuse or
    /// specular factor other than 1.
    pub fn scales_lobes(&self) -> bool {
        self.scales_lobes
    }

    /// The nearest front-face hit with t in (0, t_max) of the ray from
    /// `origin` along unit `direction` on the analytic area lights (sphere,
    /// rect, disk, cylinder; emissive meshes are found by the geometry),
    /// moving ones where they are at `time` (frames), with the index of the
    /// light hit. Lights that do not light `receiver` (the ray's origin) are
    /// not there for it (light linking: the image is the one without them).
    pub fn intersect(
        &self,
        (origin, receiver): (Vec3, Receiver),
        direction: Vec3,
        t_max: f32,
        time: f32,
    ) -> Option<(usize, LightHit)> {
        let mut nearest: Option<(usize, LightHit)> = None;
        let mut t_max = t_max;
        for &i in &self.area {
            if !self.lights_receiver(i, receiver) {
                continue;
            }
            if let Some(hit) = self.lights[i].intersect(origin, direction, t_max, time) {
                t_max = hit.t;
                nearest = Some((i, hit));
            }
        }
        // The selection probability of the nearest only: a BVH walk each.
        nearest.map(|(i, mut hit)| {
            hit.pdf *= self.probability(origin, i, receiver);
            (i, hit)
        })
    }

    /// Whether the front face of an analytic area light other than `target`
    /// (the light the shadow ray goes to) lies on the shadow ray from `origin`
    /// along unit `direction` with t in (0, t_max): lights stop the rays that
    /// hit them (see [`Lights::intersect`]), so they must stop shadow rays
    /// too, or light sampling and BSDF sampling would estimate different
    /// images wherever one light hides another. The target itself is skipped:
    /// its sampled point is its first hit, up to rounding that would
    /// otherwise let a sphere light shadow itself at grazing angles. Moving
    /// lights block where they are at `time` (frames); lights that do not
    /// light `receiver` (the shadow ray's origin) do not.
    pub fn blocks(
        &self,
        (origin, receiver): (Vec3, Receiver),
        direction: Vec3,
        t_max: f32,
        time: f32,
        target: usize,
    ) -> bool {
        self.area.iter().any(|&i| {
            i != target
                && self.lights_receiver(i, receiver)
                && self.lights[i]
                    .intersect(origin, direction, t_max, time)
                    .is_some()
        })
    }

    /// Calls `radiance_pdf(light, radiance, pdf)` once for each infinite light a ray
    /// from `origin` escaping the scene along unit `direction` at `time`
    /// (frames) sees: the dome, and distant lights of non-zero angle whose
    /// cone holds `direction`, turning ones as they are at `time`. `pdf` is
    /// what [`Lights::sample`] gives that direction, selection included;
    /// lights that do not light `receiver` are left out.
    pub fn escaped(
        &self,
        (origin, receiver): (Vec3, Receiver),
        direction: Vec3,
        time: f32,
        mut radiance_pdf: impl FnMut(usize, Vec3, f32),
    ) {
        for &i in &self.infinite {
            if !self.lights_receiver(i, receiver) {
                continue;
            }
            if let Some(hit) = self.lights[i].escaped(direction, time) {
                radiance_pdf(
                    i,
                    hit.radiance,
                    hit.pdf * self.probability(origin, i, receiver),
                );
            }
        }
    }

    /// Solid-angle density with which [`Lights::sample`] picks the emissive
    /// mesh point `sp` from `origin`, selection included (for MIS when a BSDF
    /// ray hits an emitter); 0 when `sp`'s mesh is not a light.
    pub fn mesh_pdf(&self, sp: &SurfacePoint, (origin, receiver): (Vec3, Receiver)) -> f32 {
        let Some(&i) = self.meshes.get(&(sp.instance, sp.prototype_mesh)) else {
            return 0.0;
        };
        match &self.lights[i] {
            Light::Mesh(mesh) => mesh.pdf(sp, origin) * self.probability(origin, i, receiver),
            _ => unreachable!("the mesh map holds mesh lights only"),
        }
    }

    /// Whether any volume emits as a light.
    pub fn has_volume_lights(&self) -> bool {
        !self.volumes.is_empty()
    }

    /// The emitting volumes' lights as seen from `origin`, for the MIS
    /// weights of volume emission that tracking finds along a ray from there
    /// (leaving `receiver`).
    pub fn volume_lights_from(&self, (origin, receiver): (Vec3, Receiver)) -> VolumeLightsFrom<'_> {
        VolumeLightsFrom {
            lights: self,
            origin,
            picks: self
                .volumes
                .iter()
                .map(|&i| (i, self.probability(origin, i, receiver)))
                .filter(|&(_, p)| p > 0.0)
                .collect(),
        }
    }

    /// Probability of picking light `index` from shading point `p` in link
    /// set `receiver`.
    pub fn probability(&self, p: Vec3, index: usize, receiver: Receiver) -> f32 {
        self.selections
            .get(receiver.set())
            .map_or(0.0, |s| s.probability(p, index))
    }

    /// Whether light `index` lights `receiver`.
    pub fn lights_receiver(&self, index: usize, receiver: Receiver) -> bool {
        self.linking
            .as_ref()
            .is_none_or(|l| l.lights(index, receiver))
    }

    /// The link set of surface part `part` (`Hit::prototype_mesh`) of
    /// `instance`: what a ray leaving it may be lit by.
    pub fn receiver(&self, instance: u32, part: u32) -> Receiver {
        self.linking
            .as_ref()
            .map_or(Receiver::UNNAMED, |l| l.receiver(instance, part))
    }

    /// Whether surface part `part` of `instance` casts light `index`'s
    /// shadow (every part does unless the light's shadow is linked).
    pub fn casts_shadow(&self, index: usize, instance: u32, part: u32) -> bool {
        self.linking
            .as_ref()
            .is_none_or(|l| l.casts_shadow(index, l.receiver(instance, part)))
    }

    /// Whether light `index`'s shadow is linked: some parts let its light through.
    pub fn shadow_linked(&self, index: usize) -> bool {
        self.linking
            .as_ref()
            .is_some_and(|l| l.shadow_linked(index))
    }

    /// Calls `found(light, hit)` for each shadow-linked light that lights
    /// `receiver` and lies on the ray from `origin` along unit `direction`
    /// beyond `t_from` (see `linking::hit_beyond`): what a BSDF- or
    /// phase-sampled ray stopped at `t_from` could still reach through parts
    /// transparent to that light (Cycles' dedicated light ray). `hit.pdf`
    /// includes the selection.
    pub fn beyond_linked_blockers(
        &self,
        (origin, receiver): (Vec3, Receiver),
        direction: Vec3,
        (t_from, time): (f32, f32),
        mut found: impl FnMut(usize, LightHit),
    ) {
        let Some(linking) = self.linking.as_ref().filter(|l| l.any_shadow_linked()) else {
            return;
        };
        for (i, light) in self.lights.iter().enumerate() {
            if !linking.shadow_linked(i) || !linking.lights(i, receiver) {
                continue;
            }
            let hit = linking::hit_beyond(light, (origin, direction), (t_from, time));
            if let Some(mut hit) = hit {
                hit.pdf *= self.probability(origin, i, receiver);
                found(i, hit);
            }
        }
    }

    /// Every UsdLux light of the scene and every placed mesh with emissive
    /// triangles, then the power-based selection over them. Lights of zero
    /// power (black, zero size without `normalize`) are left out with a
    /// warning; unusable values are a [`LightError`]. When `shutter` blurs,
    /// emissive meshes of moving instances, and deforming emissive meshes,
    /// are left out too, with a warning naming the mesh: a light sample would sit where the mesh is at the
    /// frame while rays meet it at their own time, so only rays that hit it
    /// find its light (BSDF sampling alone, unbiased: their MIS weight is
    /// then 1, as [`Lights::mesh_pdf`] is 0 for them).
    pub fn build(
        scene: &Scene,
        materials: &Materials,
        media: &Media,
        volume_lights: bool,
        shutter: Shutter,
    ) -> Result<Self, LightError> {
        let radius = select::scene_radius(&scene.manifest.bounds);
        let mut lights = Vec::new();
        let mut links = Vec::new();
        let mut lobes = Vec::new();
        for record in &scene.manifest.lights {
            let light = Light::from_record(record)?;
            if light.power(radius) > 0.0 {
                lobes.push(record.lobes);
                lights.push(moved(light, record, shutter));
                links.push(Some(&record.links));
            } else {
                log::warn!(target: LOG_TARGET, "light {} emits nothing; left out", record.path);
            }
        }
        let moving = moving_instances(scene, shutter);
        let mut meshes = HashMap::new();
        let mut unsampled = BTreeSet::new();
        for (key, mesh) in MeshLight::build_all(scene, materials) {
            let deforms =
                shutter.blurs() && scene.manifest.meshes[mesh.mesh() as usize].motion.is_some();
            if moving.contains(&key.0) || deforms {
                unsampled.insert(mesh.mesh());
            } else if mesh.power() > 0.0 {
                meshes.insert(key, lights.len());
                lobes.push(materials.light_lobes(mesh.material()));
                lights.push(Light::Mesh(mesh));
            }
        }
        let any_mesh_emits = !meshes.is_empty() || !unsampled.is_empty();
        for mesh in unsampled {
            log::warn!(
                target: LOG_TARGET,
                "emissive mesh {} moves or deforms over the shutter: its light is found only by rays that \
                 hit it, not light-sampled (unbiased, noisier)",
                scene.manifest.meshes[mesh as usize].path
            );
        }
        let emitters: Vec<_> = media.emitters().collect();
        let mut volumes = Vec::new();
        for emitter in emitters.iter().filter(|_| volume_lights) {
            let light = VolumeLight::new(emitter);
            log::debug!(
                target: LOG_TARGET,
                "emitting volume {} as a light: power {:.4} W (luminance), box {} .. {}",
                emitter.medium,
                emitter.power,
                emitter.world_min,
                emitter.world_max
            );
            if light.power() > 0.0 {
                volumes.push(lights.len());
                lobes.push(LightLobes::default());
                lights.push(Light::Volume(light));
            }
        }
        // Fire counts as a light here whether or not it is light-sampled,
        // so `--volume-light-sampling off` renders the same image.
        let emits = !scene.manifest.lights.is_empty() || any_mesh_emits || media.emits();
        if lights.len() == volumes.len() && !emits {
            log::warn!(
                target: LOG_TARGET,
                "the scene has no lights: lighting it with a white dome of radiance 1 \
                 (add a DomeLight or any UsdLux light to choose)"
            );
            lobes.push(LightLobes::default());
            lights.push(Light::from_record(&default_dome())?);
        }
        links.resize(lights.len(), None);
        let linking = Linking::build(scene, &links)?;
        let mut lights = Self::from_lights(
            (lights, lobes, linking),
            meshes,
            volumes,
            &scene.manifest.bounds,
        );
        // Mesh lights moving over the shutter are found by rays alone.
        lights.scales_lobes |= materials.any_light_lobes();
        Ok(lights)
    }

    fn from_lights(
        (lights, lobes, linking): (Vec<Light>, Vec<LightLobes>, Option<Linking>),
        meshes: HashMap<(u32, u32), usize>,
        volumes: Vec<usize>,
        bounds: &crate::scene::Bounds,
    ) -> Self {
        let indices = |keep: fn(&Light) -> bool| -> Vec<usize> {
            (0..lights.len()).filter(|&i| keep(&lights[i])).collect()
        };
        let area = indices(|l| match l {
            Light::Sphere(_) | Light::Rect(_) | Light::Disk(_) | Light::Cylinder(_) => true,
            Light::Moving(m) => m.bounds().is_some(),
            Light::Shaped(_) => true,
            _ => false,
        });
        let infinite = indices(seen_by_escaping_rays);
        // One selection per link set, among the lights that light it (a
        // single one, over every light, when nothing links).
        let sets = if lights.is_empty() {
            0
        } else {
            linking.as_ref().map_or(1, Linking::sets)
        };
        let selections = (0..sets)
            .map(|set| {
                let receiver = Receiver::of_set(set);
                LightSelection::new(&lights, bounds, |i| {
                    linking.as_ref().is_none_or(|l| l.lights(i, receiver))
                })
            })
            .collect();
        Self {
            lights,
            selections,
            linking,
            area,
            infinite,
            meshes,
            volumes,
            scales_lobes: lobes.iter().any(LightLobes::scales),
            lobes,
        }
    }
}

/// The emitting volumes' lights with their selection probabilities from
/// one ray origin (see [`Lights::volume_lights_from`]).
pub struct VolumeLightsFrom<'a> {
    lights: &'a Lights,
    origin: Vec3,
    picks: smallvec::SmallVec<[(usize, f32); 2]>,
}

impl VolumeLightsFrom<'_> {
    /// The density, selection included, with which [`Lights::sample`] from
    /// the origin picks the volume point `point` where tracking's majorant
    /// is `sigma_maj` (see `volume.rs` for the measure); summed over the
    /// volumes whose emission may hold it.
    pub fn pdf(&self, media: &Media, point: Vec3, sigma_maj: f32) -> f32 {
        self.picks
            .iter()
            .map(|&(i, p)| match &self.lights.lights[i] {
                Light::Volume(l) => p * l.pdf(media, self.origin, point, sigma_maj),
                _ => unreachable!("the volume list holds volume lights only"),
            })
            .sum()
    }
}

/// The light of a scene that has none: a constant white dome of radiance 1,
/// so a layout without lights (many assets ship without) renders visibly.
fn default_dome() -> LightRecord {
    LightRecord {
        path: "(default dome)".into(),
        transform: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        color: [1.0; 3],
        intensity: 1.0,
        exposure: 0.0,
        normalize: false,
        color_temperature: None,
        lobes: LightLobes::default(),
        shape: LightShape::Dome {
            texture: None,
            texture_format: Default::default(),
        },
        motion: None,
        shaping: None,
        links: Default::default(),
    }
}

/// Whether a ray escaping the scene can see `light`: a dome, or a distant
/// light with a cone, still or turning.
fn seen_by_escaping_rays(light: &Light) -> bool {
    match light {
        Light::Dome(_) => true,
        Light::Distant(d) => !d.is_delta(),
        Light::Moving(m) => seen_by_escaping_rays(m.frame()),
        _ => false,
    }
}

/// `light` (of `record`) moving by the record's keys when `shutter` blurs
/// and it has some; still, with a warning naming it, when its keys scale or
/// shear it.
fn moved(light: Light, record: &LightRecord, shutter: Shutter) -> Light {
    let Some(motion) = record.motion.as_ref().filter(|_| shutter.blurs()) else {
        return light;
    };
    let world_from_light = crate::scene::affine(&record.transform);
    let still = light.clone();
    MovingLight::new(light, &world_from_light, motion).map_or_else(
        || {
            log::warn!(
                target: LOG_TARGET,
                "light {}: its keys over the shutter scale or shear it (only rigid motion of \
                 lights is blurred); rendered where it is at the frame",
                record.path
            );
            still
        },
        Light::Moving,
    )
}

/// The instances that move over `shutter` (none when it does not blur).
fn moving_instances(scene: &Scene, shutter: Shutter) -> HashSet<u32> {
    match &scene.manifest.instances.motion {
        Some(motion) if shutter.blurs() => scene.view(&motion.instance).iter().copied().collect(),
        _ => HashSet::new(),
    }
}

#[cfg(test)]
#[path = "container_tests.rs"]
mod tests;
