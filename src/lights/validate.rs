//! What every light's `from_record` shares: [`LightError`], naming the
//! light's prim, and the checks of its transform.

use glam::{Mat3, Vec3};
use thiserror::Error;

use super::LOG_TARGET;
use crate::scene::Light as LightRecord;

/// A light that cannot be used.
#[derive(Debug, Error)]
pub enum LightError {
    /// A value out of its domain (non-finite, negative, a degenerate shape
    /// asked to normalize), with the light's prim path.
    #[error("light {path}: {message}")]
    Invalid {
        /// Light prim path.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The manifest's link runs are inconsistent (exporter/FORMAT.md, "Linking").
    #[error("light linking: {0}")]
    Linking(String),
}

impl LightError {
    /// An [`LightError::Invalid`] naming `record`'s prim.
    pub(crate) fn invalid(record: &LightRecord, message: impl Into<String>) -> Self {
        Self::Invalid {
            path: record.path.clone(),
            message: message.into(),
        }
    }
}

/// The record's world-from-light transform as (linear part, light origin in
/// world space); non-finite entries are refused.
pub(crate) fn world_from_light(record: &LightRecord) -> Result<(Mat3, Vec3), LightError> {
    if !record.transform.iter().all(|v| v.is_finite()) {
        return Err(LightError::invalid(record, "transform is not finite"));
    }
    let a = crate::scene::affine(&record.transform);
    Ok((Mat3::from(a.matrix3), Vec3::from(a.translation)))
}

/// Mean length of the transform's three axes: the scale applied to a
/// sphere's radius. Non-uniform scale (axes differing by more than 0.1%)
/// cannot keep a sphere round and is warned about.
pub(crate) fn mean_scale(record: &LightRecord, linear: Mat3) -> f32 {
    let s = Vec3::new(
        linear.x_axis.length(),
        linear.y_axis.length(),
        linear.z_axis.length(),
    );
    if s.max_element() - s.min_element() > 1e-3 * s.max_element() {
        log::warn!(
            target: LOG_TARGET,
            "light {}: non-uniform scale {s} on a sphere; using their mean",
            record.path
        );
    }
    (s.x + s.y + s.z) / 3.0
}
