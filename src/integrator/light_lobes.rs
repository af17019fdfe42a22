//! Per-light diffuse and specular factors (UsdLux `inputs:diffuse` and
//! `inputs:specular`, docs/conventions.md, "Lights"): what a light gives a
//! surface through its diffuse lobe is scaled by the one, through its
//! specular lobes by the other. Transmission, Dirac pass-through, phase
//! functions (volumes) and camera rays are not scaled, as Cycles does
//! (Blender reads the two inputs into a light's diffuse and glossy factors
//! and leaves its transmission and volume factors at 1).
//!
//! Both estimators scale the same BSDF value: next-event estimation the
//! value towards the light sample ([`scaled`]), BSDF sampling the share of
//! each lobe in the sampled direction's value ([`LobeSplit`]), so they stay
//! consistent under MIS.

use glam::Vec3;

use super::gathered::lobe_shares;
use crate::materials::LobeValues;
use crate::scene::LightLobes;

/// How the BSDF value of the direction a path took splits between the lobes
/// a light's factors scale, for emission that direction finds.
#[derive(Clone, Copy, Debug)]
pub(super) enum LobeSplit {
    /// A camera ray, a Dirac pass-through or a phase-sampled ray: no factor.
    Unscaled,
    /// Each lobe's share (per RGB channel) of the BSDF value; the rest
    /// (transmission) is not scaled.
    Surface { diffuse: Vec3, specular: Vec3 },
}

impl LobeSplit {
    /// The shares of `split`'s diffuse and specular parts in its total.
    pub(super) fn of(split: LobeValues) -> Self {
        let [diffuse, specular, ..] = lobe_shares(split);
        Self::Surface { diffuse, specular }
    }

    /// The factor on emission of a light with `lobes` found along the ray.
    pub(super) fn factor(self, lobes: LightLobes) -> Vec3 {
        match self {
            Self::Unscaled => Vec3::ONE,
            Self::Surface { diffuse, specular } => {
                Vec3::ONE + diffuse * (lobes.diffuse - 1.0) + specular * (lobes.specular - 1.0)
            }
        }
    }
}

/// `split` with a light's factors on its diffuse and specular parts.
pub(super) fn scaled(split: LobeValues, lobes: LightLobes) -> LobeValues {
    LobeValues {
        diffuse: split.diffuse * lobes.diffuse,
        specular: split.specular * lobes.specular,
        transmission: split.transmission,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factor a BSDF-sampled ray applies equals the ratio of the scaled
    /// value to the unscaled one, as next-event estimation applies it.
    #[test]
    fn both_estimators_scale_alike() {
        let split = LobeValues {
            diffuse: Vec3::new(0.3, 0.2, 0.0),
            specular: Vec3::new(0.1, 0.0, 0.5),
            transmission: Vec3::new(0.2, 0.1, 0.5),
        };
        let lobes = LightLobes {
            diffuse: 0.0,
            specular: 3.0,
        };
        let ratio = scaled(split, lobes).total() / split.total();
        let factor = LobeSplit::of(split).factor(lobes);
        assert!(
            (ratio - factor).abs().max_element() < 1e-6,
            "{ratio} {factor}"
        );
        assert_eq!(LobeSplit::Unscaled.factor(lobes), Vec3::ONE);
        assert_eq!(
            LobeSplit::of(LobeValues::default()).factor(lobes),
            Vec3::ONE
        );
    }
}
