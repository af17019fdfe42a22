//! Random and quasi-random numbers for Monte Carlo estimators.

mod rng;

pub use rng::Pcg32;
