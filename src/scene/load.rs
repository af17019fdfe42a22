//! Reading a scene folder: `scene.json` parsed and checked, `scene.bin` read
//! once into a 16-byte-aligned buffer whose arrays are viewed in place with
//! `bytemuck`, never parsed element by element. Every array reference, index,
//! enum and transform is validated here, so nothing downstream re-checks.

mod instance_primvars;
mod round_shapes;

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use bytemuck::{Pod, Zeroable};

use super::format::{
    Array, CameraMotion, Element, LightShape, Manifest, MeshMotion, Subdivision, FORMAT_NAME,
    FORMAT_VERSION, NO_MATERIAL,
};
use super::material::{Input, Material};

/// Largest magnitude of a position, normal, UV or transform entry: a point
/// at 1e9 scene units under a transform entry of 1e9 stays below 1e19, whose
/// squared box extents still fit in f32.
const MAX_MAGNITUDE: f32 = 1e9;
/// The manifest's file name inside a scene folder.
pub const MANIFEST_FILE: &str = "scene.json";
/// The bulk data's file name inside a scene folder.
pub const BLOB_FILE: &str = "scene.bin";

/// Why a scene folder could not be loaded. Every variant names the file, and
/// [`SceneError::Invalid`] the field path (`meshes[3].triangles`).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be opened or read (missing, truncated, permissions).
    #[error("{path}: {error}", path = path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// `scene.json` is not valid JSON.
    #[error("{path}: not JSON: {error}", path = path.display())]
    NotJson {
        /// `scene.json`.
        path: PathBuf,
        /// The parser's message, with line and column.
        error: serde_json::Error,
    },
    /// Valid JSON, but not a Cirrus scene manifest.
    #[error("{path}: not a Cirrus scene (\"format\" is {found}, expected \"{FORMAT_NAME}\")", path = path.display())]
    NotScene {
        /// `scene.json`.
        path: PathBuf,
        /// The `format` value found.
        found: String,
    },
    /// A manifest of another format version.
    #[error("{path}: scene format version {found}, but this Cirrus reads version {FORMAT_VERSION} only; re-export the scene with this checkout's exporter", path = path.display())]
    Version {
        /// `scene.json`.
        path: PathBuf,
        /// The `version` value found.
        found: String,
    },
    /// A field that is missing, of the wrong type or out of range.
    #[error("{path}: {field}: {message}", path = path.display())]
    Invalid {
        /// `scene.json` (or `scene.bin` for array contents).
        path: PathBuf,
        /// JSON path of the field, e.g. `meshes[3].triangles`.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A subdivision level above [`crate::subdivision::MAX_LEVEL`], refused
    /// before refining anything.
    #[error("{path}: subdivision level {level} ({from}) is above the safe bound {max}: it would make {triangles} triangles", path = path.display(), max = crate::subdivision::MAX_LEVEL)]
    SubdivisionLevel {
        /// `scene.json`.
        path: PathBuf,
        /// The level asked for.
        level: u32,
        /// Who asked: `--subdiv-level`, or the mesh whose primvar says so.
        from: String,
        /// Triangles the scene's subdivision meshes would make at their levels.
        triangles: u64,
    },
}

/// One 16-byte chunk: a `Vec` of these is a byte buffer aligned for any array view.
#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C, align(16))]
struct Chunk([u8; 16]);

/// The contents of `scene.bin`, 16-byte aligned.
pub(crate) struct Blob {
    chunks: Vec<Chunk>,
    len: usize,
}

