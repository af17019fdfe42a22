//! The intermediate scene format (`exporter/FORMAT.md`): what the USD exporter
//! (`exporter/export_usd.py`) writes and the renderer reads.
//!
//! A scene is a folder of `scene.json` (the manifest, [`Manifest`]) and
//! `scene.bin` (every bulk array). [`Scene::load`] reads the blob once into an
//! aligned buffer and validates every reference, index and enum, so a [`Scene`]
//! in hand is internally consistent. It is plain data: acceleration structures
//! are built from it by `geometry`, never stored in it.
//!
//! Memory grows with prototypes, not instances: meshes are stored once, and
//! each instance costs 60 bytes (a 3x4 transform and three `u32`s) in
//! structure-of-arrays form, viewed in place from `scene.bin`.
//!
//! [`export`] runs the Python exporter on a USD file, and [`export_cached`]
//! keeps its result in a cache keyed by the input's path and modification time;
//! [`Scene::open`] takes either a USD file or an exported scene.

mod export;
mod format;
mod load;
mod material;
mod names;
mod subdivide;
mod summary;

use std::path::{Path, PathBuf};

use crate::motion::Shutter;

pub use export::{
    cache_root, export, export_cached, is_usd, CachedExport, ExportError, ExportOptions,
};
pub use format::Subdivision;
pub use format::{
    affine, Array, Bounds, Camera, CameraMotion, Curves, CurvesPart, DomeFormat, Element,
    InstanceMotion, InstancePrimvarRun, Instances, Light, LightLinks, LightShape, LightShaping,
    LinkRun, Manifest, Mesh, MeshMotion, MeshPart, NamePattern, NameRun, PartNames, Points,
    PointsMotion, PointsPart, Projection, Prototype, Render, RenderProduct, RenderVar, Scalar,
    Source, Stage, Transform, UpAxis, Volume, VolumeField, VolumePart, FORMAT_NAME, FORMAT_VERSION,
    NO_MATERIAL,
};
pub use load::{SceneError, BLOB_FILE, MANIFEST_FILE};
pub use material::{
    Channel, ColorSpace, GeometryLight, Input, InputValue, LightLobes, Material, Model, NormalMap,
    Op, OpInput, OpenPbr, PrimvarInput, Rgb, StTransform, Texture, TextureInput, Wrap,
};
pub use names::InstanceNames;
pub use subdivide::{PlannedMesh, Refinement, SubdivisionSummary};
pub use summary::summary;

/// A loaded, validated scene: the manifest records and the bulk data they reference.
pub struct Scene {
    /// The scene folder.
    pub dir: PathBuf,
    /// Every record of `scene.json`; bulk fields are [`Array`]s, read with [`Scene::view`].
    pub manifest: Manifest,
    /// What loading did to the subdivision meshes (refined in `manifest`).
    pub subdivision: SubdivisionSummary,
    blob: load::Blob,
}

/// Why [`Scene::open`] has no scene.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The USD file could not be exported.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The exported scene could not be read.
    #[error(transparent)]
    Load(#[from] SceneError),
    /// A USD time code or camera (`flag`) was asked of an exported scene.
    #[error("{flag} applies to USD input only; {} is an exported scene", path.display())]
    UsdOnly {
        /// `--frame`, `--camera` or `--settings`.
        flag: &'static str,
        /// The exported scene.
        path: PathBuf,
    },
    /// `--shutter` differs from the shutter an exported scene's motion
    /// keys were written for.
    #[error(
        "--shutter {asked}: {} was exported with shutter {exported}, and its motion covers only \
         that; export it again with `cirrus export --shutter {asked}`, or render the USD file",
        path.display()
    )]
    ShutterNotExported {
        /// The shutter asked for, frames.
        asked: Shutter,
        /// The shutter the scene was exported with, frames.
        exported: Shutter,
        /// The exported scene.
        path: PathBuf,
    },
}

/// Bytes of bulk data a scene holds, by what they describe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ArrayBytes {
    /// Mesh points, triangles, normals, UVs, primvars and per-triangle
    /// materials; points and curves prims' arrays.
    pub meshes: u64,
    /// Instance transforms, prototype, source and source-index arrays.
    pub instances: u64,
}

impl Manifest {
    /// Each material's model name (`preview_surface`, `open_pbr`).
    pub fn material_models(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.materials.iter().map(|m| m.model.name())
    }

    /// How many materials could not be read and hold UsdPreviewSurface's defaults.
    pub fn fallback_count(&self) -> usize {
        self.materials.iter().filter(|m| m.fallback).count()
    }

