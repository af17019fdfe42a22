//! The records of `scene.json`, format version 1, field for field as
//! `exporter/FORMAT.md` defines them. Each field names the USD attribute it comes
//! from, its default when unauthored, and its units. serde checks shapes and
//! enums; `load.rs` checks everything that needs more than one field (array
//! references against `scene.bin`, indices, finite numbers).

use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::path::PathBuf;

use serde::Deserialize;

use super::material::{unit_scale, Material, Rgb, Texture};

mod dome_format;
mod instance_primvars;
mod light;
mod linking;
mod names;
mod shaping;
pub use dome_format::DomeFormat;
pub use instance_primvars::InstancePrimvarRun;
pub use light::{Light, LightShape};
pub use linking::{LightLinks, LinkRun};
pub use names::{NamePattern, NameRun};
pub use shaping::LightShaping;

/// The only manifest version this loader reads.
pub const FORMAT_VERSION: u32 = 1;

/// The value of the manifest's `format` field.
pub const FORMAT_NAME: &str = "cirrus-scene";

/// A 3x4 row-major affine matrix `[R | t]` acting on column vectors:
/// `p' = M[:, :3] p + M[:, 3]`; composed in double precision by the exporter.
pub type Transform = [f32; 12];

/// A [`Transform`] as a glam affine map (`matrix3` columns are the 3x4's
/// first three columns).
pub fn affine(m: &Transform) -> glam::Affine3A {
    use glam::{Mat3A, Vec3A};
    glam::Affine3A {
        matrix3: Mat3A::from_cols(
            Vec3A::new(m[0], m[4], m[8]),
            Vec3A::new(m[1], m[5], m[9]),
            Vec3A::new(m[2], m[6], m[10]),
        ),
        translation: Vec3A::new(m[3], m[7], m[11]),
    }
}

/// The whole manifest: everything the renderer models, bulk data as [`Array`]s.
#[derive(Clone, Debug, Deserialize)]
pub struct Manifest {
    /// Always [`FORMAT_NAME`].
    pub format: String,
    /// Always [`FORMAT_VERSION`]; checked before the rest is parsed.
    pub version: u32,
    /// The USD file this scene was exported from.
    pub source: Source,
    /// Stage metadata.
    pub stage: Stage,
    /// World-space bounds of all geometry and volumes, in scene units.
    pub bounds: Bounds,
    /// Unique geometry, stored once and shared by prototypes.
    pub meshes: Vec<Mesh>,
    /// `UsdGeomPoints`, stored once and shared by prototypes (absent in
    /// files written before points).
    #[serde(default)]
    pub points: Vec<Points>,
    /// `UsdGeomBasisCurves` (and `NurbsCurves` as their control polygon),
    /// as linear round tubes (absent in files written before curves).
    #[serde(default)]
    pub curves: Vec<Curves>,
    /// What instances place: meshes and volumes in the prototype's space.
    pub prototypes: Vec<Prototype>,
    /// Every placed copy, plain prims included, as structure of arrays.
    pub instances: Instances,
    /// Materials, indexed by `Mesh::triangle_materials`.
    pub materials: Vec<Material>,
    /// Image files, indexed by [`TextureInput::texture`](super::TextureInput::texture).
    pub textures: Vec<Texture>,
    /// UsdLux lights.
    pub lights: Vec<Light>,
    /// The render camera (or a default one framing `bounds`).
    pub camera: Camera,
    /// Volume prims with their OpenVDB fields.
    pub volumes: Vec<Volume>,
    /// Render settings.
    pub render: Render,
    /// Everything that fell back during export, once each.
    pub warnings: Vec<String>,
    /// Of those warnings, the prims and attributes not rendered or
    /// approximated, counted by kind (optional: none counted when absent).
    #[serde(default)]
    pub unrendered: Unrendered,
}

/// Counts by kind (`NurbsPatch`, `NurbsCurves`, ...) of what the exporter
/// warned it does not render, or renders approximately.
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(default)]
pub struct Unrendered {
    /// Left out of the render.
    pub not_rendered: BTreeMap<String, u64>,
    /// Rendered, but not as authored.
    pub approximated: BTreeMap<String, u64>,
}

