//! Colour: linear Rec.709 RGB as every radiance in Cirrus is, its
//! luminance, and the colour of blackbody radiation. Lights, volumes and
//! materials all read it, so it sits below them (pbrt-v4 keeps the same in
//! `spectrum.h`/`color.h`).

mod blackbody;

pub use blackbody::{blackbody_radiance, blackbody_rgb};

use glam::Vec3;

/// Rec.709 luminance weights (ITU-R BT.709): Y of linear RGB.
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}