    /// The materials read through a simpler look because the exporter
    /// skipped a richer one (a non-empty [`Material::skipped`]): not fallbacks,
    /// but not the whole look either.
    pub fn skipped_looks(&self) -> impl Iterator<Item = &Material> {
        self.materials.iter().filter(|m| !m.skipped.is_empty())
    }
}

/// How [`Scene::open`] exports and loads a scene; the defaults take the
/// stage's own frame, camera and shutter and refine subdivision surfaces at
/// the default level.
#[derive(Clone, Copy, Debug, Default)]
pub struct OpenOptions<'a> {
    /// How a USD file is exported. Its frame, camera and settings apply to
    /// USD input only; its shutter, for an exported scene, must be the one
    /// the scene was exported with (or one its velocity fields serve).
    pub export: ExportOptions<'a>,
    /// How subdivision surfaces are refined.
    pub refinement: Refinement,
}

impl Scene {
    /// A scene from a USD file (exported through the cache at `frame`, seen
    /// by the camera prim `camera`, see [`export`]; the
    /// export's warnings are printed to stderr again when the cache already
    /// held it, so a user sees them every time) or from an exported folder
    /// or its scene.json, as `options` say (their defaults: the stage's own
    /// frame, camera and shutter, subdivision at the default level).
    pub fn open(path: &Path, options: &OpenOptions) -> Result<Self, OpenError> {
        let OpenOptions { export, refinement } = *options;
        let ExportOptions {
            frame,
            camera,
            settings,
            shutter,
        } = export;
        if !is_usd(path) {
            let flag = match (frame, camera, settings) {
                (Some(_), _, _) => "--frame",
                (_, Some(_), _) => "--camera",
                (_, _, Some(_)) => "--settings",
                _ => return Self::load_exported(path, shutter, refinement),
            };
            let path = path.to_path_buf();
            return Err(OpenError::UsdOnly { flag, path });
        }
        let export = export_cached(path, &export)?;
        let scene = Self::load_with(&export.dir, refinement)?;
        if export.reused {
            for warning in &scene.manifest.warnings {
                eprintln!("warning: {warning}");
            }
        }
        Ok(scene)
    }

    /// Loads an exported scene for [`Scene::open`]. A shutter that blurs
    /// must be the one the scene was exported with: its motion keys cover
    /// that interval only, and rendering another would leave what moves
    /// still without a word. Velocity fields advect volumes over any
    /// shutter, so a scene that has them renders, with a warning.
    fn load_exported(
        path: &Path,
        shutter: Option<Shutter>,
        refinement: Refinement,
    ) -> Result<Self, OpenError> {
        let scene = Self::load_with(path, refinement)?;
        let exported = scene
            .manifest
            .camera
            .shutter
            .map_or(Shutter::CLOSED, |[open, close]| Shutter { open, close });
        let Some(asked) = shutter.filter(|s| s.blurs() && *s != exported) else {
            return Ok(scene);
        };
        let velocities = scene
            .manifest
            .volumes
            .iter()
            .any(|v| v.fields.contains_key("velocity"));
        if !velocities {
            return Err(OpenError::ShutterNotExported {
                asked,
                exported,
                path: path.to_path_buf(),
            });
        }
        log::warn!(
            "--shutter {asked}: {} was exported with shutter {exported}: its velocity fields blur \
             over {asked}, but transforms move only as keyed for {exported} (export it with \
             `cirrus export --shutter {asked}` if anything else moves)",
            path.display()
        );
        Ok(scene)
    }