/// Where the scene came from.
#[derive(Clone, Debug, Deserialize)]
pub struct Source {
    /// Absolute path of the exported USD file.
    pub path: PathBuf,
    /// Its modification time, seconds since the Unix epoch.
    pub mtime: f64,
    /// The USD time code exported; `null` = the default time.
    pub time_code: Option<f64>,
}

/// Stage-level metadata.
#[derive(Clone, Debug, Deserialize)]
pub struct Stage {
    /// `metersPerUnit` (default 0.01): metres per scene unit.
    pub meters_per_unit: f64,
    /// `upAxis` (default Y).
    pub up_axis: UpAxis,
}

/// USD's `upAxis`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum UpAxis {
    /// +Y is up.
    Y,
    /// +Z is up.
    Z,
}

/// An axis-aligned box in world space, scene units.
#[derive(Clone, Copy, Debug, Deserialize)]
pub struct Bounds {
    /// Smallest corner.
    pub min: [f32; 3],
    /// Largest corner.
    pub max: [f32; 3],
}

/// The scalar type of an array in `scene.bin`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scalar {
    /// IEEE 754 binary32, little-endian.
    F32,
    /// Unsigned 32-bit integer, little-endian.
    U32,
}

/// What one element of an [`Array`] is in Rust: its scalar type and width, so
/// the loader can check the manifest's `type`/`width` before viewing the bytes.
pub trait Element: bytemuck::Pod {
    /// The scalar type the manifest must name.
    const SCALAR: Scalar;
    /// Scalars per element the manifest must name.
    const WIDTH: u32;
}

macro_rules! element {
    ($t:ty, $scalar:ident, $width:expr) => {
        impl Element for $t {
            const SCALAR: Scalar = Scalar::$scalar;
            const WIDTH: u32 = $width;
        }
    };
}
element!(u32, U32, 1);
// A primvar: `width` (1 to 4) floats per element, viewed as flat scalars.
element!(f32, F32, 1);
element!([u32; 3], U32, 3);
element!([f32; 2], F32, 2);
element!([f32; 3], F32, 3);
element!([f32; 12], F32, 12);

/// A reference to bulk data in `scene.bin`: `count` elements of type `T`
/// starting at byte `offset`. View it with `Scene::view`.
#[derive(Clone, Debug, Deserialize)]
#[serde(bound = "")]
pub struct Array<T> {
    /// Byte offset into `scene.bin`, a multiple of 16.
    pub offset: u64,
    /// Number of elements (not scalars).
    pub count: u64,
    /// Scalar type as written; must equal `T::SCALAR`.
    #[serde(rename = "type")]
    pub scalar: Scalar,
    /// Scalars per element as written; must equal `T::WIDTH`.
    pub width: u32,
    #[serde(skip)]
    element: PhantomData<T>,
}

impl<T: Element> Array<T> {
    /// A reference to `count` elements at `offset` (for arrays the loader
    /// appends: refined meshes).
    pub(crate) fn new(offset: u64, count: u64) -> Self {
        Self {
            offset,
            count,
            scalar: T::SCALAR,
            width: T::WIDTH,
            element: PhantomData,
        }
    }

    /// Bytes the array occupies in `scene.bin` (`None` on overflow).
    pub fn bytes(&self) -> Option<u64> {
        self.count.checked_mul(u64::from(self.width) * 4)
    }
}

