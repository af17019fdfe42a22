//! The material and texture records of `scene.json` (`exporter/FORMAT.md`,
//! "Material" and "Texture"): UsdPreviewSurface and OpenPBR Surface
//! records, and the input grammar both share (constant, texture, primvar,
//! op), parsed with messages naming the sub-field at fault.

use std::path::PathBuf;

use serde::Deserialize;

/// Linear Rec.709 RGB.
pub type Rgb = [f32; 3];

/// The default of scales that multiply: 1.
pub(super) fn unit_scale() -> f32 {
    1.0
}

/// A material: a UsdPreviewSurface or an OpenPBR Surface record. Every field
/// but `path` is optional; an absent one takes UsdPreviewSurface's default
/// ([`Material::default`], also the look of a surface without a material).
#[derive(Clone, Debug, Deserialize)]
#[serde(default)]
pub struct Material {
    /// Prim path of the Material.
    pub path: String,
    /// When `path` is inside a native prototype (`/__Prototype_N/...`,
    /// numbered anew at each load): the Material as seen through the first
    /// instance that binds it (`/World/teapot_1/Looks/Red`), its CryptoMaterial
    /// name; absent otherwise and in files written before names.
    pub name: Option<String>,
    /// Which surface model renders it (default `preview_surface`).
    pub model: Model,
    /// The shader that was read, e.g. `UsdPreviewSurface`,
    /// `ND_open_pbr_surface_surfaceshader`, `ND_standard_surface_surfaceshader`,
    /// `displayColor` (default empty).
    pub shader: String,
    /// Richer looks the exporter skipped for this simpler one, one sentence
    /// each naming what was skipped (default none); `cirrus info` names them.
    pub skipped: Vec<String>,
    /// True when the material could not be read (MaterialX-only, glslfx, ...)
    /// and holds UsdPreviewSurface's defaults (grey 0.18 plastic); the
    /// exporter warned once naming it.
    pub fallback: bool,
    /// `inputs:diffuseColor` (default 0.18 grey), linear RGB.
    pub diffuse_color: Input<Rgb>,
    /// `inputs:emissiveColor` (default black), radiance in W/(m^2 sr), linear RGB.
    pub emissive_color: Input<Rgb>,
    /// `inputs:metallic` (default 0), in [0, 1].
    pub metallic: Input<f32>,
    /// `inputs:roughness` (default 0.5), perceptual, in [0, 1].
    pub roughness: Input<f32>,
    /// `inputs:specularColor` (default black), used with the specular workflow.
    pub specular_color: Input<Rgb>,
    /// `inputs:useSpecularWorkflow` (default 0).
    pub use_specular_workflow: bool,
    /// `inputs:ior` (default 1.5).
    pub ior: f32,
    /// `inputs:opacity` (default 1), in [0, 1].
    pub opacity: Input<f32>,
    /// `inputs:opacityThreshold` (default 0), in [0, 1]. Above 0 opacity
    /// is a mask (UsdPreviewSurface specification): below the threshold the
    /// surface is cut out (absent to every ray), at or above it opaque.
    pub opacity_threshold: f32,
    /// `inputs:clearcoat` (default 0), weight in [0, 1].
    pub clearcoat: f32,
    /// `inputs:clearcoatRoughness` (default 0.01).
    pub clearcoat_roughness: f32,
    /// `inputs:normal` texture (tangent space); `null` = none.
    pub normal: Option<TextureInput>,
    /// With `model: open_pbr`: the OpenPBR inputs by their specification
    /// names; an absent one takes the specification's default.
    pub open_pbr: OpenPbr,
    /// OpenPBR `geometry_thin_walled` (default false).
    pub geometry_thin_walled: bool,
    /// OpenPBR `geometry_normal` as a MaterialX `normalmap`; `null` = the
    /// interpolated shading normal.
    pub geometry_normal: Option<NormalMap>,
    /// OpenPBR `geometry_coat_normal`, likewise; `null` = the interpolated
    /// shading normal.
    pub geometry_coat_normal: Option<NormalMap>,
    /// Set when the material was made for a gprim with `UsdLuxMeshLightAPI`
    /// (a mesh light): its emission is scaled by the light's inputs; absent
    /// otherwise (and in files written before mesh lights).
    pub light: Option<GeometryLight>,
}

