//! Everything a render reads, built once from a [`Scene`] in a fixed order
//! (volumes, textures and materials, lights, camera, geometry) and never changed
//! afterwards, so threads share it freely. The scene itself can be dropped.

use glam::UVec2;
use thiserror::Error;

use crate::camera::{Camera, CameraError};
use crate::geometry::Geometry;
use crate::lights::{Emitters, LightError, Lights};
use crate::materials::{MaterialError, Materials};
use crate::motion::Shutter;
use crate::scene::Scene;
use crate::volumes::{MajorantKind, Media, VolumeError};

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
}

/// The prim paths the film's Cryptomatte ids stand for.
#[derive(Clone, Debug, Default)]
pub struct IdNames {
    /// Mesh prim paths, indexed like the meshes (CryptoObject).
    pub objects: Vec<String>,
    /// Material prim paths, indexed like the materials (CryptoMaterial).
    pub materials: Vec<String>,
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
        let media = Media::build(scene, options.majorant)?;
        let materials = Materials::build(scene)?;
        let lights = Lights::build(scene, &materials, &media, options.volume_lights)?;
        // The camera first: its shutter says whether geometry moves.
        let camera = Camera::new(&scene.manifest.camera, resolution)?;
        let camera = match options.shutter {
            Some(shutter) => camera.with_shutter(shutter),
            None => camera,
        };
        let shutter = camera.shutter();
        if shutter.blurs() {
            log::info!("shutter {shutter} frames: motion blur on");
            let m = &scene.manifest;
            if m.camera.shutter.is_none() && m.instances.motion.is_none() {
                log::warn!("the scene was exported with a closed shutter: nothing moves (render the USD stage itself with --shutter {shutter}, or export it with export_usd.py --shutter {shutter})");
            }
        }
        let geometry = Geometry::build(scene, shutter.blurs());
        let m = &scene.manifest;
        let id_names = IdNames {
            objects: (m.meshes.iter().map(|x| &x.path))
                .chain(m.points.iter().map(|x| &x.path))
                .chain(m.curves.iter().map(|x| &x.path))
                .cloned()
                .collect(),
            materials: m.materials.iter().map(|x| x.path.clone()).collect(),
        };
        Ok(Self {
            geometry,
            materials,
            lights,
            camera,
            media,
            resolution,
            options,
            id_names,
        })
    }
}

impl RenderState {
    /// What light samples read emission from.
    pub fn emitters(&self) -> Emitters<'_> {
        Emitters {
            materials: &self.materials,
            media: &self.media,
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
