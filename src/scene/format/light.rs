//! A UsdLux light record ([`Light`]): the LightAPI inputs every type shares,
//! its type and own attributes ([`LightShape`]), motion, shaping and links.

use std::path::PathBuf;

use serde::Deserialize;

use super::super::material::{LightLobes, Rgb};
use super::{CameraMotion, DomeFormat, LightLinks, LightShaping, Transform};

/// A UsdLux light: what every type shares, plus its [`LightShape`].
#[derive(Clone, Debug, Deserialize)]
pub struct Light {
    /// Prim path.
    pub path: String,
    /// World-from-light transform; the light faces its -Z.
    pub transform: Transform,
    /// `inputs:color` (default 1,1,1), linear RGB.
    pub color: Rgb,
    /// `inputs:intensity` (default 1).
    pub intensity: f32,
    /// `inputs:exposure` (default 0), stops: emission scales by 2^exposure.
    pub exposure: f32,
    /// `inputs:normalize` (default false): divide by area (or, for distant
    /// lights, give irradiance); see docs/conventions.md, "Lights".
    pub normalize: bool,
    /// `inputs:colorTemperature` in kelvin when `enableColorTemperature` is
    /// true; `null` otherwise.
    pub color_temperature: Option<f32>,
    /// `inputs:diffuse` and `inputs:specular` (default 1 each).
    #[serde(flatten)]
    pub lobes: LightLobes,
    /// The type and its own attributes.
    #[serde(flatten)]
    pub shape: LightShape,
    /// World-from-light at key times over the shutter (the camera's record),
    /// for a sphere, rect, disk or cylinder light whose transform changes;
    /// absent when it does not move (and in files written before moving
    /// lights).
    #[serde(default)]
    pub motion: Option<CameraMotion>,
    /// `UsdLuxShapingAPI`'s inputs; absent when not applied (unshaped).
    #[serde(default)]
    pub shaping: Option<LightShaping>,
    /// Its light and shadow linking (absent: none).
    #[serde(flatten)]
    pub links: LightLinks,
}

/// The UsdLux light types, with their type-specific attributes.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum LightShape {
    /// `DistantLight`.
    Distant {
        /// `inputs:angle` (default 0.53), angular diameter in degrees.
        angle_deg: f32,
    },
    /// `SphereLight`.
    Sphere {
        /// `inputs:radius` (default 0.5), scene units.
        radius: f32,
        /// `treatAsPoint` (default false).
        treat_as_point: bool,
    },
    /// `RectLight`, in the light's XY plane.
    Rect {
        /// `inputs:width` (default 1), scene units along X.
        width: f32,
        /// `inputs:height` (default 1), scene units along Y.
        height: f32,
        /// `inputs:texture:file`, absolute; `null` = none.
        texture: Option<PathBuf>,
    },
    /// `DiskLight`, in the light's XY plane.
    Disk {
        /// `inputs:radius` (default 0.5), scene units.
        radius: f32,
    },
    /// `CylinderLight`, along the light's X axis.
    Cylinder {
        /// `inputs:radius` (default 0.5), scene units.
        radius: f32,
        /// `inputs:length` (default 1), scene units.
        length: f32,
    },
    /// `DomeLight`.
    Dome {
        /// `inputs:texture:file`, absolute; `null` = constant.
        texture: Option<PathBuf>,
        /// `inputs:texture:format` (default lat-long).
        #[serde(default)]
        texture_format: DomeFormat,
    },
}

impl LightShape {
    /// The manifest's name for this type (`"distant"`, `"sphere"`, ...).
    pub fn type_name(&self) -> &'static str {
        match self {
            Self::Distant { .. } => "distant",
            Self::Sphere { .. } => "sphere",
            Self::Rect { .. } => "rect",
            Self::Disk { .. } => "disk",
            Self::Cylinder { .. } => "cylinder",
            Self::Dome { .. } => "dome",
        }
    }
}
