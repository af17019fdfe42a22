//! A light's `UsdLuxShapingAPI` inputs ([`LightShaping`]): the cone, focus
//! and IES profile that shape where it emits (docs/how-it-renders.md,
//! "Shaped lights").

use std::path::PathBuf;

use serde::Deserialize;

use super::super::material::Rgb;

/// `UsdLuxShapingAPI` on a sphere, rect, disk or cylinder light, written when
/// the API is applied or any `inputs:shaping:*` attribute is authored; each
/// field defaults to the schema's fallback, which leaves emission unshaped.
/// Out-of-range values are clamped by the renderer, with a warning.
#[derive(Clone, Debug, Deserialize)]
pub struct LightShaping {
    /// `inputs:shaping:cone:angle` (USD's fallback 90; absent here, 180: no
    /// cone), degrees off the light's axis (-Z) beyond which it emits
    /// nothing; valid range [0, 180].
    #[serde(default = "default_cone_angle")]
    pub cone_angle_deg: f32,
    /// `inputs:shaping:cone:softness` (default 0), the fraction of the cone
    /// over which emission fades (smoothstep); valid range [0, 1].
    #[serde(default)]
    pub cone_softness: f32,
    /// `inputs:shaping:focus` (default 0): emission scales by
    /// |cos(angle off the axis)|^focus; values below 0 are ignored.
    #[serde(default)]
    pub focus: f32,
    /// `inputs:shaping:focusTint` (default 0,0,0), linear RGB: the colour
    /// emission fades to where the focus factor is 0.
    #[serde(default)]
    pub focus_tint: Rgb,
    /// `inputs:shaping:ies:file`, absolute; `null` = no IES profile.
    #[serde(default)]
    pub ies_file: Option<PathBuf>,
    /// `inputs:shaping:ies:angleScale` (default 0 = none): the profile's
    /// vertical angles are scaled about 0 (> 0) or 180 degrees (< 0).
    #[serde(default)]
    pub ies_angle_scale: f32,
    /// `inputs:shaping:ies:normalize` (default false): the profile is
    /// divided by its mean intensity, so it shapes without changing power.
    #[serde(default)]
    pub ies_normalize: bool,
}

fn default_cone_angle() -> f32 {
    180.0
}
