//! Motion blur's two shared pieces: the camera's shutter interval, and
//! transforms keyed over it (docs/rendering.md, "Motion blur").
//!
//! - **Time** is in frames relative to the frame rendered (USD's
//!   `shutter:open`/`shutter:close` convention): 0 is the exported time code,
//!   -0.25 a quarter frame before it.
//! - **Shutter**: a box, every time in [open, close] equally likely; each
//!   camera sample draws its time from its own sampler dimension.
//! - **Keyed transforms** ([`TransformTrack`]) interpolate their 3x4 matrices
//!   linearly between neighbouring keys and hold the end keys outside them.
//!   Matrix lerp, not decomposed (translation lerp, rotation slerp, scale
//!   lerp): every point x moves on p(t) = M(t) x, linear in t between keys,
//!   so a box's images at the keys bound it over the whole interval, exactly
//!   and cheaply (the top-level BVH stays conservative with no extra
//!   padding, and no ray misses a moving instance). Matrix lerp shortens a
//!   rotation by the chord: a point at radius r swept through an angle theta
//!   between two keys passes at most r (1 - cos(theta / 2)) inside its arc,
//!   so the exporter adds keys (USD's own interpolation, read at the
//!   inserted times) until no key-to-key rotation exceeds
//!   `MAX_KEY_ROTATION_DEG` in `exporter/cirrus_export/motion.py` (5 degrees:
//!   at most 0.095% of r, below a pixel for anything under 1000 pixels
//!   across). pbrt-v4's `AnimatedTransform` takes the other road: decomposed
//!   interpolation with bounds from the roots of the motion derivative.

use std::fmt;

use glam::Affine3A;
use thiserror::Error;

/// A shutter interval, frames relative to the frame rendered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shutter {
    /// When the shutter opens, frames (USD `shutter:open`, default 0).
    pub open: f32,
    /// When it closes, frames (USD `shutter:close`, default 0); `>= open`.
    pub close: f32,
}

/// A shutter that cannot be used.
#[derive(Debug, Error, PartialEq)]
pub enum ShutterError {
    /// Not two finite numbers with close >= open.
    #[error("shutter {open},{close}: {why}")]
    Invalid {
        /// The open time as given.
        open: f32,
        /// The close time as given.
        close: f32,
        /// What is wrong.
        why: &'static str,
    },
    /// The `OPEN,CLOSE` text does not parse.
    #[error("{0:?}: expected OPEN,CLOSE in frames, e.g. -0.25,0.25")]
    Syntax(String),
}

impl Shutter {
    /// The instantaneous shutter at the frame itself (USD's default 0, 0).
    pub const CLOSED: Self = Self {
        open: 0.0,
        close: 0.0,
    };

    /// A shutter from `open` to `close` (frames); refuses non-finite times
    /// and close < open.
    pub fn new(open: f32, close: f32) -> Result<Self, ShutterError> {
        let invalid = |why| ShutterError::Invalid { open, close, why };
        if !open.is_finite() || !close.is_finite() {
            return Err(invalid("both times must be finite"));
        }
        if close < open {
            return Err(invalid("close must not be before open"));
        }
        Ok(Self { open, close })
    }

    /// Whether the shutter stays open for a while (close > open): only
    /// then do camera samples draw a time.
    pub fn is_open(&self) -> bool {
        self.close > self.open
    }

    /// Whether anything may move: every shutter but [`Shutter::CLOSED`].
    /// A shutter closed at the frame itself renders the scene as it is at
    /// the frame, motion keys ignored, bit-identical to the scene exported
    /// without them.
    pub fn blurs(&self) -> bool {
        *self != Self::CLOSED
    }

    /// The time at fraction `u` in [0, 1) of the interval, frames.
    pub fn time(&self, u: f32) -> f32 {
        if self.is_open() {
            self.open + u * (self.close - self.open)
        } else {
            self.open
        }
    }
}

impl std::str::FromStr for Shutter {
    type Err = ShutterError;

    /// `OPEN,CLOSE` in frames (`--shutter`).
    fn from_str(s: &str) -> Result<Self, ShutterError> {
        let syntax = || ShutterError::Syntax(s.to_owned());
        let (open, close) = s.split_once(',').ok_or_else(syntax)?;
        let time = |v: &str| v.trim().parse::<f32>().map_err(|_| syntax());
        Self::new(time(open)?, time(close)?)
    }
}

impl fmt::Display for Shutter {
    /// `open,close` in frames, as `--shutter` takes it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.open, self.close)
    }
}

/// Where a time falls among strictly increasing key times: the two keys
/// around it and the fraction of the way from the first to the second
/// (linear interpolation weight); outside the keys, the end key held
/// (both keys the same, `s` 0). Shared by transform tracks and deforming
/// meshes' per-vertex keys.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bracket {
    /// The key at or before the time (the first key before all keys).
    pub before: usize,
    /// The key after it (equal to `before` outside the keys).
    pub after: usize,
    /// Weight of `after`, in [0, 1).
    pub s: f32,
}

impl Bracket {
    /// The bracket of `time` (frames) among `times` (non-empty, strictly
    /// increasing).
    pub fn at(times: &[f32], time: f32) -> Self {
        let last = times.len() - 1;
        let after = times.partition_point(|&t| t <= time);
        if after == 0 || after > last {
            let key = if after == 0 { 0 } else { last };
            return Self {
                before: key,
                after: key,
                s: 0.0,
            };
        }
        let (t0, t1) = (times[after - 1], times[after]);
        Self {
            before: after - 1,
            after,
            s: (time - t0) / (t1 - t0),
        }
    }

