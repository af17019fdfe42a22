//! Emitting volumes: what they emit, blackbody radiance from a temperature
//! grid (blackbody.rs, [`BlackbodyTable`]), and where, for sampling a
//! volume as a light (Villemin & Hery 2013, "Practical Illumination from
//! Flames"): its majorant grid's occupied cells weighed by the power they
//! emit (emitter.rs, `EmissionCells`), picked by what they deliver near
//! the shading point (near_picks.rs, `NearImportance`, weighed as Conty
//! Estevez & Kulla 2018 weigh lights).

mod blackbody;
mod emitter;
mod near_picks;

pub use blackbody::{BlackbodyTable, REFERENCE_TEMPERATURE_K};
pub(crate) use emitter::{EmissionCells, SourceSample};
pub(crate) use near_picks::NearImportance;
