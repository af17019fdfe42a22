//! OpenPBR Surface (ASWF OpenPBR specification 1.1,
//! <https://academysoftwarefoundation.github.io/OpenPBR/>): inputs at a hit
//! (inputs.rs) to a mixture of lobes (model.rs builds it, eval.rs evaluates
//! and samples it) that [`Bsdf::from_open_pbr`](super::Bsdf::from_open_pbr)
//! wraps.
//!
//! Lobes and papers (docs/materials.md states the equations, what conserves
//! energy and what deliberately loses it, with measured furnace values):
//! - diffuse: EON, energy-preserving Oren-Nayar (Portsmouth et al. 2024),
//!   eon.rs;
//! - metal: GGX with the F82-tint Fresnel (Kutz et al. 2021);
//! - dielectric specular, coat, thin wall: GGX (Heitz 2014, visible normals
//!   by Dupuy and Benyoub 2023) with exact Fresnel, the spec's
//!   specular_weight ior modulation, coat darkening and roughening;
//! - thick transmission: the rough dielectric of Walter et al. 2007, its
//!   interior's absorption from transmission_depth (medium.rs);
//! - thin film: Belcour and Barla 2017's Airy reflectance on the metal,
//!   specular and transmission Fresnel (1 - R transmitted), thin_film.rs;
//! - fuzz: Zeltner et al. 2022's LTC sheen, fuzz.rs;
//! - energy compensation of the GGX lobes (Turquin 2019) and albedo-scaling
//!   layering from tabulated directional albedos, albedo.rs.

mod albedo;
mod eon;
mod eval;
mod fuzz;
mod inputs;
mod medium;
mod model;
mod thin_film;

pub(crate) use inputs::{OpenPbrInputs, ShadingFrames};
pub(crate) use medium::interior_absorption;
pub(crate) use model::OpenPbr;