    /// `a` and `b` (values at `before` and `after`) mixed by `s`.
    pub fn lerp<T>(&self, a: T, b: T) -> T
    where
        T: std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
    {
        a * (1.0 - self.s) + b * self.s
    }
}

/// A transform keyed at increasing times and interpolated by matrix lerp
/// (see the module doc); never empty.
#[derive(Clone, Debug)]
pub struct TransformTrack {
    /// Key times, frames, strictly increasing.
    times: Vec<f32>,
    /// The transform at each key.
    keys: Vec<Affine3A>,
}

impl TransformTrack {
    /// The track through `keys` at `times` (equally long, at least one key,
    /// times strictly increasing); `None` otherwise.
    pub fn new(times: Vec<f32>, keys: Vec<Affine3A>) -> Option<Self> {
        let increasing = times.windows(2).all(|w| w[0] < w[1]);
        (!keys.is_empty() && times.len() == keys.len() && increasing)
            .then_some(Self { times, keys })
    }

    /// The transform at `time` (frames): the lerp of the two keys around
    /// it, the first or last key outside them.
    pub fn at(&self, time: f32) -> Affine3A {
        let Bracket { before, after, s } = Bracket::at(&self.times, time);
        if s == 0.0 {
            return self.keys[before];
        }
        let (a, b) = (&self.keys[before], &self.keys[after]);
        Affine3A {
            matrix3: a.matrix3 * (1.0 - s) + b.matrix3 * s,
            translation: a.translation * (1.0 - s) + b.translation * s,
        }
    }

    /// The keys: their images of a box bound its image at every time.
    pub fn keys(&self) -> &[Affine3A] {
        &self.keys
    }

    /// The key times, frames.
    pub fn times(&self) -> &[f32] {
        &self.times
    }
}

#[cfg(test)]
mod tests {
    use glam::{Quat, Vec3, Vec3A};

    use super::*;
    use crate::sampling::Pcg32;

    #[test]
    fn shutter_parses_and_refuses_close_before_open() {
        let s: Shutter = "-0.25, 0.25".parse().unwrap();
        assert_eq!((s.open, s.close), (-0.25, 0.25));
        assert!(s.is_open());
        assert_eq!(s.time(0.5), 0.0);
        assert!(!Shutter::CLOSED.is_open());
        assert_eq!(Shutter::new(0.5, 0.5).unwrap().time(0.9), 0.5);
        let err = "1,0".parse::<Shutter>().unwrap_err().to_string();
        assert!(err.contains("close must not be before open"), "{err}");
        assert!("nan,1".parse::<Shutter>().is_err());
        assert!(matches!(
            "0.5".parse::<Shutter>(),
            Err(ShutterError::Syntax(_))
        ));
    }

    #[test]
    fn track_lerps_between_keys_and_holds_the_ends() {
        let a = Affine3A::from_translation(Vec3::ZERO);
        let b = Affine3A::from_translation(Vec3::new(2.0, 0.0, 0.0));
        let c = Affine3A::from_translation(Vec3::new(2.0, 4.0, 0.0));
        let track = TransformTrack::new(vec![0.0, 1.0, 2.0], vec![a, b, c]).unwrap();
        let x = |t: f32| Vec3::from(track.at(t).translation);
        assert_eq!(x(-1.0), Vec3::ZERO);
        assert_eq!(x(0.25), Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(x(1.0), Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(x(1.5), Vec3::new(2.0, 2.0, 0.0));
        assert_eq!(x(7.0), Vec3::new(2.0, 4.0, 0.0));
        assert!(TransformTrack::new(vec![1.0, 1.0], vec![a, b]).is_none());
        assert!(TransformTrack::new(vec![], vec![]).is_none());
    }

    /// The measurement behind the choice of matrix lerp: between keys
    /// `theta` apart, a point at radius 1 comes at most 1 - cos(theta / 2)
    /// inside its arc (0.095% at 5 degrees), and it never leaves the box of
    /// its key positions.
    #[test]
    fn matrix_lerp_shortens_rotations_by_the_chord_and_stays_in_the_key_boxes() {
        let mut rng = Pcg32::new(23, 0);
        for theta_deg in [5.0f32, 30.0, 90.0] {
            let theta = theta_deg.to_radians();
            let axis = Vec3::new(0.3, 1.0, -0.2).normalize();
            let keys = vec![
                Affine3A::from_rotation_translation(Quat::IDENTITY, Vec3::X),
                Affine3A::from_rotation_translation(Quat::from_axis_angle(axis, theta), Vec3::X),
            ];
            let track = TransformTrack::new(vec![0.0, 1.0], keys.clone()).unwrap();
            let mut worst = 0.0f32;
            for _ in 0..200 {
                let p = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
                let p = p.cross(axis.into()).normalize();
                let t = rng.next_f32();
                let q = track.at(t).transform_point3a(p) - Vec3A::X;
                worst = worst.max(1.0 - q.length());
                let (k0, k1) = (keys[0].transform_point3a(p), keys[1].transform_point3a(p));
                let (lo, hi) = (k0.min(k1), k0.max(k1));
                let inside = track.at(t).transform_point3a(p);
                assert!((inside.cmpge(lo - 1e-6) & inside.cmple(hi + 1e-6)).all());
            }
            let bound = 1.0 - (theta / 2.0).cos();
            assert!(worst <= bound + 1e-5, "{theta_deg} deg: {worst} > {bound}");
            assert!(worst >= 0.9 * bound, "{theta_deg} deg: {worst} << {bound}");
        }
    }
}
