//! An orthonormal frame: the local shading space in which BSDFs and lights
//! work with `z` as the normal, as pbrt-v4's `Frame` and Mitsuba's `Frame3f`.

use glam::Vec3;

/// An orthonormal basis `(s, t, n)`: `to_local` maps world vectors to
/// coordinates where `n` is +z; `to_world` maps them back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent (local +x).
    pub s: Vec3,
    /// Second tangent (local +y), `n x s`.
    pub t: Vec3,
    /// Normal (local +z).
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit vector `n`, tangents chosen without branches
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let (s, t) = n.any_orthonormal_pair();
        Self { s, t, n }
    }

    /// A frame with normal `n` (unit) and first tangent as close to `tangent`
    /// as orthogonality allows (Gram-Schmidt); falls back to
    /// [`Frame::from_normal`] when `tangent` is parallel to `n` or degenerate.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = (tangent - n * n.dot(tangent)).normalize_or_zero();
        if s == Vec3::ZERO {
            return Self::from_normal(n);
        }
        Self {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World vector `v` in this frame's coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local coordinates `v` back in world space.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_round_trip() {
        let v = Vec3::new(0.3, -0.5, 0.8);
        for n in [Vec3::Z, -Vec3::Z, Vec3::new(1.0, 2.0, -3.0).normalize()] {
            for f in [
                Frame::from_normal(n),
                Frame::from_normal_tangent(n, Vec3::X),
            ] {
                assert!((f.s.dot(f.t)).abs() < 1e-6 && (f.s.dot(f.n)).abs() < 1e-6);
                assert!((f.s.length() - 1.0).abs() < 1e-6 && (f.t.length() - 1.0).abs() < 1e-6);
                assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "right-handed");
                assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
            }
        }
    }
}
