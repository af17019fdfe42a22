//! Everything a render reads, built once from a [`Scene`] in a fixed order
//! (camera, volumes, textures and materials, lights, geometry) and never changed
//! afterwards, so threads share it freely. The scene itself can be dropped.

use std::collections::BTreeSet;

use glam::UVec2;
use thiserror::Error;

use crate::camera::{Camera, CameraError, Raster};
use crate::film::{murmur3_32, primvar_of, Aov, AovSet, CryptoIds, CryptoNames, Murmur3};
use crate::film::{CRYPTOMATTES, MAX_PRIMVARS};
use crate::geometry::{Geometry, Hit, Ray};
use crate::lights::{Emitters, LightError, Lights};
use crate::materials::{MaterialError, Materials};
use crate::motion::Shutter;
use crate::scene::{InstanceNames, Scene};
use crate::volumes::grid::VolumeError;
use crate::volumes::majorant::MajorantKind;
use crate::volumes::Media;

/// Image width used when neither the command line nor the stage's render
/// settings give a resolution; the height follows the camera's aperture aspect.
pub const DEFAULT_WIDTH: u32 = 960;

/// Choices that shape the render state, beside the scene and resolution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateOptions {
    /// How finely the media's majorants follow their density (`--majorant`).
    pub majorant: MajorantKind,
    /// Emitting volumes are lights, sampled by next-event estimation and
    /// MIS-combined with the emission tracking finds (on by default;
    /// `--volume-light-sampling off` leaves them to tracking alone).
    pub volume_lights: bool,
    /// Replaces the camera's shutter (`--shutter`); `None` keeps the
    /// scene's `shutter:open`/`shutter:close`.
    pub shutter: Option<Shutter>,
}

impl Default for StateOptions {
    fn default() -> Self {
        Self {
            majorant: MajorantKind::Grid,
            volume_lights: true,
            shutter: None,
        }
    }
}

impl StateOptions {
    /// The defaults with one majorant over each whole grid (the baseline
    /// the benchmarks compare the grid against).
    pub fn global_majorant() -> Self {
        Self {
            majorant: MajorantKind::Global,
            ..Self::default()
        }
    }
}

/// The immutable inputs of the integrator.
pub struct RenderState {
    /// BVHs and per-vertex shading data.
    pub geometry: Geometry,
    /// BSDF inputs and textures.
    pub materials: Materials,
    /// Lights and the structure that picks one.
    pub lights: Lights,
    /// The render camera.
    pub camera: Camera,
    /// Participating media from the scene's volumes (empty when it has none).
    pub media: Media,
    /// Image size in pixels.
    pub resolution: UVec2,
    /// The choices it was built with.
    pub options: StateOptions,
    /// The prim paths of the ids the film stores.
    pub id_names: IdNames,
    /// The primvars the render settings' RenderVars read that some prim
    /// carries: (MurmurHash3 of the name, `Materials::primvar` id).
    aov_primvars: Vec<(u32, u32)>,
}

/// What the film's Cryptomatte ids stand for: the names of every placed
/// mesh, its asset and every material. A camera hit's ids are hashed from
/// the names' pieces (MurmurHash3, Cryptomatte 1.2.0), so no instance keeps
/// a string; names are spelled out only for the ids a film holds.
pub struct IdNames {
    instances: InstanceNames,
    /// Material prim paths, indexed like the materials, with their hashes.
    materials: Vec<(u32, String)>,
}

/// MurmurHash3 (seed 0) of the name `spell` gives in pieces.
fn hash_of(spell: impl FnOnce(&mut dyn FnMut(&[u8]))) -> u32 {
    let mut hasher = Murmur3::new(0);
    spell(&mut |piece| hasher.write(piece));
    hasher.finish()
}

/// The name `spell` gives in pieces, as one string.
fn name_of(spell: impl FnOnce(&mut dyn FnMut(&[u8]))) -> String {
    let mut name = Vec::new();
    spell(&mut |piece| name.extend_from_slice(piece));
    String::from_utf8_lossy(&name).into_owned()
}

impl IdNames {
    fn new(scene: &Scene) -> Self {
        let materials = scene.manifest.materials.iter();
        Self {
            instances: InstanceNames::new(scene),
            materials: materials
                .map(|x| x.name.as_ref().unwrap_or(&x.path))
                .map(|name| (crate::film::murmur3_32(name.as_bytes(), 0), name.clone()))
                .collect(),
        }
    }

