//! What both BSDF models (UsdPreviewSurface, OpenPBR) share when they
//! scatter: the sample type, which side of the surface a direction leaves
//! on, lobe selection, and mirror and Snell directions.

use glam::Vec3;

/// A direction drawn from a [`Bsdf`].
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Unit world direction towards the light (away from the surface).
    pub wi: Vec3,
    /// f(wo, wi) |cos theta_i| / pdf.
    pub weight: Vec3,
    /// Solid-angle density of `wi` (for a Dirac lobe: the discrete
    /// probability of having chosen it).
    pub pdf: f32,
    /// Drawn from a Dirac lobe (a thin sheet's straight-through
    /// transmission): no MIS.
    pub delta: bool,
}

/// What a model's lobe drew: a direction in the shading frame (its pdf and
/// weight then come from the whole BSDF), or a finished Dirac sample.
pub(super) enum Drawn {
    /// A direction in the shading frame.
    Direction(Vec3),
    /// A Dirac lobe's sample, in world space.
    Dirac(BsdfSample),
}

/// Which side of the surface `wi` leaves on, relative to `wo`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Side {
    /// On `wo`'s side of both the geometric and the shading normal.
    Reflect,
    /// Across both.
    Transmit,
}

/// `weights` scaled to sum to 1 (negative ones to 0); all 0 when they sum
/// to 0: the lobe selection probabilities of both models.
pub(super) fn normalized<const N: usize>(mut weights: [f32; N]) -> [f32; N] {
    let total: f32 = weights.iter().sum();
    for p in &mut weights {
        *p = if total > 0.0 {
            (*p / total).max(0.0)
        } else {
            0.0
        };
    }
    weights
}

/// The lobe (index into `lobe_pdf`) that `u` falls in, and `u` rescaled to
/// [0, 1) within it.
pub(super) fn pick_lobe<const N: usize>(lobe_pdf: &[f32; N], u: f32) -> Option<(usize, f32)> {
    let mut start = 0.0;
    for (lobe, &p) in lobe_pdf.iter().enumerate() {
        if p > 0.0 && u < start + p {
            return Some((lobe, ((u - start) / p).clamp(0.0, 1.0 - f32::EPSILON)));
        }
        start += p;
    }
    // Rounding left u past the last lobe: take the last one with weight.
    let last = lobe_pdf.iter().rposition(|p| *p > 0.0)?;
    Some((last, 1.0 - f32::EPSILON))
}

/// Mirror `wo` about `h`.
pub(super) fn reflect(wo: Vec3, h: Vec3) -> Vec3 {
    2.0 * wo.dot(h) * h - wo
}

/// Refract `wo` through the microfacet `h` into a medium of relative index
/// `eta` (Snell); `None` on total internal reflection.
pub(super) fn refract(wo: Vec3, h: Vec3, eta: f32) -> Option<Vec3> {
    let cos_o = wo.dot(h);
    let sin2_t = (1.0 - cos_o * cos_o).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo / eta + (cos_o / eta - cos_t) * h).normalize())
}
