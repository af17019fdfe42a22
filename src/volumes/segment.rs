//! [`MajorantSegment`]: a stretch of a ray with bounds on its extinction,
//! what the majorant grid's DDA (`majorant/`) yields and every estimator
//! (`estimators/`) walks; overlapping media's segments are merged and
//! summed (overlap.rs).

/// One stretch of a ray over which extinction is bounded:
/// `sigma_min <= sigma_t(t) <= sigma_maj` for t in `[t_min, t_max)`.
/// Extinctions are per unit of `t` along the caller's direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MajorantSegment {
    /// Start of the stretch, in the caller's ray parameter.
    pub t_min: f32,
    /// End of the stretch (exclusive); the next segment starts exactly here
    /// unless empty cells or a cell's empty part were skipped.
    pub t_max: f32,
    /// Majorant of `sigma_t` (density max x scale) over the stretch, grey:
    /// it bounds every RGB channel of a chromatic extinction.
    pub sigma_maj: f32,
    /// Minorant of `sigma_t` (density min x scale, >= 0) in every channel,
    /// the control extinction of residual ratio tracking (Novák et al. 2014).
    pub sigma_min: f32,
}