    /// The Cryptomatte ids of `hit`, on a surface bound to `material` (an
    /// index into the materials) or to none, in the Cryptomattes `wanted`
    /// (by [`CRYPTOMATTES`] slot): the others are 0 and cost nothing.
    pub fn ids(&self, hit: &Hit, material: Option<u32>, wanted: [bool; 3]) -> CryptoIds {
        let (instance, part) = (hit.instance, hit.prototype_mesh);
        let names = &self.instances;
        let [want_object, want_material, want_asset] = wanted;
        let object = || hash_of(|out| names.object(instance, part, out));
        let asset = match names.asset_is_object(instance, part) {
            true => want_asset.then(object),
            false => want_asset.then(|| hash_of(|out| names.asset(instance, part, out))),
        };
        CryptoIds {
            object: if want_object { object() } else { 0 },
            material: material
                .filter(|_| want_material)
                .map(|m| self.materials[m as usize].0),
            asset: asset.unwrap_or(0),
        }
    }

    /// The names of those of `ids` that name something in Cryptomatte
    /// `aov`: one pass over the placed meshes (or materials), spelling out
    /// only the names asked for.
    pub fn names(&self, aov: Aov, ids: &BTreeSet<u32>) -> CryptoNames {
        let mut found = CryptoNames::new();
        if ids.is_empty() {
            return found;
        }
        if aov == Aov::CryptoMaterial {
            let materials = self.materials.iter().filter(|(id, _)| ids.contains(id));
            found.extend(materials.cloned());
            return found;
        }
        let names = &self.instances;
        for (instance, part) in names.placed() {
            let spell = |out: &mut dyn FnMut(&[u8])| match aov {
                Aov::CryptoAsset => names.asset(instance, part, out),
                _ => names.object(instance, part, out),
            };
            let id = hash_of(spell);
            if ids.contains(&id) && !found.contains_key(&id) {
                found.insert(id, name_of(spell));
            }
        }
        found
    }
}

/// What a render's AOVs read at the camera ray's first surface hit, beyond
/// its position and normal: which Cryptomatte ids to hash and which
/// primvars to look up. Built once per render from its AOV set, so a hit
/// costs only what is written.
#[derive(Clone, Debug, Default)]
pub struct HitAovs {
    /// Per [`CRYPTOMATTES`] slot, whether it is written.
    pub crypto: [bool; 3],
    /// Per slot of `AovSample::primvars`, the primvar's id for
    /// `Materials::primvar`; `None` when no prim carries it.
    pub primvars: Vec<Option<u32>>,
}

