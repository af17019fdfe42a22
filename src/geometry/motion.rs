//! The scene's moving instances (`instances.motion`), as transform tracks
//! the BVHs place meshes with: a moving instance's meshes sit under the top
//! level, their boxes the union of their boxes at the keys (conservative
//! for matrix lerp, see `crate::motion`), and a ray enters such a mesh
//! through the inverse of its transform at the ray's time.

use glam::Affine3A;

use crate::motion::TransformTrack;
use crate::scene::{affine, Scene};

/// World-from-prototype tracks of the moving instances, by instance index.
pub struct MovingInstances {
    /// Moving instance indices, strictly increasing.
    instances: Vec<u32>,
    /// `tracks[i]` moves instance `instances[i]`.
    tracks: Vec<TransformTrack>,
}

impl MovingInstances {
    /// The moving instances of `scene`; none without `motion` or when the
    /// scene has no motion.
    pub fn new(scene: &Scene, motion: bool) -> Self {
        let motion = scene.manifest.instances.motion.as_ref().filter(|_| motion);
        let Some(motion) = motion else {
            return Self {
                instances: Vec::new(),
                tracks: Vec::new(),
            };
        };
        let instances = scene.view(&motion.instance).to_vec();
        let tracks = scene
            .view(&motion.transform)
            .chunks_exact(motion.times.len())
            .map(|keys| {
                TransformTrack::new(motion.times.clone(), keys.iter().map(affine).collect())
                    .expect("the loader checked the key times")
            })
            .collect();
        Self { instances, tracks }
    }

    /// Whether instance `instance` moves.
    pub(super) fn moves(&self, instance: u32) -> bool {
        self.instances.binary_search(&instance).is_ok()
    }

    /// The world-from-mesh track of a mesh placed by `instance` at
    /// `prototype_from_mesh`; `None` when the instance does not move.
    /// Lerping world-from-prototype keys and then placing the mesh equals
    /// lerping the placed keys, so the mesh's keys are the instance's
    /// times the part's transform.
    pub fn mesh_track(
        &self,
        instance: u32,
        prototype_from_mesh: Affine3A,
    ) -> Option<TransformTrack> {
        let i = self.instances.binary_search(&instance).ok()?;
        let track = &self.tracks[i];
        let keys = track.keys().iter().map(|k| *k * prototype_from_mesh);
        TransformTrack::new(track.times().to_vec(), keys.collect())
    }
}
