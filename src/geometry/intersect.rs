//! Watertight ray-triangle intersection (Woop, Benthin and Wald 2013,
//! "Watertight Ray/Triangle Intersection", JCGT 2(1)): the triangle is sheared
//! into a space where the ray runs along +z from the origin, and the 2D edge
//! functions decide inside/outside. Edge functions that round to exactly zero
//! are recomputed in double precision, so a ray through an edge or vertex
//! shared by two triangles hits at least one of them, never neither.

use glam::{DVec2, Vec2, Vec3A};

/// A ray prepared for the watertight test: the axis permutation and shear,
/// computed once per ray and reused for every triangle it meets.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3A,
    /// Axis indices: `kz` is the ray's largest direction component.
    kx: usize,
    ky: usize,
    kz: usize,
    /// Shear constants: `d[kx]/d[kz]`, `d[ky]/d[kz]`, `1/d[kz]`.
    sx: f32,
    sy: f32,
    sz: f32,
}

/// Where a ray meets a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter: the hit is at `origin + t * direction`.
    pub t: f32,
    /// Weights of the triangle's second and third vertices; the first's is
    /// `1 - x - y`.
    pub barycentrics: Vec2,
}

impl WatertightRay {
    /// Prepares a ray; `direction` need not be normalized but must be non-zero.
    pub fn new(origin: Vec3A, direction: Vec3A) -> Self {
        let kz = direction.abs().max_position();
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Swapping keeps the winding, so the sign of the edge functions means
        // the same thing whichever way the ray points along kz.
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self {
            origin,
            kx,
            ky,
            kz,
            sx: direction[kx] / direction[kz],
            sy: direction[ky] / direction[kz],
            sz: 1.0 / direction[kz],
        }
    }

    /// The hit on triangle `(v0, v1, v2)` with `t_min < t < t_max`, from either side.
    #[inline]
    pub fn intersect(
        &self,
        v0: Vec3A,
        v1: Vec3A,
        v2: Vec3A,
        t_min: f32,
        t_max: f32,
    ) -> Option<TriangleHit> {
        let (a, b, c) = (v0 - self.origin, v1 - self.origin, v2 - self.origin);
        // Vertices in the sheared 2D space where the ray is the origin.
        let shear = |p: Vec3A| {
            Vec2::new(
                p[self.kx] - self.sx * p[self.kz],
                p[self.ky] - self.sy * p[self.kz],
            )
        };
        let (a2, b2, c2) = (shear(a), shear(b), shear(c));
        let mut u = c2.x * b2.y - c2.y * b2.x;
        let mut v = a2.x * c2.y - a2.y * c2.x;
        let mut w = b2.x * a2.y - b2.y * a2.x;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let (a2, b2, c2) = (a2.as_dvec2(), b2.as_dvec2(), c2.as_dvec2());
            let edge = |p: DVec2, q: DVec2| (p.x * q.y - p.y * q.x) as f32;
            u = edge(c2, b2);
            v = edge(a2, c2);
            w = edge(b2, a2);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let t_scaled = self.sz * (u * a[self.kz] + v * b[self.kz] + w * c[self.kz]);
        let t = t_scaled / det;
        (t > t_min && t < t_max).then(|| TriangleHit {
            t,
            barycentrics: Vec2::new(v, w) / det,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::vec3a;

    const V0: Vec3A = vec3a(0.0, 0.0, 0.0);
    const V1: Vec3A = vec3a(1.0, 0.0, 0.0);
    const V2: Vec3A = vec3a(0.0, 1.0, 0.0);

    #[test]
    fn hit_point_and_barycentrics_match_analytic() {
        let ray = WatertightRay::new(vec3a(0.25, 0.5, 2.0), vec3a(0.0, 0.0, -0.5));
        let hit = ray.intersect(V0, V1, V2, 0.0, f32::INFINITY).unwrap();
        assert_eq!(hit.t, 4.0);
        assert_eq!(hit.barycentrics, Vec2::new(0.25, 0.5));
        // Back face, behind the origin, beyond t_max.
        let up = WatertightRay::new(vec3a(0.25, 0.5, -1.0), vec3a(0.0, 0.0, 1.0));
        assert_eq!(up.intersect(V0, V1, V2, 0.0, 10.0).unwrap().t, 1.0);
        assert!(up.intersect(V0, V1, V2, 0.0, 0.5).is_none());
        assert!(ray.intersect(V0, V1, V2, 5.0, 10.0).is_none());
        // Outside the triangle.
        let miss = WatertightRay::new(vec3a(0.75, 0.75, 1.0), vec3a(0.0, 0.0, -1.0));
        assert!(miss.intersect(V0, V1, V2, 0.0, f32::INFINITY).is_none());
    }
}
