//! The interior of a thick OpenPBR dielectric (OpenPBR 1.1, "Transmission"):
//! with `transmission_depth` d > 0 the dielectric is filled with a
//! homogeneous medium whose transmittance over the distance d is
//! `transmission_color` c, so its extinction is sigma_t = -ln(c) / d per
//! channel (per scene unit), and c no longer tints the interface; with d = 0
//! the interior is clear and c tints the refraction. Thin walls have no
//! interior. Only absorption is modelled (sigma_a = sigma_t):
//! `transmission_scatter` is warned by the exporter. The path tracer
//! attenuates a segment by Beer-Lambert exp(-sigma_a t) when it ends on the
//! back face of such a surface (docs/materials.md, "Interior absorption").

use glam::Vec3;

/// The smallest transmittance at the depth: `transmission_color` 0 would
/// give an infinite coefficient (and exp(-inf * 0) = NaN on a zero-length
/// segment).
const DARKEST: f32 = 1e-8;

/// Whether `transmission_depth` gives a thick dielectric an absorbing
/// interior (positive; NaN is not).
pub(crate) fn has_interior(depth: f32) -> bool {
    depth > 0.0
}

/// The interior's absorption coefficient sigma_a = -ln(c) / d (per scene
/// unit, RGB, finite and non-negative) for `transmission_color` c and
/// `transmission_depth` d; `None` where there is no interior (thin walls,
/// d not positive) or it absorbs nothing (c white, or d infinite). The
/// caller leaves thin walls out.
pub(crate) fn interior_absorption(color: Vec3, depth: f32) -> Option<Vec3> {
    if !has_interior(depth) {
        return None;
    }
    let c = Vec3::new(
        unit_or_clear(color.x),
        unit_or_clear(color.y),
        unit_or_clear(color.z),
    );
    let sigma = -c.max(Vec3::splat(DARKEST)).ln() / depth;
    (sigma.max_element() > 0.0).then_some(sigma.max(Vec3::ZERO))
}

/// A transmittance clamped to [0, 1]; NaN is clear (1).
fn unit_or_clear(x: f32) -> f32 {
    if x.is_nan() {
        1.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_colour_is_the_transmittance_at_the_depth() {
        let c = Vec3::new(0.25, 0.5, 0.9);
        let sigma = interior_absorption(c, 2.0).unwrap();
        let at_depth = (-sigma * 2.0).exp();
        assert!((at_depth - c).abs().max_element() < 1e-6, "{at_depth}");
        assert!((sigma.x - 4.0f32.ln() / 2.0).abs() < 1e-6);
    }

    #[test]
    fn no_interior_where_nothing_absorbs() {
        let c = Vec3::splat(0.5);
        assert!(interior_absorption(c, 0.0).is_none());
        assert!(interior_absorption(c, f32::NAN).is_none());
        assert!(interior_absorption(Vec3::ONE, 1.0).is_none());
        assert!(interior_absorption(c, f32::INFINITY).is_none());
        let black = interior_absorption(Vec3::ZERO, 1.0).unwrap();
        assert!(black.is_finite() && (-black * 0.0).exp() == Vec3::ONE);
    }
}
