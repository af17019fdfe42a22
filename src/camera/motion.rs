//! A camera record's shutter and motion keys, checked.

use glam::Affine3A;

use crate::motion::{Shutter, TransformTrack};
use crate::scene;

/// The record's `shutter:open`/`shutter:close` (closed when unauthored);
/// refuses close < open.
pub(super) fn shutter(record: &scene::Camera) -> Result<Shutter, String> {
    match record.shutter {
        Some([open, close]) => Shutter::new(open, close).map_err(|e| e.to_string()),
        None => Ok(Shutter::CLOSED),
    }
}

/// The track of a moving camera record; refuses keys that are singular or
/// do not make a track.
pub(super) fn track(record: &scene::Camera) -> Result<Option<TransformTrack>, String> {
    let Some(motion) = &record.motion else {
        return Ok(None);
    };
    let keys: Vec<Affine3A> = motion.transforms.iter().map(scene::affine).collect();
    if let Some(k) = keys
        .iter()
        .position(|k| !k.matrix3.determinant().is_normal())
    {
        return Err(format!(
            "the world-from-camera transform at time {} is singular",
            motion.times[k]
        ));
    }
    let track = TransformTrack::new(motion.times.clone(), keys);
    track
        .map(Some)
        .ok_or_else(|| "motion key times must be strictly increasing".into())
}