/// Unique triangle geometry in its prototype's local space (`UsdGeomMesh`).
#[derive(Clone, Debug, Deserialize)]
pub struct Mesh {
    /// Prim path (inside the prototype for instanced geometry).
    pub path: String,
    /// `points`: vertex positions, scene units; unwelded per corner by the
    /// exporter where normals or UVs are faceVarying.
    pub points: Array<[f32; 3]>,
    /// `faceVertexIndices`, fan-triangulated, counter-clockwise seen from the
    /// front (`leftHanded` meshes flipped by the exporter); indices into `points`.
    pub triangles: Array<[u32; 3]>,
    /// `normals`/`primvars:normals`, one per point; `null` = geometric normals.
    pub normals: Option<Array<[f32; 3]>>,
    /// `primvars:st`, one per point; `null` when unauthored.
    pub uvs: Option<Array<[f32; 2]>>,
    /// Bound material per triangle (GeomSubsets resolved); [`NO_MATERIAL`] = none.
    pub triangle_materials: Array<u32>,
    /// `doubleSided` (default false).
    pub double_sided: bool,
    /// The primvars some bound material reads, by name (default none): f32,
    /// `width` 1 to 4, one element per point (unwelded like `uvs`).
    #[serde(default)]
    pub primvars: BTreeMap<String, Array<f32>>,
    /// The control cage of a mesh whose `subdivisionScheme` is not `none`;
    /// absent for polygonal meshes and in files written before subdivision.
    /// The arrays above then hold the triangulated cage, which the loader
    /// replaces with the refined surface (or keeps, with a warning, when
    /// OpenSubdiv refuses the cage).
    #[serde(default)]
    pub subdivision: Option<Subdivision>,
    /// The mesh's points (and normals) at key times over the shutter, when
    /// it deforms (time-sampled points, `velocities`, UsdSkel animation);
    /// absent for meshes that do not (and in files written before
    /// deforming motion blur). The arrays above hold the mesh at the frame.
    #[serde(default)]
    pub motion: Option<MeshMotion>,
}

/// A deforming mesh's vertices at key times (docs/rendering.md, "Motion
/// blur"): each vertex moves linearly between neighbouring keys, the end
/// keys held outside them; the triangles, UVs, primvars and materials stay
/// those of the [`Mesh`]. A subdivision mesh's keys are its cage's points,
/// refined at load like the frame's.
#[derive(Clone, Debug, Deserialize)]
pub struct MeshMotion {
    /// Key times, frames relative to `source.time_code`, strictly increasing.
    pub times: Vec<f32>,
    /// Every point of the mesh at every key, key-major: point i at key k is
    /// element `k * points.count + i`.
    pub points: Array<[f32; 3]>,
    /// The normals at every key, laid out like `points`; present exactly
    /// when the mesh has `normals` (they are interpolated between keys and
    /// renormalized).
    pub normals: Option<Array<[f32; 3]>>,
}

/// A subdivision surface's control cage and tags (`UsdGeomMesh`), refined by
/// `crate::subdivision` at load. Cage vertex `face_indices[c]` sits at
/// `points[corner_points[c]]`, and every per-point array of the [`Mesh`]
/// (`uvs`) is read at the corners the same way, so a per-point primvar is
/// refined as face-varying data (or per vertex when the mesh is welded).
#[derive(Clone, Debug, Deserialize)]
pub struct Subdivision {
    /// `subdivisionScheme` (`catmullClark` when unauthored, as USD defines it).
    pub scheme: crate::subdivision::Scheme,
    /// `interpolateBoundary` (default `edgeAndCorner`).
    pub interpolate_boundary: crate::subdivision::Boundary,
    /// `faceVaryingLinearInterpolation` (default `cornersPlus1`).
    pub face_varying_linear_interpolation: crate::subdivision::FaceVaryingLinear,
    /// `triangleSubdivisionRule` (default `catmullClark`).
    pub triangle_subdivision_rule: crate::subdivision::TriangleRule,
    /// `primvars:cirrus:subdivisionLevel` (constant int): this mesh's level,
    /// which `--subdiv-level` does not override; `null` when unauthored.
    pub level: Option<u32>,
    /// Number of authored `points` (cage vertices).
    pub vertex_count: u32,
    /// `faceVertexCounts`, every face.
    pub face_counts: Array<u32>,
    /// `faceVertexIndices`, cage vertex indices (reversed per face for `leftHanded`).
    pub face_indices: Array<u32>,
    /// Per face corner: the index into the mesh's `points` holding it.
    pub corner_points: Array<u32>,
    /// Bound material per cage face (GeomSubsets resolved); [`NO_MATERIAL`] = none.
    pub face_materials: Array<u32>,
    /// `creaseIndices`/`creaseLengths` as vertex pairs, two entries per creased edge.
    pub crease_pairs: Array<u32>,
    /// `creaseSharpnesses` per creased edge (10 or more: infinitely sharp).
    pub crease_sharpness: Array<f32>,
    /// `cornerIndices`: sharp cage vertices.
    pub corners: Array<u32>,
    /// `cornerSharpnesses`, one per corner.
    pub corner_sharpness: Array<f32>,
    /// `holeIndices`: cage faces not rendered.
    pub holes: Array<u32>,
}