    /// Loads a scene from its folder or its `scene.json`, validating everything
    /// (see [`SceneError`] for what is refused), and refines its subdivision
    /// meshes at the default level.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_with(path, Refinement::default())
    }

    /// [`Scene::load`], its subdivision meshes refined as `refinement` says:
    /// once per mesh, so every instance shares the refined surface.
    pub fn load_with(path: &Path, refinement: Refinement) -> Result<Self, SceneError> {
        let dir = load::scene_dir(path);
        let (manifest, blob) = load::load(&dir)?;
        let subdivision = subdivide::cages(&manifest, Refinement::Cages);
        let mut scene = Self {
            dir,
            manifest,
            subdivision,
            blob,
        };
        scene.refine(refinement)?;
        Ok(scene)
    }

    /// What refining this scene's cages as `refinement` asks would make,
    /// mesh by mesh, every level capped at `cap` when given: counted from
    /// the cages, nothing refined (the memory preflight). Refuses a level
    /// above [`crate::subdivision::MAX_LEVEL`]. Empty once refined.
    pub fn refinement_plan(
        &self,
        refinement: Refinement,
        cap: Option<u32>,
    ) -> Result<Vec<PlannedMesh>, SceneError> {
        if self.subdivision.refinement != Refinement::Cages {
            return Ok(Vec::new());
        }
        let path = self.dir.join(MANIFEST_FILE);
        subdivide::plan(&path, &self.manifest, &self.blob, refinement, cap)
    }

    /// Refines the cages of a scene loaded with [`Refinement::Cages`] as
    /// `refinement` says: once per mesh, so every instance shares the
    /// refined surface. A scene already refined is left as it is.
    pub fn refine(&mut self, refinement: Refinement) -> Result<(), SceneError> {
        if self.subdivision.refinement == Refinement::Cages {
            let path = self.dir.join(MANIFEST_FILE);
            self.subdivision =
                subdivide::refine(&path, &mut self.manifest, &mut self.blob, refinement)?;
        }
        Ok(())
    }

    /// The elements of one of this scene's arrays, viewed in place in `scene.bin`.
    ///
    /// # Panics
    /// If `array` is not one of this scene's (validated) references.
    pub fn view<T: Element>(&self, array: &Array<T>) -> &[T] {
        self.blob.view(array)
    }

    /// The first vertex of each curve of `curves`, then the vertex count.
    pub fn curve_starts(&self, curves: &Curves) -> Vec<u32> {
        let counts = self.view(&curves.vertex_counts);
        let starts = counts.iter().scan(0, |start, &n| {
            *start += n;
            Some(*start)
        });
        std::iter::once(0).chain(starts).collect()
    }

    /// The linear pieces of `curves`, curve after curve: each one's first
    /// vertex (its second is the next one).
    pub fn piece_starts(&self, curves: &Curves) -> Vec<u32> {
        let starts = self.curve_starts(curves);
        let pieces = starts.windows(2).flat_map(|w| w[0]..w[1] - 1);
        pieces.collect()
    }

    /// CRC-32 of `scene.json` and `scene.bin` together: a fingerprint of the
    /// exported contents (the blob from memory: it was read once at load).
    pub fn content_crc(&self) -> std::io::Result<u32> {
        let manifest = std::fs::read(self.dir.join(MANIFEST_FILE))?;
        let mut crc = crc32fast::Hasher::new();
        crc.update(&manifest);
        crc.update(self.blob.bytes());
        Ok(crc.finalize())
    }

    /// Bulk bytes by kind: meshes grow with unique geometry, instances by 60
    /// bytes per instance (and their per-instance primvars).
    pub fn array_bytes(&self) -> ArrayBytes {
        let bytes = |b: Option<u64>| b.expect("validated array");
        let meshes = self
            .manifest
            .meshes
            .iter()
            .map(|m| {
                bytes(m.points.bytes())
                    + bytes(m.triangles.bytes())
                    + m.normals.as_ref().map_or(0, |a| bytes(a.bytes()))
                    + m.uvs.as_ref().map_or(0, |a| bytes(a.bytes()))
                    + m.primvars.values().map(|a| bytes(a.bytes())).sum::<u64>()
                    + bytes(m.triangle_materials.bytes())
            })
            .sum::<u64>();
        let primvars = |p: &std::collections::BTreeMap<String, Array<f32>>| {
            p.values().map(|a| bytes(a.bytes())).sum::<u64>()
        };
        let points = self
            .manifest
            .points
            .iter()
            .map(|p| bytes(p.points.bytes()) + bytes(p.widths.bytes()) + primvars(&p.primvars));
        let curves = self.manifest.curves.iter().map(|c| {
            bytes(c.points.bytes())
                + bytes(c.widths.bytes())
                + bytes(c.vertex_counts.bytes())
                + primvars(&c.primvars)
        });
        let meshes = meshes + points.chain(curves).sum::<u64>();
        let i = &self.manifest.instances;
        let instances = bytes(i.prototype.bytes())
            + bytes(i.transform.bytes())
            + bytes(i.source.bytes())
            + bytes(i.source_index.bytes())
            + i.primvars
                .values()
                .flatten()
                .map(|run| bytes(run.values.bytes()))
                .sum::<u64>();
        ArrayBytes { meshes, instances }
    }
}

/// Whether `path` names what [`Scene::open`] opens: a USD file (by its
/// extension), a folder (an exported scene) or its `scene.json`.
pub fn is_scene(path: &Path) -> bool {
    is_usd(path) || path.is_dir() || path.file_name().is_some_and(|n| n == MANIFEST_FILE)
}
