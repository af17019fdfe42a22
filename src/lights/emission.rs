//! What a UsdLux light emits before its shape is taken into account:
//! `color x intensity x 2^exposure x blackbody(colorTemperature)`
//! (docs/conventions.md, "Lights").

use glam::Vec3;

use super::LightError;
use crate::color::blackbody_rgb;
use crate::scene::Light as LightRecord;

/// The radiance of an area light of world-space `area` (square scene units):
/// its [`emission`], divided by the area when `normalize` is on
/// (docs/conventions.md, "Lights"). `shape` names the type in the error that a
/// zero area under `normalize` is.
pub(crate) fn area_radiance(
    record: &LightRecord,
    area: f32,
    shape: &str,
) -> Result<Vec3, LightError> {
    let e = emission(record)?;
    if !record.normalize {
        return Ok(e);
    }
    if area.is_nan() || area <= 0.0 {
        return Err(LightError::invalid(
            record,
            format!("normalize on a {shape} of zero area"),
        ));
    }
    Ok(e / area)
}

/// The light's emission, linear Rec.709 RGB: `color x intensity x 2^exposure`,
/// times the blackbody colour of `colorTemperature` (luminance 1) when enabled.
/// Its meaning (radiance, irradiance) depends on the type and `normalize`.
/// Non-finite or negative values are refused: sampling by power needs a
/// non-negative emission.
pub(crate) fn emission(record: &LightRecord) -> Result<Vec3, LightError> {
    let tint = match record.color_temperature {
        Some(t) if !(t.is_finite() && t > 0.0) => {
            return Err(LightError::invalid(
                record,
                format!("colorTemperature {t} K is not a positive number"),
            ))
        }
        Some(t) => blackbody_rgb(t),
        None => Vec3::ONE,
    };
    let e = Vec3::from(record.color) * record.intensity * record.exposure.exp2() * tint;
    if !e.is_finite() || e.min_element() < 0.0 {
        return Err(LightError::invalid(
            record,
            format!(
                "emission {e} (color {:?} x intensity {} x 2^exposure {}) is not finite and non-negative",
                record.color, record.intensity, record.exposure
            ),
        ));
    }
    Ok(e)
}