impl Blob {
    /// The file's bytes.
    pub(crate) fn bytes(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.chunks)[..self.len]
    }

    /// The elements of a validated array, viewed in place.
    pub(crate) fn view<T: Element>(&self, array: &Array<T>) -> &[T] {
        let start = array.offset as usize;
        let end = start + array.bytes().expect("validated array") as usize;
        bytemuck::cast_slice(&self.bytes()[start..end])
    }

    /// Appends `values` at the next 16-byte boundary (a refined mesh's
    /// arrays) and returns their reference.
    pub(crate) fn push<T: Element>(&mut self, values: &[T]) -> Array<T> {
        let offset = self.chunks.len() * 16;
        let bytes: &[u8] = bytemuck::cast_slice(values);
        let mut chunks = vec![Chunk::zeroed(); bytes.len().div_ceil(16)];
        bytemuck::cast_slice_mut(&mut chunks)[..bytes.len()].copy_from_slice(bytes);
        self.chunks.extend(chunks);
        self.len = offset + bytes.len();
        Array::new(offset as u64, values.len() as u64)
    }

    fn read(path: &Path) -> Result<Self, SceneError> {
        let io = |error| SceneError::Io {
            path: path.to_owned(),
            error,
        };
        let mut file = File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len() as usize;
        let mut chunks = vec![Chunk::zeroed(); len.div_ceil(16)];
        file.read_exact(&mut bytemuck::cast_slice_mut(&mut chunks)[..len])
            .map_err(io)?;
        Ok(Self { chunks, len })
    }
}

/// Resolves a scene argument (the folder, or its `scene.json`) to the folder.
pub(crate) fn scene_dir(path: &Path) -> PathBuf {
    if path.file_name().is_some_and(|n| n == MANIFEST_FILE) {
        path.parent().unwrap_or(Path::new(".")).to_owned()
    } else {
        path.to_owned()
    }
}

/// Reads and validates `dir/scene.json` and `dir/scene.bin`.
pub(crate) fn load(dir: &Path) -> Result<(Manifest, Blob), SceneError> {
    let manifest_path = dir.join(MANIFEST_FILE);
    let text = std::fs::read_to_string(&manifest_path).map_err(|error| SceneError::Io {
        path: manifest_path.clone(),
        error,
    })?;
    let mut manifest = parse_manifest(&manifest_path, &text)?;
    anchor_relative_files(&mut manifest, dir);
    let blob = Blob::read(&dir.join(BLOB_FILE))?;
    Checker {
        path: &manifest_path,
        blob: &blob,
        manifest: &manifest,
    }
    .scene()?;
    Ok((manifest, blob))
}

/// Makes the image paths written relative to the scene folder (textures the
/// exporter extracted from a `.usdz` into `usdz/`) absolute, so the scene
/// folder can be renamed or moved with them.
fn anchor_relative_files(manifest: &mut Manifest, dir: &Path) {
    let anchor = |file: &mut PathBuf| {
        // Empty = no file authored (warned at export): nothing to anchor.
        if file.is_relative() && !file.as_os_str().is_empty() {
            *file = dir.join(&*file);
        }
    };
    manifest
        .textures
        .iter_mut()
        .for_each(|t| anchor(&mut t.file));
    for light in &mut manifest.lights {
        if let LightShape::Rect { texture, .. } | LightShape::Dome { texture, .. } =
            &mut light.shape
        {
            texture.iter_mut().for_each(anchor);
        }
    }
}

/// Parses the manifest: the format name and version first, so a file of another
/// version is refused as such rather than as a pile of field errors.
fn parse_manifest(path: &Path, text: &str) -> Result<Manifest, SceneError> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|error| SceneError::NotJson {
            path: path.to_owned(),
            error,
        })?;
    let field = |name: &str| {
        value
            .get(name)
            .map_or_else(|| "missing".to_owned(), |v| v.to_string())
    };
    if value.get("format").and_then(|v| v.as_str()) != Some(FORMAT_NAME) {
        return Err(SceneError::NotScene {
            path: path.to_owned(),
            found: field("format"),
        });
    }
    if value.get("version").and_then(|v| v.as_u64()) != Some(FORMAT_VERSION.into()) {
        return Err(SceneError::Version {
            path: path.to_owned(),
            found: field("version"),
        });
    }
    if let Some((field, number)) = number_beyond_f32(&value, String::new()) {
        return Err(SceneError::Invalid {
            path: path.to_owned(),
            field,
            message: format!("{number:e} is beyond the single-precision range"),
        });
    }
    serde_path_to_error::deserialize(value).map_err(|e| SceneError::Invalid {
        path: path.to_owned(),
        // serde_path_to_error names the root ".": a field missing at the top level.
        field: match e.path().to_string() {
            root if root == "." => "manifest".to_owned(),
            path => path,
        },
        message: e.inner().to_string(),
    })
}

