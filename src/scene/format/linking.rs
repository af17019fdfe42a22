//! Light and shadow linking in the manifest (exporter/FORMAT.md, "Linking"):
//! each light's link sets, and each placed part's set in [`LinkRun`]s.

use serde::Deserialize;

/// A light's `collection:lightLink` and `collection:shadowLink`, as link
/// set ids (see [`LinkRun`]); each absent (the default) when its collection
/// holds everything: the light lights every part and every part casts its
/// shadow.
#[derive(Clone, Debug, Default, Deserialize)]
pub struct LightLinks {
    /// The link sets whose parts this light lights (`collection:lightLink`).
    #[serde(default)]
    pub light_link: Option<Vec<u32>>,
    /// The link sets whose parts cast this light's shadow (`collection:shadowLink`);
    /// the others are transparent to it.
    #[serde(default)]
    pub shadow_link: Option<Vec<u32>>,
}

/// The link sets of the parts of a run of consecutive instances (one
/// prototype's copies); parts of instances in no run are in set 0.
#[derive(Clone, Debug, Deserialize)]
pub struct LinkRun {
    /// The run's first instance.
    pub first: u64,
    /// Instances in the run.
    pub count: u64,
    /// Per surface part of the prototype, in `Hit::prototype_mesh` order
    /// (meshes, then points, then curves): its link set.
    pub parts: Vec<u32>,
    /// Per volume part of the prototype: its link set.
    #[serde(default)]
    pub volumes: Vec<u32>,
}
