//! Primvars carried per instance (`Instances::primvars`): the values a
//! PointInstancer's `vertex`/`varying` primvars give each of its instances,
//! its `constant`/`uniform` ones give all of them, and constant primvars on
//! native instance roots and their ancestors give each copy below them
//! (exporter/FORMAT.md, "Instances"; docs/materials.md, "Primvars").

use serde::Deserialize;

use super::Array;

/// One primvar's values for a run of consecutive instances.
#[derive(Clone, Debug, Deserialize)]
pub struct InstancePrimvarRun {
    /// Index of the run's first instance.
    pub first: u64,
    /// One element per instance of the run (f32, width 1 to 4): instance
    /// `first + k` holds element `k`.
    pub values: Array<f32>,
}
