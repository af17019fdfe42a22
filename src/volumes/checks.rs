//! What a Volume prim may hold that Cirrus refuses or reads as something
//! else: emission and velocity scales out of their domain (errors naming the
//! prim), NaN, infinite and negative grid values (read as 0, one warning
//! per grid naming volume, grid and file).

use super::grid::{SparseGrid, VolumeError};
use super::motion::VelocityField;
use crate::scene::{Volume, VolumeField};

/// Refuses a negative or non-finite `heatScale` or `emissionScale` (0 turns
/// emission off), naming the prim and the value.
pub(super) fn check_emission_scales(volume: &Volume) -> Result<(), VolumeError> {
    for (name, value) in [
        ("heatScale", volume.heat_scale),
        ("emissionScale", volume.emission_scale),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(VolumeError::Invalid {
                prim: volume.path.clone(),
                message: format!(
                    "primvars:{name} is {value}; it must be a finite number >= 0 (0 turns \
                     emission off)"
                ),
            });
        }
    }
    Ok(())
}

/// Warns once per grid when `grid` holds NaN, infinite or negative values,
/// naming the volume, grid and file: they are read as 0 (`what` names the
/// values: densities, temperatures...).
pub(super) fn warn_bad_values(volume: &Volume, field: &VolumeField, grid: &SparseGrid, what: &str) {
    let stats = grid.stats();
    if stats.non_finite_count > 0 || stats.min_value < 0.0 {
        log::warn!(
            "volume {}: grid {} of {} has {} NaN or infinite values and a smallest value of \
             {}: non-finite values (with their trilinear neighbourhood) and negative {what} \
             are read as 0",
            volume.path,
            field.grid,
            field.file.display(),
            stats.non_finite_count,
            stats.min_value
        );
    }
}

/// World units per frame of one unit of velocity (world units per second):
/// `motion:velocityScale` / `timeCodesPerSecond`; refuses non-finite scales
/// and a rate that is not positive, naming the prim.
pub(super) fn velocity_units_per_frame(volume: &Volume) -> Result<f32, VolumeError> {
    let (scale, rate) = (volume.velocity_scale, volume.time_codes_per_second);
    if !(scale.is_finite() && rate.is_finite() && rate > 0.0) {
        return Err(VolumeError::Invalid {
            prim: volume.path.clone(),
            message: format!(
                "motion:velocityScale {scale} and timeCodesPerSecond {rate}: the scale must be \
                 finite and the rate a positive number"
            ),
        });
    }
    Ok((f64::from(scale) / rate) as f32)
}

/// Warns once per velocity field holding NaN or infinite values, naming
/// the volume, grid and file: those lookups read a zero velocity.
pub(super) fn warn_bad_velocities(volume: &Volume, field: &VolumeField, velocity: &VelocityField) {
    let count = velocity.non_finite_count();
    if count > 0 {
        log::warn!(
            "volume {}: velocity grid {} of {} has {count} NaN or infinite values: read as a \
             zero velocity (with their trilinear neighbourhood)",
            volume.path,
            field.grid,
            field.file.display(),
        );
    }
}
