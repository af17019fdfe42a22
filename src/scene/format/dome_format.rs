//! The mapping of a dome light's image, as the manifest names it.

use serde::Deserialize;

/// The parameterisation of a dome light's image (UsdLux DomeLight
/// `inputs:texture:format`; `src/lights/dome.rs` gives each mapping).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DomeFormat {
    /// `latlong`: the OpenEXR latitude-longitude map, 2:1.
    #[default]
    Latlong,
    /// `angular`: a square light-probe disk, radius linear in the angle
    /// from the centre direction.
    Angular,
    /// `mirroredBall`: a square image of a mirrored sphere seen from far
    /// away (orthographic), radius the sine of half that angle.
    MirroredBall,
}
