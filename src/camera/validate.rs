//! The attribute ranges a camera needs before it can make rays.

use super::Raster;
use crate::scene;

/// The attribute ranges a camera needs, as a message naming the first one
/// out of range.
pub(super) fn validate(record: &scene::Camera, raster: Raster) -> Result<(), String> {
    let resolution = raster.resolution;
    let positive = |name: &str, v: f32| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(format!("{name} must be finite and positive, got {v}"))
        }
    };
    let non_negative = |name: &str, v: f32| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(format!("{name} must be finite and non-negative, got {v}"))
        }
    };
    if resolution.min_element() == 0 {
        return Err(format!("the resolution {resolution} has no pixels"));
    }
    positive("the render product's pixelAspectRatio", raster.pixel_aspect)?;
    if record.projection == scene::Projection::Perspective {
        positive("focalLength", record.focal_length)?;
    }
    positive("horizontalAperture", record.horizontal_aperture)?;
    positive("verticalAperture", record.vertical_aperture)?;
    for (name, v) in [
        (
            "horizontalApertureOffset",
            record.horizontal_aperture_offset,
        ),
        ("verticalApertureOffset", record.vertical_aperture_offset),
    ] {
        if !v.is_finite() {
            return Err(format!("{name} must be finite, got {v}"));
        }
    }
    let [near, far] = record.clipping_range;
    non_negative("clippingRange near", near)?;
    positive("clippingRange far", far)?;
    if near >= far {
        return Err(format!("clippingRange near {near} must be below far {far}"));
    }
    non_negative("fStop", record.f_stop)?;
    non_negative("focusDistance", record.focus_distance)?;
    positive(
        "the exposure scale (exposure, exposure:*)",
        record.exposure_scale,
    )
}