/// A `UsdGeomPoints` prim: spheres in its prototype's local space.
#[derive(Clone, Debug, Deserialize)]
pub struct Points {
    /// Prim path (inside the prototype for instanced geometry).
    pub path: String,
    /// `points`: sphere centres, scene units (points whose width is negative
    /// or not finite are left out by the exporter, with a warning).
    pub points: Array<[f32; 3]>,
    /// `widths`: sphere diameters, scene units; one (constant) or one per
    /// point. Unauthored: one width of 1 (with a warning).
    pub widths: Array<f32>,
    /// Bound material (or the `displayColor` one); [`NO_MATERIAL`] = none.
    pub material: u32,
    /// The primvars some bound material reads, by name (default none): f32,
    /// `width` 1 to 4, one element per point.
    #[serde(default)]
    pub primvars: BTreeMap<String, Array<f32>>,
    /// The centres (and widths) at key times over the shutter, when the
    /// points move (time-sampled `points`, `velocities`); absent otherwise.
    #[serde(default)]
    pub motion: Option<PointsMotion>,
}

/// Moving points' spheres (or deforming curves' vertices) at key times
/// (docs/rendering.md, "Motion blur"): each centre (and diameter) moves linearly between neighbouring keys, the
/// end keys held outside them.
#[derive(Clone, Debug, Deserialize)]
pub struct PointsMotion {
    /// Key times, frames relative to `source.time_code`, strictly increasing.
    pub times: Vec<f32>,
    /// Every centre at every key, key-major (`k * points.count + i`).
    pub points: Array<[f32; 3]>,
    /// Diameters laid out like `points` when `widths` are time-sampled;
    /// absent: the [`Points`]' widths at every key.
    pub widths: Option<Array<f32>>,
}

/// A `UsdGeomBasisCurves` prim as linear round tubes (docs/conventions.md,
/// "Points and curves"): the exporter evaluates cubic curves into linear
/// pieces and closes periodic ones, so every curve here is a polyline of
/// linear swept spheres.
#[derive(Clone, Debug, Deserialize)]
pub struct Curves {
    /// Prim path (inside the prototype for instanced geometry).
    pub path: String,
    /// Polyline vertices, scene units, curve after curve.
    pub points: Array<[f32; 3]>,
    /// Tube diameter per vertex, scene units (USD `widths`, evaluated at the
    /// vertices), finite and not negative.
    pub widths: Array<f32>,
    /// Vertices per curve (2 or more), summing to the count of `points`.
    pub vertex_counts: Array<u32>,
    /// Bound material (or the `displayColor` one, or the hair default);
    /// [`NO_MATERIAL`] = none.
    pub material: u32,
    /// The primvars some bound material reads, by name (default none): f32,
    /// `width` 1 to 4, one element per vertex.
    #[serde(default)]
    pub primvars: BTreeMap<String, Array<f32>>,
    /// The vertices (and widths) at key times over the shutter, laid out as
    /// a points record's (a vertex per point), when the curves deform
    /// (time-sampled `points` or `widths`, `velocities`); absent otherwise.
    #[serde(default)]
    pub motion: Option<PointsMotion>,
}

/// `triangle_materials` entry for a triangle with no bound material (grey default).
pub const NO_MATERIAL: u32 = u32::MAX;

/// What an instance places: meshes and volumes, each with its own transform.
#[derive(Clone, Debug, Deserialize)]
pub struct Prototype {
    /// Prim path of the prototype (or of the plain prim it wraps).
    pub path: String,
    /// Meshes of this prototype.
    pub meshes: Vec<MeshPart>,
    /// Volumes of this prototype.
    pub volumes: Vec<VolumePart>,
    /// Points prims of this prototype (absent in files written before points).
    #[serde(default)]
    pub points: Vec<PointsPart>,
    /// Curves prims of this prototype (absent in files written before curves).
    #[serde(default)]
    pub curves: Vec<CurvesPart>,
}

