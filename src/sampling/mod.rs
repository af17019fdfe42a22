//! Random and quasi-random numbers for Monte Carlo estimators, the warps that
//! shape them into directions and points, and tabulated distributions.

mod alias;
mod distribution;
mod rng;
mod sobol;
pub mod warp;

pub use alias::AliasTable;
pub use distribution::{ContinuousSample, DiscreteSample, Distribution1D, Distribution2D};
pub use rng::Pcg32;
pub use sobol::{Sampler, SamplerKind};
