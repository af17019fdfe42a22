//! Emissive meshes as lights: every placed mesh (instance x prototype mesh)
//! with triangles whose material emits is one light, its emissive triangles
//! kept in world space and sampled uniformly by area (a triangle by area,
//! then a point uniformly in it), as pbrt-v4's `DiffuseAreaLight` on
//! triangles.

use std::f32::consts::PI;

use glam::{Affine3A, Vec2, Vec3, Vec3A};

use super::bvh::{cone_union, LightBounds};
use super::LightSample;
use crate::color::luminance;
use crate::geometry::{MeshSite, SurfacePoint};
use crate::materials::Materials;
use crate::sampling::warp::{area_to_solid_angle, square_to_uniform_triangle};
use crate::sampling::Distribution1D;
use crate::scene::affine;
use crate::scene::Scene;

/// One placed mesh's emissive triangles, world space.
#[derive(Clone, Debug)]
pub(crate) struct MeshLight {
    /// Sorted by `index`.
    triangles: Vec<EmissiveTriangle>,
    /// Over `triangles`, by area.
    distribution: Distribution1D,
    /// Sum of the triangles' world areas, square scene units.
    area: f32,
    /// The mesh's `doubleSided`: both faces emit.
    double_sided: bool,
    /// Index of the mesh in the scene's meshes (for its primvars).
    mesh: u32,
    /// Index of the instance placing it (for the primvars the mesh lacks).
    instance: u32,
    /// Luminance of the emitted power (see [`MeshLight::power`]).
    power: f32,
    /// Box and normal cone of the emissive triangles, for the light BVH.
    bounds: LightBounds,
}

/// A triangle of a [`MeshLight`].
#[derive(Clone, Copy, Debug)]
struct EmissiveTriangle {
    /// Triangle index within the scene mesh.
    index: u32,
    /// First vertex, world space.
    p0: Vec3,
    /// Edges to the second and third vertices, world space.
    e1: Vec3,
    e2: Vec3,
    /// Unit normal of the front face (counter-clockwise in the mesh's own
    /// space, so a mirroring transform keeps the mesh's front).
    normal: Vec3,
    /// Texture coordinates of the three vertices (zero without `primvars:st`).
    uv: [Vec2; 3],
    /// Bound material.
    material: u32,
}

impl MeshLight {
    /// A point uniformly over the emissive area, as seen from `p`; `None`
    /// when it faces away (single-sided) or emits nothing there.
    pub fn sample(&self, materials: &Materials, p: Vec3, u: Vec2) -> Option<LightSample> {
        let pick = self.distribution.sample_discrete(u.x);
        let tri = &self.triangles[pick.index];
        let b = square_to_uniform_triangle(Vec2::new(pick.remapped, u.y));
        let point = tri.p0 + b.x * tri.e1 + b.y * tri.e2;
        let offset = point - p;
        let distance = offset.length();
        let wi = offset / distance;
        let cos_light = -wi.dot(tri.normal);
        if cos_light == 0.0 || !(self.double_sided || cos_light > 0.0) {
            return None;
        }
        let site = self.site(tri, b);
        let radiance = materials.emission(tri.material, &site);
        let pdf = area_to_solid_angle(1.0 / self.area, distance, cos_light);
        (radiance != Vec3::ZERO && pdf.is_finite()).then_some(LightSample {
            radiance,
            wi,
            distance,
            pdf,
            delta: false,
        })
    }

    /// Solid-angle density with which [`Self::sample`] picks `sp` from
    /// `origin`: 1/area converted to solid angle; 0 for a triangle that is
    /// not emissive or a back face of a single-sided mesh.
    pub fn pdf(&self, sp: &SurfacePoint, origin: Vec3) -> f32 {
        let Ok(i) = self
            .triangles
            .binary_search_by_key(&sp.triangle, |t| t.index)
        else {
            return 0.0;
        };
        let offset = sp.p - origin;
        let distance = offset.length();
        let cos_light = -offset.dot(self.triangles[i].normal) / distance;
        if !(self.double_sided || cos_light > 0.0) {
            return 0.0;
        }
        area_to_solid_angle(1.0 / self.area, distance, cos_light)
    }

    /// The point of `tri` with barycentric weights `b` (of its second and
    /// third vertices), for material lookups.
    fn site(&self, tri: &EmissiveTriangle, b: Vec2) -> MeshSite {
        MeshSite {
            mesh: self.mesh,
            instance: self.instance,
            triangle: tri.index,
            barycentrics: b,
            uv: (1.0 - b.x - b.y) * tri.uv[0] + b.x * tri.uv[1] + b.y * tri.uv[2],
        }
    }

    /// Where and how it emits, for the light BVH.
    pub fn bounds(&self) -> LightBounds {
        self.bounds
    }

    /// Luminance of the emitted power: pi x sum of area x emission at the
    /// triangle's centroid, doubled for a double-sided mesh.
    pub fn power(&self) -> f32 {
        self.power
    }

    /// The material of its first emissive triangle (every material of a
    /// mesh light's gprim carries that light's factors).
    pub fn material(&self) -> u32 {
        self.triangles[0].material
    }

    /// Index of the mesh in the scene's meshes.
    pub fn mesh(&self) -> u32 {
        self.mesh
    }

