//! Analytic ray intersection with spheres (points) and linear swept spheres
//! (curve pieces: round cones, the convex hull of two spheres).
//!
//! Both solve their quadratics about a ray origin first moved along the ray
//! to the shape (Haines, Günther, Akenine-Möller 2019, "Precision
//! Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7): the
//! discriminant then loses no digits to the origin's distance. The round
//! cone is Quilez's ("Intersectors", iquilezles.org, `iRoundedCone`):
//! the lateral surface between the two spheres' tangent circles, and each
//! sphere's cap beyond its circle, extended to both roots of each piece so
//! a ray starting inside leaves through the far side.

use glam::{Vec3A, Vec4};

/// Where a ray meets a round shape, in the shape's space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundHit {
    /// Ray parameter, in units of the ray's direction length.
    pub t: f32,
    /// Unit outward normal.
    pub normal: Vec3A,
    /// Along a round cone, 0 at its first sphere to 1 at its second (the
    /// swept sphere touching the hit); 0 on a sphere.
    pub s: f32,
}

/// A ray prepared for round shapes: unit direction and its length.
#[derive(Clone, Copy, Debug)]
pub struct RoundRay {
    origin: Vec3A,
    /// Unit direction.
    dir: Vec3A,
    /// Length of the original direction: normalised `t` divided by it is
    /// the caller's `t`.
    length: f32,
}

impl RoundRay {
    /// Prepares a ray; `direction` must be non-zero.
    pub fn new(origin: Vec3A, direction: Vec3A) -> Self {
        let length = direction.length();
        Self {
            origin,
            dir: direction / length,
            length,
        }
    }

    /// The nearest hit on the sphere `centre_radius` (xyz centre, w radius)
    /// with `t_min < t < t_max`, from outside or inside.
    #[inline]
    pub fn sphere(&self, centre_radius: Vec4, t_min: f32, t_max: f32) -> Option<RoundHit> {
        let (centre, r) = (Vec3A::from(centre_radius.truncate()), centre_radius.w);
        let shift = (centre - self.origin).dot(self.dir);
        let f = self.origin + shift * self.dir - centre;
        let disc = r * r - f.length_squared();
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        [-root, root].into_iter().find_map(|dt| {
            let t = (shift + dt) / self.length;
            (t > t_min && t < t_max).then(|| RoundHit {
                t,
                normal: ((f + dt * self.dir) / r).normalize(),
                s: 0.0,
            })
        })
    }