/// The LightAPI inputs of a mesh light (`UsdLuxMeshLightAPI`) that scale its
/// material's emission (exporter/FORMAT.md, "Material"): the exporter wrote
/// the material's emission as the glow the light's `materialSyncMode` asks
/// for, and the emitted radiance is that times `scale` times the blackbody
/// colour of `color_temperature`.
#[derive(Clone, Debug, Deserialize)]
pub struct GeometryLight {
    /// Prim path of the gprim that is a light.
    pub path: String,
    /// `inputs:color` x `inputs:intensity` x 2^`inputs:exposure`, divided by
    /// the gprim's world-space surface area (square scene units) when
    /// `inputs:normalize` is on; linear RGB.
    pub scale: Rgb,
    /// `inputs:colorTemperature` in kelvin when `enableColorTemperature` is
    /// true; `null` otherwise.
    pub color_temperature: Option<f32>,
    /// `inputs:diffuse` and `inputs:specular` (default 1 each).
    #[serde(flatten)]
    pub lobes: LightLobes,
}

impl Default for Material {
    /// UsdPreviewSurface's defaults: grey 0.18 diffuse, roughness 0.5,
    /// dielectric with ior 1.5, opaque, no emission.
    fn default() -> Self {
        Self {
            path: String::new(),
            name: None,
            model: Model::PreviewSurface,
            shader: String::new(),
            skipped: Vec::new(),
            fallback: false,
            diffuse_color: Input::Constant([0.18; 3]),
            emissive_color: Input::Constant([0.0; 3]),
            metallic: Input::Constant(0.0),
            roughness: Input::Constant(0.5),
            specular_color: Input::Constant([0.0; 3]),
            use_specular_workflow: false,
            ior: 1.5,
            opacity: Input::Constant(1.0),
            opacity_threshold: 0.0,
            clearcoat: 0.0,
            clearcoat_roughness: 0.01,
            normal: None,
            open_pbr: OpenPbr::default(),
            geometry_thin_walled: false,
            geometry_normal: None,
            geometry_coat_normal: None,
            light: None,
        }
    }
}

/// A light's `inputs:diffuse` and `inputs:specular`: factors on what it
/// contributes through the diffuse and the specular lobes of surfaces (see
/// docs/conventions.md, "Lights"); both default to 1 (absent in files written
/// before them), which changes nothing.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub struct LightLobes {
    /// `inputs:diffuse` (default 1).
    #[serde(default = "unit_scale")]
    pub diffuse: f32,
    /// `inputs:specular` (default 1).
    #[serde(default = "unit_scale")]
    pub specular: f32,
}

impl Default for LightLobes {
    fn default() -> Self {
        Self {
            diffuse: 1.0,
            specular: 1.0,
        }
    }
}

impl LightLobes {
    /// Whether either factor differs from 1.
    pub fn scales(&self) -> bool {
        *self != Self::default()
    }
}

/// The surface model of a [`Material`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// `UsdPreviewSurface`: the `diffuse_color` ... `normal` fields.
    #[default]
    PreviewSurface,
    /// OpenPBR Surface 1.1: the `open_pbr` and `geometry_*` fields.
    OpenPbr,
}

impl Model {
    /// The manifest's name for it.
    pub fn name(self) -> &'static str {
        match self {
            Self::PreviewSurface => "preview_surface",
            Self::OpenPbr => "open_pbr",
        }
    }
}

