//! The methods of the convergence study: `cirrus render`'s defaults with at
//! most one flag changed, by their names in `--methods`, the CSVs and the
//! charts; the series of a study (a method or a peer); its budgets.

use crate::integrator::{RenderSettings, Strategy, VolumeEstimator};
use crate::lab::peers::Peer;
use crate::render_state::RenderState;
use crate::sampling::SamplerKind;
use crate::volumes::majorant::MajorantKind;

/// A method of the study: the reference's settings ([`base_settings`](crate::lab::reference::base_settings),
/// which are `cirrus render`'s defaults but a box filter) with at most one
/// `cirrus render` flag changed, through the same option types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// No flag changed: the reference's own estimator.
    Default,
    /// `--sampler`.
    Sampler(SamplerKind),
    /// `--strategy`.
    Strategy(Strategy),
    /// `--majorant`.
    Majorant(MajorantKind),
    /// `--volume-estimator`.
    Estimator(VolumeEstimator),
    /// `--no-equiangular`.
    NoEquiangular,
    /// `--camera-ray-transmittance on`: camera rays see what lies behind
    /// media through a transmittance estimate.
    CameraRayTransmittance,
}

/// Every method, in table and chart order.
pub(crate) const METHODS: [Method; 11] = [
    Method::Default,
    Method::Sampler(SamplerKind::Independent),
    Method::Strategy(Strategy::Bsdf),
    Method::Strategy(Strategy::Nee),
    Method::Majorant(MajorantKind::Global),
    Method::Majorant(MajorantKind::Adaptive),
    Method::Estimator(VolumeEstimator::Ratio),
    Method::Estimator(VolumeEstimator::ResidualRatio),
    Method::Estimator(VolumeEstimator::TrackLength),
    Method::NoEquiangular,
    Method::CameraRayTransmittance,
];

impl Method {
    /// The name in `--methods`, the CSVs and the charts: the flag's name
    /// (volume estimators shortened to `estimator`) and value.
    pub(crate) fn name(self) -> String {
        match self {
            Self::Default => "default".into(),
            Self::Sampler(s) => format!("sampler-{}", s),
            Self::Strategy(s) => format!("strategy-{}", s),
            Self::Majorant(m) => format!("majorant-{}", m),
            Self::Estimator(e) => format!("estimator-{}", e),
            Self::NoEquiangular => "no-equiangular".into(),
            Self::CameraRayTransmittance => "camera-ray-transmittance".into(),
        }
    }

    /// The `cirrus render` flag this method adds (empty for `default`).
    pub(crate) fn flag(self) -> String {
        match self {
            Self::Default => String::new(),
            Self::Sampler(s) => format!("--sampler {}", s),
            Self::Strategy(s) => format!("--strategy {}", s),
            Self::Majorant(m) => format!("--majorant {}", m),
            Self::Estimator(e) => format!("--volume-estimator {}", e),
            Self::NoEquiangular => "--no-equiangular".into(),
            Self::CameraRayTransmittance => "--camera-ray-transmittance on".into(),
        }
    }

    /// Whether the method differs from `default` on this scene: volume
    /// methods need volumes, and `no-equiangular` also a light that
    /// equiangular sampling targets ([`crate::lights::Lights::has_equiangular_target`]).
    pub(crate) fn applies_to(self, state: &RenderState) -> bool {
        let volumes = !state.media.is_empty();
        match self {
            Self::Default | Self::Sampler(_) | Self::Strategy(_) => true,
            Self::Majorant(_) | Self::Estimator(_) | Self::CameraRayTransmittance => volumes,
            Self::NoEquiangular => volumes && state.lights.has_equiangular_target(),
        }
    }

    /// `base` with this method's flag applied, as `cirrus render` applies it.
    pub(crate) fn settings(self, base: RenderSettings) -> RenderSettings {
        let mut s = base;
        match self {
            Self::Default | Self::Majorant(_) => {}
            Self::Sampler(sampler) => s.sampler = sampler,
            Self::Strategy(strategy) => s.path.strategy = strategy,
            Self::Estimator(estimator) => s.path.volume_estimator = estimator,
            Self::NoEquiangular => s.path.equiangular = false,
            Self::CameraRayTransmittance => s.path.camera_ray_transmittance = true,
        }
        s
    }

    /// The majorants the render state is built with.
    pub(crate) fn majorant(self) -> MajorantKind {
        match self {
            Self::Majorant(m) => m,
            _ => MajorantKind::Grid,
        }
    }
}

/// What one row of the study rendered: a method of ours or a peer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Series {
    Ours(Method),
    Peer(Peer),
}

impl Series {
    /// The name in the CSVs and charts: the method's or the peer's.
    pub(crate) fn name(self) -> String {
        match self {
            Self::Ours(m) => m.name(),
            Self::Peer(p) => p.to_string(),
        }
    }

    /// How it is rendered: the `cirrus render` flag, or the peer's script.
    pub(crate) fn flag(self) -> String {
        match self {
            Self::Ours(m) => m.flag(),
            Self::Peer(p) => format!("render_peer.py {p}"),
        }
    }
}

/// Parses one `--methods` name.
pub fn parse_method(s: &str) -> Result<Method, String> {
    METHODS.into_iter().find(|m| m.name() == s).ok_or_else(|| {
        let names: Vec<String> = METHODS.iter().map(|m| m.name()).collect();
        format!("{s:?}: expected one of {}", names.join(", "))
    })
}

/// The budgets: 1, 2, 4, ... spp up to `spp_max`, which comes last when it
/// is not a power of two.
pub(crate) fn budgets(spp_max: u32) -> Vec<u32> {
    let mut spp: Vec<u32> = std::iter::successors(Some(1u32), |&n| n.checked_mul(2))
        .take_while(|&n| n <= spp_max)
        .collect();
    if !spp_max.is_power_of_two() {
        spp.push(spp_max);
    }
    spp
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::Budget;
    use crate::lab::reference::base_settings;

    #[test]
    fn method_names_parse_back_and_are_unique() {
        for m in METHODS {
            assert_eq!(parse_method(&m.name()), Ok(m));
        }
        let names: std::collections::HashSet<String> = METHODS.iter().map(|m| m.name()).collect();
        assert_eq!(names.len(), METHODS.len());
        assert!(parse_method("estimator-delta").is_err());
        assert_eq!(
            Method::Estimator(VolumeEstimator::ResidualRatio).name(),
            "estimator-residual-ratio"
        );
    }

    #[test]
    fn each_method_changes_only_its_field() {
        let base = base_settings(Budget::Samples(4), 7);
        let s = Method::Sampler(SamplerKind::Independent).settings(base.clone());
        assert_eq!(s.sampler, SamplerKind::Independent);
        assert_eq!(s.path.strategy, base.path.strategy);
        let s = Method::NoEquiangular.settings(base.clone());
        assert!(!s.path.equiangular && base.path.equiangular);
        assert_eq!(s.seed, 7);
        let s = Method::Majorant(MajorantKind::Global).settings(base.clone());
        assert_eq!(s.path.volume_estimator, base.path.volume_estimator);
        assert_eq!(
            Method::Majorant(MajorantKind::Global).majorant(),
            MajorantKind::Global
        );
    }

    #[test]
    fn budgets_double_up_to_the_largest() {
        assert_eq!(budgets(1), [1]);
        assert_eq!(budgets(16), [1, 2, 4, 8, 16]);
        assert_eq!(budgets(12), [1, 2, 4, 8, 12]);
    }
}