    /// The nearest hit on the round cone from sphere `a` to sphere `b` (xyz
    /// centre, w radius) with `t_min < t < t_max`, from outside or inside.
    #[inline]
    pub fn round_cone(&self, a: Vec4, b: Vec4, t_min: f32, t_max: f32) -> Option<RoundHit> {
        let (pa, ra) = (Vec3A::from(a.truncate()), a.w);
        let (pb, rb) = (Vec3A::from(b.truncate()), b.w);
        let ba = pb - pa;
        let rr = ra - rb;
        let m0 = ba.length_squared();
        let d2 = m0 - rr * rr;
        if d2 <= 0.0 {
            // One sphere holds the other: the hull is the larger.
            return self.sphere(if ra >= rb { a } else { b }, t_min, t_max);
        }
        // Origin moved to the ray's closest approach to the cone's middle.
        let shift = ((pa + pb) * 0.5 - self.origin).dot(self.dir);
        let ro = self.origin + shift * self.dir;
        let rd = self.dir;
        let (oa, ob) = (ro - pa, ro - pb);
        let (m1, m2, m3) = (ba.dot(oa), ba.dot(rd), rd.dot(oa));
        let (m5, m6, m7) = (oa.length_squared(), ob.dot(rd), ob.length_squared());
        let mut best: Option<(f32, RoundHit)> = None;
        let mut offer = |local: f32, normal: Vec3A, s: f32| {
            let t = (shift + local) / self.length;
            if t > t_min && t < t_max && best.is_none_or(|(b, _)| t < b) {
                best = Some((t, RoundHit { t, normal, s }));
            }
        };
        // Lateral surface: y = d2 * s, valid for 0 < s < 1.
        let k2 = d2 - m2 * m2;
        let k1 = d2 * m3 - m1 * m2 + m2 * rr * ra;
        let k0 = d2 * m5 - m1 * m1 + 2.0 * m1 * rr * ra - m0 * ra * ra;
        let h = k1 * k1 - k0 * k2;
        if h >= 0.0 && k2 != 0.0 {
            for sign in [-1.0, 1.0] {
                let local = (sign * h.sqrt() - k1) / k2;
                let y = m1 - ra * rr + local * m2;
                if y > 0.0 && y < d2 {
                    let normal = (d2 * (oa + local * rd) - ba * y).normalize();
                    offer(local, normal, y / d2);
                }
            }
        }
        // Caps: sphere a where y <= 0, sphere b where y >= d2.
        for (o, m_dot, m_len, r, s) in [(oa, m3, m5, ra, 0.0), (ob, m6, m7, rb, 1.0)] {
            let h = m_dot * m_dot - m_len + r * r;
            if h < 0.0 || r <= 0.0 {
                continue;
            }
            for sign in [-1.0, 1.0] {
                let local = -m_dot + sign * h.sqrt();
                let y = m1 - ra * rr + local * m2;
                if (s == 0.0 && y <= 0.0) || (s == 1.0 && y >= d2) {
                    offer(local, ((o + local * rd) / r).normalize(), s);
                }
            }
        }
        best.map(|(_, hit)| hit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{vec3a, vec4};

    #[test]
    fn sphere_hits_near_and_far_side_with_outward_normals() {
        let ray = RoundRay::new(vec3a(0.0, 0.0, 10.0), vec3a(0.0, 0.0, -2.0));
        let s = vec4(0.0, 0.0, 0.0, 1.0);
        let near = ray.sphere(s, 0.0, f32::INFINITY).unwrap();
        assert!((near.t - 4.5).abs() < 1e-5 && (near.normal - Vec3A::Z).length() < 1e-5);
        let far = ray.sphere(s, 4.6, f32::INFINITY).unwrap();
        assert!((far.t - 5.5).abs() < 1e-5 && (far.normal + Vec3A::Z).length() < 1e-5);
        assert!(ray.sphere(s, 0.0, 4.0).is_none());
        let miss = RoundRay::new(vec3a(1.01, 0.0, 10.0), vec3a(0.0, 0.0, -1.0));
        assert!(miss.sphere(s, 0.0, f32::INFINITY).is_none());
    }

    /// A cylinder (equal radii) seen side on: hits at the analytic distance
    /// with the radial normal and the position along the axis; the caps are
    /// hemispheres past the ends; a ray from inside leaves through the far side.
    #[test]
    fn round_cone_body_caps_and_inside() {
        let (a, b) = (vec4(0.0, 0.0, 0.0, 0.5), vec4(2.0, 0.0, 0.0, 0.5));
        let side = RoundRay::new(vec3a(0.5, 0.3, 5.0), vec3a(0.0, 0.0, -1.0));
        let hit = side.round_cone(a, b, 0.0, f32::INFINITY).unwrap();
        let z = (0.25f32 - 0.09).sqrt();
        assert!((hit.t - (5.0 - z)).abs() < 1e-5, "{hit:?}");
        assert!((hit.s - 0.25).abs() < 1e-5);
        assert!((hit.normal - vec3a(0.0, 0.3, z) / 0.5).length() < 1e-5);
        let cap = RoundRay::new(vec3a(-0.3, 0.0, 5.0), vec3a(0.0, 0.0, -1.0));
        let hit = cap.round_cone(a, b, 0.0, f32::INFINITY).unwrap();
        assert!(
            (hit.t - (5.0 - 0.4)).abs() < 1e-5 && hit.s == 0.0,
            "{hit:?}"
        );
        let inside = RoundRay::new(vec3a(1.0, 0.0, 0.0), vec3a(0.0, 0.0, 1.0));
        let hit = inside.round_cone(a, b, 0.0, f32::INFINITY).unwrap();
        assert!((hit.t - 0.5).abs() < 1e-5, "{hit:?}");
        let along = RoundRay::new(vec3a(-5.0, 0.0, 0.0), vec3a(1.0, 0.0, 0.0));
        assert!((along.round_cone(a, b, 0.0, 100.0).unwrap().t - 4.5).abs() < 1e-5);
        let miss = RoundRay::new(vec3a(2.6, 0.0, 5.0), vec3a(0.0, 0.0, -1.0));
        assert!(miss.round_cone(a, b, 0.0, f32::INFINITY).is_none());
    }

    /// A cone from radius 1 to 0.25: a ray grazing just inside the
    /// silhouette hits, just outside misses; the normal is perpendicular to
    /// the lateral line, not to the axis.
    #[test]
    fn round_cone_tapers() {
        let (a, b) = (vec4(0.0, 0.0, 0.0, 1.0), vec4(4.0, 0.0, 0.0, 0.25));
        // Tangent line: the silhouette in the xy plane at x = 2.
        let (d, rr) = (4.0f32, 0.75f32);
        let (sin, cos) = (rr / d, (d * d - rr * rr).sqrt() / d);
        // Points on the lateral tangent line: pa + ra (sin, cos) + k (cos, -sin).
        let on = |k: f32| vec3a(sin + k * cos, cos - k * sin, 0.0);
        let p = on(2.0);
        for (scale, hits) in [(0.999, true), (1.001, false)] {
            let ray = RoundRay::new(vec3a(p.x, p.y * scale, 5.0), vec3a(0.0, 0.0, -1.0));
            assert_eq!(ray.round_cone(a, b, 0.0, 10.0).is_some(), hits, "{scale}");
        }
        let ray = RoundRay::new(vec3a(p.x, 5.0, 0.0), vec3a(0.0, -1.0, 0.0));
        let hit = ray.round_cone(a, b, 0.0, 10.0).unwrap();
        assert!(
            (hit.normal - vec3a(sin, cos, 0.0)).length() < 1e-4,
            "{hit:?}"
        );
    }
}