/// One points prim placed in a prototype.
#[derive(Clone, Debug, Deserialize)]
pub struct PointsPart {
    /// Index into `Manifest::points`.
    pub points: u32,
    /// Prototype-from-points transform.
    pub transform: Transform,
    /// Its Cryptomatte names.
    #[serde(flatten)]
    pub names: PartNames,
}

/// One curves prim placed in a prototype.
#[derive(Clone, Debug, Deserialize)]
pub struct CurvesPart {
    /// Index into `Manifest::curves`.
    pub curves: u32,
    /// Prototype-from-curves transform.
    pub transform: Transform,
    /// Its Cryptomatte names.
    #[serde(flatten)]
    pub names: PartNames,
}

/// One mesh placed in a prototype.
#[derive(Clone, Debug, Deserialize)]
pub struct MeshPart {
    /// Index into `Manifest::meshes`.
    pub mesh: u32,
    /// Prototype-from-mesh transform (the prim's local-to-prototype xform).
    pub transform: Transform,
    /// Its Cryptomatte names.
    #[serde(flatten)]
    pub names: PartNames,
}

/// What a placed mesh, points or curves part of a prototype is called, for
/// Cryptomatte (docs/conventions.md, "Cryptomatte names").
#[derive(Clone, Debug, Default, Deserialize)]
pub struct PartNames {
    /// The part's prim path below the prototype's root (`/Geom`; empty
    /// when the root is the part itself): appended to an instance's
    /// [`NameRun::root`], the object's Cryptomatte name. Absent in files
    /// written before names (the part's `path` names it then).
    #[serde(default)]
    pub name: Option<String>,
    /// The nearest `component` or `assembly` model at or above the part
    /// inside the prototype, as a path below the prototype's root (empty =
    /// the root itself); `null` when none is inside the prototype.
    #[serde(default)]
    pub asset: Option<String>,
}

/// One volume placed in a prototype.
#[derive(Clone, Debug, Deserialize)]
pub struct VolumePart {
    /// Index into `Manifest::volumes`.
    pub volume: u32,
    /// Prototype-from-volume transform.
    pub transform: Transform,
}

/// Every placed copy of a prototype, structure of arrays, all `count` long:
/// 60 bytes per instance whatever the prototype's size.
#[derive(Clone, Debug, Deserialize)]
pub struct Instances {
    /// Number of instances.
    pub count: u64,
    /// Prototype index per instance.
    pub prototype: Array<u32>,
    /// World-from-prototype transform per instance (PointInstancer
    /// `positions`/`orientations`/`scales` composed with the instancer's xform).
    pub transform: Array<[f32; 12]>,
    /// Index into `instance_sources` per instance.
    pub source: Array<u32>,
    /// The instance's index within its source: PointInstancer `ids` if
    /// authored, else its position in the instancer's arrays.
    pub source_index: Array<u32>,
    /// Prim paths of instancers, instanceable prims and plain prims.
    pub instance_sources: Vec<String>,
    /// The instances that move over the shutter; absent when none do
    /// (and in files written before motion blur).
    #[serde(default)]
    pub motion: Option<InstanceMotion>,
    /// The instances' names as the artist authored them, in runs of
    /// consecutive instances (docs/conventions.md, "Cryptomatte names");
    /// absent in files written before names.
    #[serde(default)]
    pub names: Option<Vec<NameRun>>,
    /// Per-instance primvar values by name, in runs of consecutive
    /// instances (increasing, not overlapping); default none.
    #[serde(default)]
    pub primvars: BTreeMap<String, Vec<InstancePrimvarRun>>,
    /// Link sets of placed parts, in increasing runs; absent when no light links.
    #[serde(default)]
    pub links: Vec<LinkRun>,
}

/// World-from-prototype transforms of the moving instances at key times
/// (docs/rendering.md, "Motion blur"): interpolated linearly between keys,
/// the end keys held outside them. `transform` above keeps each instance's
/// transform at the frame itself.
#[derive(Clone, Debug, Deserialize)]
pub struct InstanceMotion {
    /// Key times, frames relative to `source.time_code`, strictly increasing.
    pub times: Vec<f32>,
    /// Indices of the moving instances, strictly increasing.
    pub instance: Array<u32>,
    /// Per moving instance, its transform at every key time, instance-major:
    /// key k of moving instance i is element `i * times.len() + k`.
    pub transform: Array<[f32; 12]>,
}

