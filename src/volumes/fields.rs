//! A scene's volume fields, each read once: the identity a grid is shared
//! under, float grids, and the velocity fields that advect volumes.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use super::checks::{velocity_units_per_frame, warn_bad_velocities};
use super::grid::{SparseGrid, VdbFile, VolumeError};
use super::motion::VelocityField;
use crate::motion::Shutter;
use crate::scene::{Scene, VolumeField};

/// A density field's identity: file, grid name and occurrence index. Each is
/// read (and its majorant grid built) once, whatever the placements.
pub(super) type FieldKey = (PathBuf, String, u32);

/// A volume's velocity field and the world units per frame one unit of it
/// moves (`motion:velocityScale` / `timeCodesPerSecond`).
pub(super) type Velocity = (Arc<VelocityField>, f32);

/// Per volume, its velocity field (read once per file, grid and index) and
/// world units per frame per unit of velocity, when it has one and
/// `shutter` is not closed at the frame; `None` otherwise.
pub(super) fn read_velocities(
    scene: &Scene,
    shutter: Shutter,
) -> Result<Vec<Option<Velocity>>, VolumeError> {
    let mut read: HashMap<FieldKey, Arc<VelocityField>> = HashMap::new();
    let mut velocities = Vec::new();
    for volume in &scene.manifest.volumes {
        let field = volume.fields.get("velocity").filter(|_| shutter.blurs());
        let Some(field) = field else {
            velocities.push(None);
            continue;
        };
        let per_frame = velocity_units_per_frame(volume)?;
        let velocity = match read.get(&field_key(field)) {
            Some(found) => Arc::clone(found),
            None => {
                let velocity = Arc::new(VelocityField::read(field)?);
                warn_bad_velocities(volume, field, &velocity);
                read.insert(field_key(field), Arc::clone(&velocity));
                velocity
            }
        };
        velocities.push(Some((velocity, per_frame)));
    }
    Ok(velocities)
}

/// The identity under which `field`'s grid is read once and shared.
pub(super) fn field_key(field: &VolumeField) -> FieldKey {
    (field.file.clone(), field.grid.clone(), field.index)
}

/// Reads `field`'s float grid from its VDB file.
pub(super) fn read_field(field: &VolumeField) -> Result<SparseGrid, VolumeError> {
    VdbFile::open(&field.file)?.read_float_grid(&field.grid, field.index as usize)
}