/// Why a scene cannot be rendered.
#[derive(Debug, Error)]
pub enum RenderStateError {
    /// A material or texture.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// A light.
    #[error(transparent)]
    Light(#[from] LightError),
    /// The camera.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// A volume's grid.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The requested resolution.
    #[error("resolution {0}x{1}: both sides must be at least 1 pixel")]
    Resolution(u32, u32),
}

impl RenderState {
    /// Builds the render state; `resolution` overrides the stage's.
    pub fn build(
        scene: &Scene,
        resolution: Option<UVec2>,
        options: StateOptions,
    ) -> Result<Self, RenderStateError> {
        let resolution = resolution_for(scene, resolution);
        if resolution.min_element() == 0 {
            return Err(RenderStateError::Resolution(resolution.x, resolution.y));
        }
        // The camera first: its shutter says whether volumes and geometry move.
        let raster = Raster {
            resolution,
            // The first render product's (the one rendered): square otherwise.
            pixel_aspect: (scene.manifest.render.products.first())
                .map_or(1.0, |p| p.pixel_aspect_ratio),
        };
        let camera = Camera::new(&scene.manifest.camera, raster)?;
        let camera = match options.shutter {
            Some(shutter) => camera.with_shutter(shutter),
            None => camera,
        };
        let shutter = camera.shutter();
        let media = Media::build_at(scene, options.majorant, shutter)?;
        let materials = Materials::build(scene)?;
        let lights = Lights::build(scene, &materials, &media, options.volume_lights, shutter)?;
        if shutter.blurs() {
            log::info!("shutter {shutter} frames: motion blur on");
            let m = &scene.manifest;
            let velocities = m.volumes.iter().any(|v| v.fields.contains_key("velocity"));
            if m.camera.shutter.is_none() && m.instances.motion.is_none() && !velocities {
                log::warn!("the scene was exported with a closed shutter: nothing moves (render the USD stage itself with --shutter {shutter}, or export it with `cirrus export --shutter {shutter}`)");
            }
        }
        let geometry = Geometry::build(scene, shutter.blurs());
        let id_names = IdNames::new(scene);
        let aov_primvars = aov_primvars(scene, &materials);
        Ok(Self {
            geometry,
            materials,
            lights,
            camera,
            media,
            resolution,
            options,
            id_names,
            aov_primvars,
        })
    }
}

/// The primvars `scene`'s RenderVars read, each as (MurmurHash3 of its
/// name, its id in `materials`); one warning names each var whose primvar
/// no prim carries (its layer is 0). More than [`MAX_PRIMVARS`] distinct
/// primvars: one warning, and the layers beyond are 0.
fn aov_primvars(scene: &Scene, materials: &Materials) -> Vec<(u32, u32)> {
    let vars = scene.manifest.render.products.iter().flat_map(|p| &p.vars);
    let mut found: Vec<(u32, u32)> = Vec::new();
    let mut names = BTreeSet::new();
    for var in vars {
        let Some(name) = primvar_of(&var.source_name, &var.source_type) else {
            continue;
        };
        names.insert(name);
        match materials.primvar_id(name) {
            Some(id) => found.push((murmur3_32(name.as_bytes(), 0), id)),
            None => log::warn!(
                "render var {}: no mesh, points or curves prim has primvar {name}; its layer is 0",
                var.path
            ),
        }
    }
    if names.len() > MAX_PRIMVARS {
        log::warn!(
            "the RenderVars read {} primvars ({}); only {MAX_PRIMVARS} are rendered, the layers of the others (last in hash order) are 0",
            names.len(),
            names.into_iter().collect::<Vec<_>>().join(", ")
        );
    }
    found.sort_unstable();
    found.dedup();
    found
}

impl RenderState {
    /// What the AOVs of `aovs` read at camera hits.
    pub fn hit_aovs(&self, aovs: &AovSet) -> HitAovs {
        HitAovs {
            crypto: CRYPTOMATTES.map(|a| aovs.contains(a)),
            primvars: aovs
                .primvars()
                .take(MAX_PRIMVARS)
                .map(|hash| {
                    let found = self.aov_primvars.iter().find(|(h, _)| *h == hash);
                    found.map(|(_, id)| *id)
                })
                .collect(),
        }
    }

    /// The closest surface `ray` hits at `time` (frames), its `t` along
    /// `ray`: hits where a material's `opacityThreshold` cuts the surface
    /// out ([`Materials::is_cut_out`]) are passed through, each once (the
    /// next search starts just beyond it), so no ray sees, shades or is
    /// shadowed by them.
    pub fn intersect(&self, ray: &Ray, time: f32) -> Option<Hit> {
        let mut ray = *ray;
        loop {
            let hit = self.geometry.intersect(&ray, time)?;
            if !self.materials.has_cut_outs() {
                return Some(hit);
            }
            let sp = self.geometry.surface_point(&hit);
            if !self.materials.is_cut_out(sp.material, &sp.site()) {
                return Some(hit);
            }
            ray.tmin = hit.t.next_up();
        }
    }

    /// Whether a surface blocks `ray` at `time` (frames), cut-outs passed
    /// through as [`Self::intersect`] does.
    pub fn occluded(&self, ray: &Ray, time: f32) -> bool {
        if self.materials.has_cut_outs() {
            self.intersect(ray, time).is_some()
        } else {
            self.geometry.occluded(ray, time)
        }
    }

    /// What light samples read emission from, at `time` (frames).
    pub fn emitters(&self, time: f32) -> Emitters<'_> {
        Emitters {
            materials: &self.materials,
            media: &self.media,
            time,
        }
    }
}

/// The image size: the command line's, else the stage's render settings',
/// else [`DEFAULT_WIDTH`] wide with the camera aperture's aspect.
pub fn resolution_for(scene: &Scene, requested: Option<UVec2>) -> UVec2 {
    let m = &scene.manifest;
    requested
        .or(m.render.resolution.map(UVec2::from))
        .unwrap_or_else(|| {
            let c = &m.camera;
            let aspect = c.vertical_aperture / c.horizontal_aperture;
            let height = (DEFAULT_WIDTH as f32 * aspect).round();
            let height = if height.is_finite() {
                height.max(1.0) as u32
            } else {
                DEFAULT_WIDTH
            };
            UVec2::new(DEFAULT_WIDTH, height)
        })
}
