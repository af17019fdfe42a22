//! The scene's moving instances (`instances.motion`), as transform tracks
//! the BVHs place meshes with: a moving instance's meshes sit under the top
//! level, their boxes the union of their boxes at the keys (conservative
//! for matrix lerp, see `crate::motion`), and a ray enters such a mesh
//! through the inverse of its transform at the ray's time.
//!
//! Deforming meshes (`meshes[i].motion`) move per vertex: [`VertexKeys`]
//! hold their points (and normals) at the keys, which a ray at time t
//! lerps between the two keys around t (`crate::motion::Bracket`).

use glam::{Affine3A, Vec3};

use crate::motion::{Bracket, TransformTrack};
use crate::scene::{self, affine, Scene};

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

/// A deforming mesh's vertices at its key times, for shading: points (and
/// normals) lerped per vertex between the keys around a time.
pub(super) struct VertexKeys {
    /// Key times, frames, strictly increasing.
    times: Vec<f32>,
    /// Points per key, key-major (`count` per key).
    points: Vec<Vec3>,
    /// Normals laid out like `points`, when the mesh has normals.
    normals: Option<Vec<Vec3>>,
    /// Points per key.
    count: usize,
}

impl VertexKeys {
    /// `mesh`'s keys; `None` when it does not deform or `motion` is off
    /// (a closed shutter renders the frame's points).
    pub(super) fn new(scene: &Scene, mesh: &scene::Mesh, motion: bool) -> Option<Self> {
        let keys = mesh.motion.as_ref().filter(|_| motion)?;
        let vec3s = |a: &scene::Array<[f32; 3]>| scene.view(a).iter().map(|&v| v.into()).collect();
        Some(Self {
            times: keys.times.clone(),
            points: vec3s(&keys.points),
            normals: keys.normals.as_ref().map(vec3s),
            count: mesh.points.count as usize,
        })
    }

    /// The bracket of `time` (frames) among the keys.
    pub(super) fn bracket(&self, time: f32) -> Bracket {
        Bracket::at(&self.times, time)
    }

    /// Vertices `corners` at `bracket`.
    pub(super) fn points(&self, bracket: &Bracket, corners: [usize; 3]) -> [Vec3; 3] {
        corners.map(|i| lerp_key(&self.points, self.count, bracket, i))
    }

    /// Vertex normals of `corners` at `bracket` (not renormalized: the
    /// caller normalizes the interpolated normal); `None` without normals.
    pub(super) fn normals(&self, bracket: &Bracket, corners: [usize; 3]) -> Option<[Vec3; 3]> {
        let normals = self.normals.as_ref()?;
        Some(corners.map(|i| lerp_key(normals, self.count, bracket, i)))
    }
}

/// Element `i` of key-major `values` (`count` per key) lerped at `bracket`.
fn lerp_key(values: &[Vec3], count: usize, bracket: &Bracket, i: usize) -> Vec3 {
    bracket.lerp(
        values[bracket.before * count + i],
        values[bracket.after * count + i],
    )
}