    /// One light per placed mesh with emissive triangles, with the
    /// (instance, prototype mesh) pair that names it in `SurfacePoint`.
    /// Zero-area triangles and placements are left out.
    pub fn build_all(scene: &Scene, materials: &Materials) -> Vec<((u32, u32), MeshLight)> {
        let m = &scene.manifest;
        // Which meshes have an emissive triangle at all: most scenes have none.
        let emissive_meshes: Vec<bool> = m
            .meshes
            .iter()
            .map(|mesh| {
                scene
                    .view(&mesh.triangle_materials)
                    .iter()
                    .any(|&mat| materials.is_emissive(mat))
            })
            .collect();
        warn_emissive_round_shapes(scene, materials);
        if !emissive_meshes.contains(&true) {
            return Vec::new();
        }
        let prototypes = scene.view(&m.instances.prototype);
        let transforms = scene.view(&m.instances.transform);
        let mut lights = Vec::new();
        for (instance, (world_from_prototype, &prototype)) in
            transforms.iter().zip(prototypes).enumerate()
        {
            for (part_index, part) in m.prototypes[prototype as usize].meshes.iter().enumerate() {
                if !emissive_meshes[part.mesh as usize] {
                    continue;
                }
                let world_from_mesh = affine(world_from_prototype) * affine(&part.transform);
                let ids = [instance as u32, part.mesh];
                if let Some(light) = Self::build(scene, materials, ids, world_from_mesh) {
                    lights.push(((instance as u32, part_index as u32), light));
                }
            }
        }
        lights
    }

    fn build(
        scene: &Scene,
        materials: &Materials,
        [instance, mesh_index]: [u32; 2],
        world_from_mesh: Affine3A,
    ) -> Option<Self> {
        let mesh = &scene.manifest.meshes[mesh_index as usize];
        let points = scene.view(&mesh.points);
        let uvs = mesh.uvs.as_ref().map(|uvs| scene.view(uvs));
        let flip = if world_from_mesh.matrix3.determinant() < 0.0 {
            -1.0
        } else {
            1.0
        };
        let mut triangles = Vec::new();
        let mut areas = Vec::new();
        let mut power = 0.0f64;
        let tri_materials = scene.view(&mesh.triangle_materials);
        for (index, (&[a, b, c], &material)) in scene
            .view(&mesh.triangles)
            .iter()
            .zip(tri_materials)
            .enumerate()
        {
            if !materials.is_emissive(material) {
                continue;
            }
            let world = |i: u32| {
                Vec3::from(world_from_mesh.transform_point3a(Vec3A::from_array(points[i as usize])))
            };
            let p0 = world(a);
            let (e1, e2) = (world(b) - p0, world(c) - p0);
            let cross = e1.cross(e2);
            let area = 0.5 * cross.length();
            if !(area > 0.0 && area.is_finite()) {
                continue;
            }
            let uv = match uvs {
                Some(uvs) => [a, b, c].map(|i| Vec2::from(uvs[i as usize])),
                None => [Vec2::ZERO; 3],
            };
            let centroid = MeshSite {
                mesh: mesh_index,
                instance,
                triangle: index as u32,
                barycentrics: Vec2::splat(1.0 / 3.0),
                uv: (uv[0] + uv[1] + uv[2]) / 3.0,
            };
            power += f64::from(area * luminance(materials.emission(material, &centroid)));
            triangles.push(EmissiveTriangle {
                index: index as u32,
                p0,
                e1,
                e2,
                normal: flip * cross / (2.0 * area),
                uv,
                material,
            });
            areas.push(area);
        }
        if triangles.is_empty() {
            return None;
        }
        let sides = if mesh.double_sided { 2.0 } else { 1.0 };
        let power = PI * sides * power as f32;
        let mut bounds = LightBounds {
            min: Vec3::INFINITY,
            max: Vec3::NEG_INFINITY,
            phi: power,
            w: triangles[0].normal,
            cos_o: 1.0,
            cos_e: 0.0,
            two_sided: mesh.double_sided,
        };
        for t in &triangles {
            for v in [t.p0, t.p0 + t.e1, t.p0 + t.e2] {
                bounds.min = bounds.min.min(v);
                bounds.max = bounds.max.max(v);
            }
            (bounds.w, bounds.cos_o) = cone_union((bounds.w, bounds.cos_o), (t.normal, 1.0));
        }
        Some(Self {
            distribution: Distribution1D::new(&areas),
            area: areas.iter().map(|&a| f64::from(a)).sum::<f64>() as f32,
            triangles,
            double_sided: mesh.double_sided,
            mesh: mesh_index,
            instance,
            power,
            bounds,
        })
    }
}

/// Points and curves prims are not light-sampled: an emissive one lights
/// the scene only where paths hit it (unbiased, but noisy). One warning
/// names them all.
fn warn_emissive_round_shapes(scene: &Scene, materials: &Materials) {
    let m = &scene.manifest;
    let points = m.points.iter().map(|p| (&p.path, p.material));
    let curves = m.curves.iter().map(|c| (&c.path, c.material));
    let emissive: Vec<&str> = points
        .chain(curves)
        .filter(|&(_, material)| materials.is_emissive(material))
        .map(|(path, _)| path.as_str())
        .collect();
    if !emissive.is_empty() {
        log::warn!(
            "{}: emissive points or curves are not light-sampled; they light the scene only where paths hit them (noisier)",
            emissive.join(", ")
        );
    }
}