/// A camera's world-from-camera transform at key times (see
/// [`InstanceMotion`]).
#[derive(Clone, Debug, Deserialize)]
pub struct CameraMotion {
    /// Key times, frames relative to `source.time_code`, strictly increasing.
    pub times: Vec<f32>,
    /// World-from-camera at each key time.
    pub transforms: Vec<Transform>,
}

/// A `UsdGeomCamera`.
#[derive(Clone, Debug, Deserialize)]
pub struct Camera {
    /// Prim path; `null` = a default camera framing `bounds`.
    pub path: Option<String>,
    /// World-from-camera; the camera looks down -Z with +Y up.
    pub transform: Transform,
    /// `projection` (default perspective).
    pub projection: Projection,
    /// `focalLength` (default 50), tenths of a scene unit.
    pub focal_length: f32,
    /// `horizontalAperture` (default 20.955), tenths of a scene unit.
    pub horizontal_aperture: f32,
    /// `verticalAperture` (default 15.2908), tenths of a scene unit.
    pub vertical_aperture: f32,
    /// `horizontalApertureOffset` (default 0), tenths of a scene unit.
    pub horizontal_aperture_offset: f32,
    /// `verticalApertureOffset` (default 0), tenths of a scene unit.
    pub vertical_aperture_offset: f32,
    /// `clippingRange` (default 1, 1000000): near and far, scene units.
    pub clipping_range: [f32; 2],
    /// `fStop` (default 0 = pinhole).
    pub f_stop: f32,
    /// `focusDistance` (default 0), scene units.
    pub focus_distance: f32,
    /// UsdGeomCamera's linear exposure scale (default 1): the image's
    /// brightness is multiplied by it ("Camera Exposure Model",
    /// `ComputeLinearExposureScale`); absent when 1.
    #[serde(default = "unit_scale")]
    pub exposure_scale: f32,
    /// `shutter:open` and `shutter:close`, frames relative to the time code;
    /// absent when both are USD's default 0 (no motion blur).
    #[serde(default)]
    pub shutter: Option<[f32; 2]>,
    /// The transform over the shutter; absent when the camera does not move.
    #[serde(default)]
    pub motion: Option<CameraMotion>,
}

/// `UsdGeomCamera.projection`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Projection {
    /// Pinhole or thin lens.
    Perspective,
    /// Parallel rays; apertures give the view size.
    Orthographic,
}

/// A `UsdVolVolume` and its shading (see docs/conventions.md, "Volumes").
#[derive(Clone, Debug, Deserialize)]
pub struct Volume {
    /// Prim path.
    pub path: String,
    /// `field:<name>` relationships to `OpenVDBAsset` prims, by field name
    /// (`density` and optionally `temperature`, `emission` and `velocity`).
    pub fields: BTreeMap<String, VolumeField>,
    /// `primvars:densityScale` (default 1): sigma_t per world unit per
    /// density, per RGB channel (a float in USD and the file is grey; a
    /// color3f makes extinction chromatic).
    #[serde(deserialize_with = "grey_or_rgb")]
    pub density_scale: Rgb,
    /// `primvars:albedo` (default 1,1,1): sigma_s / sigma_t per channel.
    pub albedo: Rgb,
    /// `primvars:anisotropy` (default 0): Henyey-Greenstein g.
    pub anisotropy: f32,
    /// `primvars:heatScale` (default 0 = no emission).
    pub heat_scale: f32,
    /// `primvars:temperatureOffset` (default 0), kelvin.
    pub temperature_offset: f32,
    /// `primvars:temperatureScale` (default 1).
    pub temperature_scale: f32,
    /// `primvars:emissionScale` (default 1): with an `emission` field, the
    /// emitted radiance is emissionScale x emissionColor x the field's value,
    /// W/(m^2 sr). Absent from files written before emission fields.
    #[serde(default = "unit_scale")]
    pub emission_scale: f32,
    /// `primvars:emissionColor` (default 1, 1, 1), see `emission_scale`.
    #[serde(default = "white")]
    pub emission_color: Rgb,
    /// `motion:velocityScale` (UsdGeomMotionAPI, default 1): scales the
    /// `velocity` field's values. Written only for volumes with one.
    #[serde(default = "unit_scale")]
    pub velocity_scale: f32,
    /// The stage's `timeCodesPerSecond` (default 24, USD's): velocities are
    /// per second, shutter times in frames. Written only for volumes with a
    /// `velocity` field.
    #[serde(default = "usd_time_codes_per_second")]
    pub time_codes_per_second: f64,
}