/// The OpenPBR record: one optional field per OpenPBR 1.1 input (defaults
/// from the specification), scalars then colours (linear Rec.709).
macro_rules! open_pbr_record {
    (
        scalars { $($(#[$sdoc:meta])* $scalar:ident,)* }
        colors { $($(#[$cdoc:meta])* $color:ident,)* }
    ) => {
        /// OpenPBR Surface 1.1 inputs (<https://academysoftwarefoundation.github.io/OpenPBR/>)
        /// by their specification names; `null`/absent = the specification's
        /// default; any other key is refused.
        #[derive(Clone, Debug, Default, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct OpenPbr {
            $($(#[$sdoc])* pub $scalar: Option<Input<f32>>,)*
            $($(#[$cdoc])* pub $color: Option<Input<Rgb>>,)*
        }

        impl OpenPbr {
            /// The authored scalar inputs, by name.
            pub fn scalars(&self) -> impl Iterator<Item = (&'static str, &Input<f32>)> {
                [$((stringify!($scalar), self.$scalar.as_ref()),)*]
                    .into_iter()
                    .filter_map(|(name, input)| Some((name, input?)))
            }

            /// The authored colour inputs, by name.
            pub fn colors(&self) -> impl Iterator<Item = (&'static str, &Input<Rgb>)> {
                [$((stringify!($color), self.$color.as_ref()),)*]
                    .into_iter()
                    .filter_map(|(name, input)| Some((name, input?)))
            }
        }
    };
}

open_pbr_record! {
    scalars {
        /// Default 1.
        base_weight,
        /// Oren-Nayar roughness, default 0.
        base_diffuse_roughness,
        /// Default 0.
        base_metalness,
        /// Default 1.
        specular_weight,
        /// Default 0.3.
        specular_roughness,
        /// Default 0.
        specular_roughness_anisotropy,
        /// Default 1.5.
        specular_ior,
        /// Default 0.
        transmission_weight,
        /// Scene units, default 0 (no interior absorption).
        transmission_depth,
        /// Default 0.
        subsurface_weight,
        /// Default 0.
        fuzz_weight,
        /// Default 0.5.
        fuzz_roughness,
        /// Default 0.
        coat_weight,
        /// Default 0.
        coat_roughness,
        /// Default 0.
        coat_roughness_anisotropy,
        /// Default 1.6.
        coat_ior,
        /// Default 1.
        coat_darkening,
        /// Default 0.
        thin_film_weight,
        /// Micrometres, default 0.5.
        thin_film_thickness,
        /// Default 1.4.
        thin_film_ior,
        /// Nits (1 nit = 1 W/(m^2 sr) of scene radiance), default 0.
        emission_luminance,
        /// Presence in [0, 1], default 1.
        geometry_opacity,
    }
    colors {
        /// Default 0.8 grey.
        base_color,
        /// Default white.
        specular_color,
        /// Default white.
        transmission_color,
        /// Default 0.8 grey.
        subsurface_color,
        /// Default white.
        fuzz_color,
        /// Default white.
        coat_color,
        /// Default white; emitted radiance is `emission_luminance * emission_color`.
        emission_color,
    }
}

/// A MaterialX `normalmap` fed by a texture: the tangent-space normal is
/// normalize((2 rgb - 1) * (scale, scale, 1)), x along dp/du, z along the
/// shading normal.
#[derive(Clone, Debug, Deserialize)]
pub struct NormalMap {
    /// Index into `Manifest::textures`.
    pub texture: u32,
    /// Output read (default `rgb`).
    #[serde(default = "rgb")]
    pub channel: Channel,
    /// `normalmap`'s `scale` (default 1): bumpiness.
    #[serde(default = "unit_scale")]
    pub scale: f32,
}

fn rgb() -> Channel {
    Channel::Rgb
}

/// A material input: a constant, a texture lookup, a mesh primvar, or an
/// operation on inputs, evaluated at each hit. Written as a number (or
/// `[r, g, b]` for a colour: a number is grey there),
/// `{"texture": i, "channel": c}`, `{"primvar": name, "channel": c,
/// "fallback": v}` or `{"op": name, "args": [Input, ...]}`.
#[derive(Clone, Debug, PartialEq)]
pub enum Input<T> {
    /// The authored (or default) value.
    Constant(T),
    /// A `UsdUVTexture` (or MaterialX `image`) connected to the input.
    Texture(TextureInput),
    /// A primvar of the mesh (`UsdPrimvarReader_*`, MaterialX `geompropvalue`).
    Primvar(PrimvarInput<T>),
    /// Per-hit maths on other inputs.
    Op(OpInput<T>),
}

/// A connection from a material input to a mesh primvar (see [`Mesh::primvars`](super::Mesh::primvars)).
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct PrimvarInput<T> {
    /// The primvar's name (without `primvars:`).
    pub primvar: String,
    /// Component(s) read: `r`..`a` = 0..3 (a scalar input reads `r` for
    /// `rgb`); a one-component primvar read as `rgb` is grey.
    #[serde(default = "rgb")]
    pub channel: Channel,
    /// The value on meshes without the primvar (the exporter warned).
    pub fallback: T,
}

/// An operation on inputs, componentwise, scalars broadcast to colours.
#[derive(Clone, Debug, PartialEq)]
pub struct OpInput<T> {
    /// Which operation.
    pub op: Op,
    /// Its arguments, [`Op::arity`] of them, in MaterialX order.
    pub args: Vec<Input<T>>,
}

/// The operations an [`OpInput`] applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Op {
    /// `multiply(a, b) = a b`.
    Multiply,
    /// `add(a, b) = a + b`.
    Add,
    /// `subtract(a, b) = a - b`.
    Subtract,
    /// `mix(fg, bg, m) = fg m + bg (1 - m)` (MaterialX argument order).
    Mix,
}

impl Op {
    /// Number of arguments it takes.
    pub fn arity(self) -> usize {
        match self {
            Self::Mix => 3,
            _ => 2,
        }
    }
}

/// The constant values an [`Input`] may hold: a scalar or an RGB colour.
pub trait InputValue: Sized {
    /// What a constant of this type is written as, for error messages.
    const EXPECTED: &'static str;
    /// The value of a JSON constant, `None` when it is not one.
    fn from_json(value: &serde_json::Value) -> Option<Self>;
}

impl InputValue for f32 {
    const EXPECTED: &'static str = "a number";
    fn from_json(value: &serde_json::Value) -> Option<Self> {
        value.as_f64().map(|v| v as f32)
    }
}

impl InputValue for Rgb {
    const EXPECTED: &'static str = "a number (grey) or [r, g, b]";
    fn from_json(value: &serde_json::Value) -> Option<Self> {
        match value {
            serde_json::Value::Array(items) if items.len() == 3 => {
                let rgb: Vec<f32> = items.iter().filter_map(f32::from_json).collect();
                rgb.try_into().ok()
            }
            _ => f32::from_json(value).map(|v| [v; 3]),
        }
    }
}

impl<T: InputValue> Input<T> {
    /// Parses one input from JSON, the message naming the sub-field at fault
    /// (`args[1].channel: ...`).
    fn from_json(value: &serde_json::Value) -> Result<Self, String> {
        use serde_json::Value;
        let Value::Object(fields) = value else {
            return T::from_json(value)
                .map(Self::Constant)
                .ok_or_else(|| format!("expected {}, found {value}", T::EXPECTED));
        };
        if fields.contains_key("texture") {
            return typed(value).map(Self::Texture);
        }
        if let Some(name) = fields.get("primvar") {
            let Some(name) = name.as_str() else {
                return Err(format!("primvar: expected a name, found {name}"));
            };
            let channel = fields.get("channel").map_or(Ok(Channel::Rgb), |c| {
                typed(c).map_err(|e| format!("channel: {e}"))
            })?;
            let fallback = fields.get("fallback").ok_or("missing field `fallback`")?;
            let fallback = T::from_json(fallback)
                .ok_or_else(|| format!("fallback: expected {}, found {fallback}", T::EXPECTED))?;
            return Ok(Self::Primvar(PrimvarInput {
                primvar: name.to_owned(),
                channel,
                fallback,
            }));
        }
        if let Some(op) = fields.get("op") {
            let op: Op = typed(op).map_err(|e| format!("op: {e}"))?;
            let Some(Value::Array(args)) = fields.get("args") else {
                return Err("args: expected a list of inputs".to_owned());
            };
            if args.len() != op.arity() {
                return Err(format!(
                    "args: {op:?} takes {} arguments, found {}",
                    op.arity(),
                    args.len()
                )
                .to_lowercase());
            }
            let args = args
                .iter()
                .enumerate()
                .map(|(i, arg)| Self::from_json(arg).map_err(|e| format!("args[{i}]: {e}")))
                .collect::<Result<_, _>>()?;
            return Ok(Self::Op(OpInput { op, args }));
        }
        Err(format!(
            "expected {}, {{\"texture\": ..}}, {{\"primvar\": ..}} or {{\"op\": ..}}, found {value}",
            T::EXPECTED
        ))
    }
}

/// A derived-`Deserialize` part of an [`Input`], the message naming the
/// field at fault within it.
fn typed<T: serde::de::DeserializeOwned>(value: &serde_json::Value) -> Result<T, String> {
    serde_path_to_error::deserialize(value.clone()).map_err(|e| match e.path().to_string() {
        root if root == "." => e.inner().to_string(),
        path => format!("{path}: {}", e.inner()),
    })
}

impl<'de, T: InputValue> Deserialize<'de> for Input<T> {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let value = serde_json::Value::deserialize(deserializer)?;
        Self::from_json(&value).map_err(serde::de::Error::custom)
    }
}

/// A connection from a material input to a texture's output channel(s).
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct TextureInput {
    /// Index into `Manifest::textures`.
    pub texture: u32,
    /// `UsdUVTexture` output used: `outputs:rgb`, `:r`, `:g`, `:b` or `:a`.
    pub channel: Channel,
}

/// A `UsdUVTexture` output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// `outputs:rgb`.
    Rgb,
    /// `outputs:r`.
    R,
    /// `outputs:g`.
    G,
    /// `outputs:b`.
    B,
    /// `outputs:a`.
    A,
}

/// A `UsdUVTexture` shader.
#[derive(Clone, Debug, Deserialize)]
pub struct Texture {
    /// `inputs:file`, resolved to an absolute path (kept even when missing).
    pub file: PathBuf,
    /// `inputs:wrapS` (default `useMetadata`, resolved by the exporter).
    pub wrap_s: Wrap,
    /// `inputs:wrapT`.
    pub wrap_t: Wrap,
    /// `inputs:scale` (default 1,1,1,1), multiplies the texel.
    pub scale: [f32; 4],
    /// `inputs:bias` (default 0,0,0,0), added after `scale`.
    pub bias: [f32; 4],
    /// `inputs:fallback` (default 0,0,0,1), used when the file is missing.
    pub fallback: [f32; 4],
    /// `inputs:sourceColorSpace` (default auto).
    pub color_space: ColorSpace,
    /// A `UsdTransform2d` feeding `inputs:st`; `null` = identity.
    pub st_transform: Option<StTransform>,
}

/// `UsdUVTexture` wrap modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Wrap {
    /// Tile.
    Repeat,
    /// Clamp to the edge texel.
    Clamp,
    /// Tile, every other copy mirrored.
    Mirror,
    /// Outside [0, 1] reads black.
    Black,
    /// Outside [0, 1] reads the texture's `fallback` (MaterialX address
    /// mode `constant`).
    Constant,
}

/// `inputs:sourceColorSpace`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum ColorSpace {
    /// sRGB for 8-bit images, linear otherwise.
    #[serde(rename = "auto")]
    Auto,
    /// sRGB-encoded.
    #[serde(rename = "sRGB")]
    Srgb,
    /// Linear data (normals, roughness).
    #[serde(rename = "raw")]
    Raw,
}

/// A `UsdTransform2d` applied to texture coordinates: scale, then rotate, then translate.
#[derive(Clone, Copy, Debug, Deserialize)]
pub struct StTransform {
    /// `inputs:translation` (default 0,0).
    pub translation: [f32; 2],
    /// `inputs:rotation` (default 0), degrees counter-clockwise.
    pub rotation_deg: f32,
    /// `inputs:scale` (default 1,1).
    pub scale: [f32; 2],
}