/// The first number of the manifest (path like `lights[2].intensity`, and
/// its value) too large for an f32: read as one it would be infinite.
/// (JSON has no NaN or infinity; the parser refuses those tokens.)
fn number_beyond_f32(value: &serde_json::Value, at: String) -> Option<(String, f64)> {
    use serde_json::Value;
    match value {
        Value::Number(n) => n
            .as_f64()
            .filter(|v| v.abs() > f64::from(f32::MAX))
            .map(|v| (at, v)),
        Value::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, v)| number_beyond_f32(v, format!("{at}[{i}]"))),
        Value::Object(fields) => fields.iter().find_map(|(k, v)| {
            let name = if at.is_empty() {
                k.clone()
            } else {
                format!("{at}.{k}")
            };
            number_beyond_f32(v, name)
        }),
        _ => None,
    }
}

/// Cross-field validation of a parsed manifest against its blob.
struct Checker<'a> {
    path: &'a Path,
    blob: &'a Blob,
    manifest: &'a Manifest,
}

impl Checker<'_> {
    fn invalid(&self, field: &str, message: String) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_owned(),
            field: field.to_owned(),
            message,
        }
    }

    fn scene(&self) -> Result<(), SceneError> {
        let m = self.manifest;
        let mpu = m.stage.meters_per_unit;
        if !(mpu.is_finite() && mpu > 0.0) {
            return Err(self.invalid(
                "stage.meters_per_unit",
                format!("{mpu} is not a positive number"),
            ));
        }
        for (i, mesh) in m.meshes.iter().enumerate() {
            self.mesh(i, mesh)?;
        }
        for (i, proto) in m.prototypes.iter().enumerate() {
            let meshes = proto.meshes.iter().map(|p| (p.mesh, &p.transform));
            self.parts(i, ("meshes", "mesh"), meshes, m.meshes.len())?;
            let volumes = proto.volumes.iter().map(|p| (p.volume, &p.transform));
            self.parts(i, ("volumes", "volume"), volumes, m.volumes.len())?;
        }
        self.round_shapes()?;
        self.instances()?;
        for (i, mat) in m.materials.iter().enumerate() {
            self.material(&format!("materials[{i}]"), mat)?;
        }
        for (i, light) in m.lights.iter().enumerate() {
            self.finite(&format!("lights[{i}].transform"), &light.transform)?;
            if let Some(motion) = &light.motion {
                self.keyed(&format!("lights[{i}].motion"), motion)?;
            }
        }
        self.finite("camera.transform", &m.camera.transform)?;
        self.camera_motion()
    }

    /// The camera's shutter (finite, close >= open) and motion keys.
    fn camera_motion(&self) -> Result<(), SceneError> {
        let camera = &self.manifest.camera;
        if let Some(shutter) = camera.shutter {
            crate::motion::Shutter::new(shutter[0], shutter[1])
                .map_err(|e| self.invalid("camera.shutter", e.to_string()))?;
        }
        camera
            .motion
            .as_ref()
            .map_or(Ok(()), |motion| self.keyed("camera.motion", motion))
    }

    /// Keyed transforms (a camera's or a light's `motion`): times strictly
    /// increasing, one finite transform per key time.
    fn keyed(&self, field: &str, motion: &CameraMotion) -> Result<(), SceneError> {
        self.key_times(&format!("{field}.times"), &motion.times)?;
        let field = format!("{field}.transforms");
        let keys = motion.transforms.len();
        self.count(&field, keys, motion.times.len(), "key time")?;
        self.finite(&field, bytemuck::cast_slice(&motion.transforms))
    }

    /// Moving instances: indices strictly increasing below the instance
    /// count, one finite transform per instance and key time.
    fn instance_motion(&self) -> Result<(), SceneError> {
        let inst = &self.manifest.instances;
        let Some(motion) = &inst.motion else {
            return Ok(());
        };
        self.key_times("instances.motion.times", &motion.times)?;
        let moving = self.array("instances.motion.instance", &motion.instance)?;
        self.indices(
            "instances.motion.instance",
            moving.iter().copied(),
            inst.count as usize,
            "instances",
            None,
        )?;
        if moving.windows(2).any(|w| w[0] >= w[1]) {
            return Err(self.invalid(
                "instances.motion.instance",
                "indices must be strictly increasing".into(),
            ));
        }
        let transform = self.array("instances.motion.transform", &motion.transform)?;
        let want = moving.len() * motion.times.len();
        self.count(
            "instances.motion.transform",
            transform.len(),
            want,
            "moving instance and key time",
        )?;
        self.finite(
            "instances.motion.transform",
            bytemuck::cast_slice(transform),
        )
    }

    /// Key times: at least one, finite and strictly increasing.
    fn key_times(&self, field: &str, times: &[f32]) -> Result<(), SceneError> {
        self.finite(field, times)?;
        if times.is_empty() || times.windows(2).any(|w| w[0] >= w[1]) {
            return Err(self.invalid(
                field,
                "expected at least one time, strictly increasing".into(),
            ));
        }
        Ok(())
    }

    /// Every texture index a material's inputs name, at any depth.
    fn material(&self, field: &str, mat: &Material) -> Result<(), SceneError> {
        let colors = [
            ("diffuse_color", &mat.diffuse_color),
            ("emissive_color", &mat.emissive_color),
            ("specular_color", &mat.specular_color),
        ];
        let scalars = [
            ("metallic", &mat.metallic),
            ("roughness", &mat.roughness),
            ("opacity", &mat.opacity),
        ];
        let open_pbr = format!("{field}.open_pbr");
        for (name, input) in colors {
            self.input(&format!("{field}.{name}"), input)?;
        }
        for (name, input) in mat.open_pbr.colors() {
            self.input(&format!("{open_pbr}.{name}"), input)?;
        }
        for (name, input) in scalars {
            self.input(&format!("{field}.{name}"), input)?;
        }
        for (name, input) in mat.open_pbr.scalars() {
            self.input(&format!("{open_pbr}.{name}"), input)?;
        }
        let maps = [
            ("normal", mat.normal.as_ref().map(|t| t.texture)),
            (
                "geometry_normal",
                mat.geometry_normal.as_ref().map(|n| n.texture),
            ),
            (
                "geometry_coat_normal",
                mat.geometry_coat_normal.as_ref().map(|n| n.texture),
            ),
        ];
        for (name, texture) in maps {
            if let Some(t) = texture {
                self.texture(&format!("{field}.{name}.texture"), t)?;
            }
        }
        Ok(())
    }

    /// An input's texture indices, through its operations' arguments.
    fn input<T>(&self, field: &str, input: &Input<T>) -> Result<(), SceneError> {
        match input {
            Input::Constant(_) | Input::Primvar(_) => Ok(()),
            Input::Texture(t) => self.texture(&format!("{field}.texture"), t.texture),
            Input::Op(op) => op
                .args
                .iter()
                .enumerate()
                .try_for_each(|(i, arg)| self.input(&format!("{field}.args[{i}]"), arg)),
        }
    }

    fn texture(&self, field: &str, texture: u32) -> Result<(), SceneError> {
        self.index(field, texture, self.manifest.textures.len(), "textures")
    }

    fn mesh(&self, i: usize, mesh: &super::format::Mesh) -> Result<(), SceneError> {
        let field = |name: &str| format!("meshes[{i}].{name}");
        let points = self.array(&field("points"), &mesh.points)?;
        self.finite(&field("points"), bytemuck::cast_slice(points))?;
        let triangles = self.array(&field("triangles"), &mesh.triangles)?;
        self.indices(
            &field("triangles"),
            triangles.iter().flatten().copied(),
            points.len(),
            "points",
            None,
        )?;
        if let Some(normals) = &mesh.normals {
            let normals = self.array(&field("normals"), normals)?;
            self.count(&field("normals"), normals.len(), points.len(), "points")?;
            self.finite(&field("normals"), bytemuck::cast_slice(normals))?;
        }
        if let Some(uvs) = &mesh.uvs {
            let uvs = self.array(&field("uvs"), uvs)?;
            self.count(&field("uvs"), uvs.len(), points.len(), "points")?;
            self.finite(&field("uvs"), bytemuck::cast_slice(uvs))?;
        }
        for (name, primvar) in &mesh.primvars {
            let field = field(&format!("primvars.{name}"));
            let values = self.array_of_width(&field, primvar, 1..=4)?;
            self.count(&field, primvar.count as usize, points.len(), "points")?;
            self.finite(&field, values)?;
        }
        let materials = self.array(&field("triangle_materials"), &mesh.triangle_materials)?;
        self.count(
            &field("triangle_materials"),
            materials.len(),
            triangles.len(),
            "triangles",
        )?;
        self.indices(
            &field("triangle_materials"),
            materials.iter().copied(),
            self.manifest.materials.len(),
            "materials",
            Some(NO_MATERIAL),
        )?;
        if let Some(motion) = &mesh.motion {
            self.mesh_motion(
                &field("motion"),
                motion,
                points.len(),
                mesh.normals.is_some(),
            )?;
        }
        match &mesh.subdivision {
            Some(cage) => self.cage(&field("subdivision"), cage, points.len()),
            None => Ok(()),
        }
    }

    /// A deforming mesh's keys (`field` is `meshes[i].motion`): key times,
    /// finite points (and normals, exactly when the mesh has them) for
    /// every point at every key.
    fn mesh_motion(
        &self,
        field: &str,
        motion: &MeshMotion,
        points: usize,
        normals: bool,
    ) -> Result<(), SceneError> {
        let f = |name: &str| format!("{field}.{name}");
        let want = self.keyed_points(field, &motion.times, &motion.points, points)?;
        match (&motion.normals, normals) {
            (Some(keyed), true) => {
                let keyed = self.array(&f("normals"), keyed)?;
                self.count(&f("normals"), keyed.len(), want, "point and key time")?;
                self.finite(&f("normals"), bytemuck::cast_slice(keyed))
            }
            (None, false) => Ok(()),
            (_, has) => Err(self.invalid(
                &f("normals"),
                format!(
                    "must be present exactly when the mesh has normals ({})",
                    if has { "it has" } else { "it has none" }
                ),
            )),
        }
    }

    /// Keyed points (`field` is a record's `motion`): key times, and a finite
    /// point for each of `points` at every key; the element count wanted
    /// of arrays laid out like them.
    fn keyed_points(
        &self,
        field: &str,
        times: &[f32],
        keyed: &Array<[f32; 3]>,
        points: usize,
    ) -> Result<usize, SceneError> {
        let f = |name: &str| format!("{field}.{name}");
        self.key_times(&f("times"), times)?;
        let want = points * times.len();
        let keyed = self.array(&f("points"), keyed)?;
        self.count(&f("points"), keyed.len(), want, "point and key time")?;
        self.finite(&f("points"), bytemuck::cast_slice(keyed))?;
        Ok(want)
    }

    /// A subdivision record: every index below what it indexes, counts
    /// matching (`field` is `meshes[i].subdivision`).
    fn cage(&self, field: &str, cage: &Subdivision, points: usize) -> Result<(), SceneError> {
        let f = |name: &str| format!("{field}.{name}");
        let vertices = cage.vertex_count as usize;
        let counts = self.array(&f("face_counts"), &cage.face_counts)?;
        let indices = self.array(&f("face_indices"), &cage.face_indices)?;
        let corners: u64 = counts.iter().map(|&n| u64::from(n)).sum();
        self.count(
            &f("face_indices"),
            indices.len(),
            corners as usize,
            "face corner",
        )?;
        self.indices(
            &f("face_indices"),
            indices.iter().copied(),
            vertices,
            "vertices",
            None,
        )?;
        let corner_points = self.array(&f("corner_points"), &cage.corner_points)?;
        self.count(
            &f("corner_points"),
            corner_points.len(),
            indices.len(),
            "face corner",
        )?;
        self.indices(
            &f("corner_points"),
            corner_points.iter().copied(),
            points,
            "points",
            None,
        )?;
        let materials = self.array(&f("face_materials"), &cage.face_materials)?;
        self.count(&f("face_materials"), materials.len(), counts.len(), "face")?;
        let len = self.manifest.materials.len();
        self.indices(
            &f("face_materials"),
            materials.iter().copied(),
            len,
            "materials",
            Some(NO_MATERIAL),
        )?;
        let sharpness = self.array(&f("crease_sharpness"), &cage.crease_sharpness)?;
        self.finite(&f("crease_sharpness"), sharpness)?;
        let pairs = self.array(&f("crease_pairs"), &cage.crease_pairs)?;
        self.count(
            &f("crease_pairs"),
            pairs.len(),
            2 * sharpness.len(),
            "sharpness, twice",
        )?;
        self.indices(
            &f("crease_pairs"),
            pairs.iter().copied(),
            vertices,
            "vertices",
            None,
        )?;
        let sharpness = self.array(&f("corner_sharpness"), &cage.corner_sharpness)?;
        self.finite(&f("corner_sharpness"), sharpness)?;
        let corners = self.array(&f("corners"), &cage.corners)?;
        self.count(&f("corners"), corners.len(), sharpness.len(), "sharpness")?;
        self.indices(
            &f("corners"),
            corners.iter().copied(),
            vertices,
            "vertices",
            None,
        )?;
        let holes = self.array(&f("holes"), &cage.holes)?;
        self.indices(
            &f("holes"),
            holes.iter().copied(),
            counts.len(),
            "faces",
            None,
        )
    }

    fn instances(&self) -> Result<(), SceneError> {
        let inst = &self.manifest.instances;
        let n = inst.count as usize;
        let prototype = self.array("instances.prototype", &inst.prototype)?;
        self.count("instances.prototype", prototype.len(), n, "instances")?;
        let prototypes = self.manifest.prototypes.len();
        self.indices(
            "instances.prototype",
            prototype.iter().copied(),
            prototypes,
            "prototypes",
            None,
        )?;
        let transform = self.array("instances.transform", &inst.transform)?;
        self.count("instances.transform", transform.len(), n, "instances")?;
        self.finite("instances.transform", bytemuck::cast_slice(transform))?;
        let source = self.array("instances.source", &inst.source)?;
        self.count("instances.source", source.len(), n, "instances")?;
        self.indices(
            "instances.source",
            source.iter().copied(),
            inst.instance_sources.len(),
            "instance_sources",
            None,
        )?;
        let source_index = self.array("instances.source_index", &inst.source_index)?;
        self.count("instances.source_index", source_index.len(), n, "instances")?;
        if let Some(runs) = &inst.names {
            let named = runs
                .iter()
                .try_fold(0u64, |sum, r| sum.checked_add(r.count));
            if named != Some(inst.count) {
                let named = named.map_or("more than 2^64".into(), |c| c.to_string());
                return Err(self.invalid(
                    "instances.names",
                    format!("its runs name {named} instances, expected {n}"),
                ));
            }
        }
        self.instance_primvars()?;
        self.instance_motion()
    }

    /// Checks an array reference (type, width, alignment, extent) and views it.
    fn array<T: Element>(&self, field: &str, array: &Array<T>) -> Result<&[T], SceneError> {
        self.array_of_width(field, array, T::WIDTH..=T::WIDTH)
    }

    /// [`Self::array`] for an array whose width may be any of `widths`
    /// (its elements then viewed as `width` scalars each).
    fn array_of_width<T: Element>(
        &self,
        field: &str,
        array: &Array<T>,
        widths: std::ops::RangeInclusive<u32>,
    ) -> Result<&[T], SceneError> {
        if array.scalar != T::SCALAR {
            return Err(self.invalid(
                field,
                format!("type {:?}, expected {:?}", array.scalar, T::SCALAR).to_lowercase(),
            ));
        }
        if !widths.contains(&array.width) {
            let (low, high) = (widths.start(), widths.end());
            let expected = if low == high {
                low.to_string()
            } else {
                format!("{low} to {high}")
            };
            return Err(self.invalid(field, format!("width {}, expected {expected}", array.width)));
        }
        if !array.offset.is_multiple_of(16) {
            return Err(self.invalid(
                field,
                format!("offset {} is not a multiple of 16", array.offset),
            ));
        }
        let len = self.blob.bytes().len() as u64;
        match array.bytes().and_then(|b| b.checked_add(array.offset)) {
            Some(end) if end <= len => Ok(self.blob.view(array)),
            _ => Err(self.invalid(
                field,
                format!(
                    "{} elements at offset {} run past the end of {BLOB_FILE} ({len} bytes)",
                    array.count, array.offset
                ),
            )),
        }
    }

    fn count(&self, field: &str, got: usize, want: usize, of: &str) -> Result<(), SceneError> {
        if got == want {
            Ok(())
        } else {
            Err(self.invalid(
                field,
                format!("count {got}, expected one per {of} ({want})"),
            ))
        }
    }

    /// Prototype `prototype`'s parts of one kind (`(list, key)` name the
    /// manifest fields, e.g. `("meshes", "mesh")`): each an index below
    /// `len` into the top-level list of that name, with a finite transform.
    fn parts<'t>(
        &self,
        prototype: usize,
        (list, key): (&str, &str),
        parts: impl Iterator<Item = (u32, &'t [f32; 12])>,
        len: usize,
    ) -> Result<(), SceneError> {
        for (j, (index, transform)) in parts.enumerate() {
            let field = format!("prototypes[{prototype}].{list}[{j}]");
            self.index(&format!("{field}.{key}"), index, len, list)?;
            self.finite(&format!("{field}.transform"), transform)?;
        }
        Ok(())
    }

    fn index(&self, field: &str, index: u32, len: usize, of: &str) -> Result<(), SceneError> {
        self.indices(field, std::iter::once(index), len, of, None)
    }

    /// Every index `< len`, or equal to `allowed` (a "none" sentinel).
    fn indices(
        &self,
        field: &str,
        indices: impl Iterator<Item = u32>,
        len: usize,
        of: &str,
        allowed: Option<u32>,
    ) -> Result<(), SceneError> {
        for index in indices {
            if index as usize >= len && Some(index) != allowed {
                return Err(self.invalid(field, format!("index {index} >= {len} {of}")));
            }
        }
        Ok(())
    }

    /// Refuses NaN, infinite and huge values: positions and transform
    /// entries beyond [`MAX_MAGNITUDE`], composed, would overflow the BVH's
    /// f32 box areas.
    fn finite(&self, field: &str, values: &[f32]) -> Result<(), SceneError> {
        let bad = |v: &f32| !v.is_finite() || v.abs() > MAX_MAGNITUDE;
        match values.iter().position(bad) {
            None => Ok(()),
            Some(at) => Err(self.invalid(
                field,
                format!(
                    "value {} at scalar {at} is not finite or beyond ±{MAX_MAGNITUDE:e}",
                    values[at]
                ),
            )),
        }
    }
}