/// USD's default `timeCodesPerSecond`.
fn usd_time_codes_per_second() -> f64 {
    24.0
}

impl Volume {
    /// Whether field `name` makes this volume emit: a `temperature` field
    /// with a positive heatScale, or an `emission` field with a positive
    /// emissionScale and a non-black emissionColor. Only these fields are
    /// read besides the density.
    pub fn emits_from(&self, name: &str) -> bool {
        match name {
            "temperature" => self.heat_scale > 0.0,
            "emission" => self.emission_scale > 0.0 && self.emission_color.iter().any(|&c| c > 0.0),
            _ => false,
        }
    }
}

fn white() -> Rgb {
    [1.0; 3]
}

/// An RGB triple written either as one number (grey) or as three.
fn grey_or_rgb<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Rgb, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum GreyOrRgb {
        Grey(f32),
        Rgb(Rgb),
    }
    let value = GreyOrRgb::deserialize(deserializer).map_err(|_| {
        serde::de::Error::custom("expected one number (grey) or three (RGB channels)")
    })?;
    Ok(match value {
        GreyOrRgb::Grey(v) => [v; 3],
        GreyOrRgb::Rgb(rgb) => rgb,
    })
}

/// An `OpenVDBAsset` field prim.
#[derive(Clone, Debug, Deserialize)]
pub struct VolumeField {
    /// `filePath`, absolute.
    pub file: PathBuf,
    /// `fieldName`: the grid's name in the file.
    pub grid: String,
    /// `fieldIndex` (default 0): which grid of that name.
    pub index: u32,
}

/// Render settings from `UsdRender.Settings`.
#[derive(Clone, Debug, Deserialize)]
pub struct Render {
    /// `resolution` in pixels (width, height): the first render product's,
    /// else the settings'; `null` when the stage has no settings.
    pub resolution: Option<[u32; 2]>,
    /// The chosen `UsdRender.Settings` prim (absent in older scenes: none).
    #[serde(default)]
    pub settings: Option<String>,
    /// Its raster `RenderProduct`s in `products` order (absent: none).
    #[serde(default)]
    pub products: Vec<RenderProduct>,
}

/// A raster `UsdRender.Product`: one image file. Each field is the
/// product's own value when authored, else its settings'.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct RenderProduct {
    /// The product prim.
    pub path: String,
    /// `productName`: the file to write, frame tokens unsubstituted
    /// (`$F4`, `<F4>`, `####`), relative to the working folder unless absolute.
    pub name: String,
    /// `resolution` in pixels (width, height).
    pub resolution: [u32; 2],
    /// `pixelAspectRatio`: a pixel's width over its height.
    pub pixel_aspect_ratio: f32,
    /// `dataWindowNDC` `[xmin, ymin, xmax, ymax]`: the rendered part of the
    /// image in NDC (0,0 bottom left, 1,1 top right).
    pub data_window_ndc: [f32; 4],
    /// `camera`'s first target (the product's, else the settings').
    pub camera: Option<String>,
    /// `orderedVars` in order.
    pub vars: Vec<RenderVar>,
}

/// A `UsdRender.Var`: one layer of a product's image, as authored.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct RenderVar {
    /// The var prim.
    pub path: String,
    /// Its prim name: the EXR layer's name.
    pub name: String,
    /// `sourceName`: what to write (an LPE, `P`, `N`, `depth`, ...).
    pub source_name: String,
    /// `sourceType`: `raw`, `primvar`, `lpe` or `intrinsic`.
    pub source_type: String,
    /// `dataType`: `color3f`, `float`, `half3`, ...
    pub data_type: String,
}
