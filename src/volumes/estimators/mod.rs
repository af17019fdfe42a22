//! Estimators over a ray's majorant segments (Novák, Georgiev, Hanika and
//! Jarosz 2018, "Monte Carlo Methods for Volumetric Light Transport
//! Simulation"): free flights by delta tracking
//! ([`walk_tentative_collisions`]) and shadow-ray transmittance
//! ([`transmittance`]) by ratio, residual ratio (Novák et al. 2014,
//! "Residual Ratio Tracking for Estimating Attenuation in Participating
//! Media") or track-length tracking (tracking.rs), or by unbiased ray
//! marching (Kettunen et al. 2021, ray_marching.rs); the camera ray's
//! pass-through weight on delta tracking's own collisions
//! ([`PassThrough`], pass_through.rs); and the counters all of them add to
//! ([`TrackingStats`], stats.rs).

mod pass_through;
mod ray_marching;
mod stats;
mod tracking;

pub use pass_through::PassThrough;
pub use stats::TrackingStats;
pub use tracking::{
    channel_mean, ratio_tracking_with_null_ratio, transmittance, walk_tentative_collisions,
    TransmittanceEstimator, RUSSIAN_ROULETTE_THRESHOLD,
};
