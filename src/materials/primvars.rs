//! Mesh primvars as material inputs and primvar AOVs read them: the names
//! material inputs name and every other name a mesh carries (the exporter
//! writes those primvar RenderVars ask for), each given a small id once at
//! build time, and per mesh the arrays of those it has (one element of 1 to
//! 4 floats per point), interpolated barycentrically at a hit like `uvs`;
//! and per instance the values its PointInstancer or instance root gave it
//! ([`InstancePrimvars`]), read where the mesh lacks the primvar.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3, Vec4};

use crate::scene::{Array, Scene};

/// The primvar names material inputs read, in the order first met: a
/// name's position is its id.
#[derive(Debug, Default)]
pub(crate) struct PrimvarNames {
    names: Vec<String>,
}

impl PrimvarNames {
    /// The id of `name`, given one if it has none yet.
    pub(crate) fn id(&mut self, name: &str) -> u32 {
        let at = match self.names.iter().position(|n| n == name) {
            Some(at) => at,
            None => {
                self.names.push(name.to_owned());
                self.names.len() - 1
            }
        };
        at as u32
    }

    /// The id of `name`, if it has one.
    pub(crate) fn find(&self, name: &str) -> Option<u32> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|at| at as u32)
    }

    /// Gives an id to every primvar a mesh, points or curves prim of
    /// `scene` carries: those no material reads are there for AOVs.
    pub(crate) fn add_carried(&mut self, scene: &Scene) {
        let m = &scene.manifest;
        let meshes = m.meshes.iter().map(|x| &x.primvars);
        let points = m.points.iter().map(|x| &x.primvars);
        let curves = m.curves.iter().map(|x| &x.primvars);
        for primvars in meshes.chain(points).chain(curves) {
            for name in primvars.keys() {
                self.id(name);
            }
        }
        for name in m.instances.primvars.keys() {
            self.id(name);
        }
    }
}

/// Primvar values per instance (`Instances::primvars`), by id: what a
/// mesh without the primvar reads at a hit on that instance, as USD's
/// primvar inheritance makes an instancer's (or an ancestor's) primvar
/// visible to the prims below it that do not author their own.
#[derive(Debug, Default)]
pub(crate) struct InstancePrimvars {
    /// By primvar id: runs sorted by their first instance, not overlapping.
    by_id: Vec<Vec<InstanceRun>>,
}

/// One primvar's values for consecutive instances from `first`.
#[derive(Debug)]
struct InstanceRun {
    first: u32,
    array: PrimvarArray,
}

/// For lookups that have no instance values (textures-only lookups).
pub(crate) static NO_INSTANCE_PRIMVARS: InstancePrimvars = InstancePrimvars { by_id: Vec::new() };

impl InstancePrimvars {
    /// The scene's per-instance primvars among `names` (runs validated by
    /// the scene loader: increasing, inside the instances, width 1 to 4).
    pub(crate) fn build(scene: &Scene, names: &PrimvarNames) -> Self {
        let mut by_id: Vec<Vec<InstanceRun>> = Vec::new();
        for (name, runs) in &scene.manifest.instances.primvars {
            let Some(id) = names.find(name) else {
                continue;
            };
            let id = id as usize;
            if by_id.len() <= id {
                by_id.resize_with(id + 1, Vec::new);
            }
            by_id[id] = runs
                .iter()
                .map(|run| InstanceRun {
                    first: run.first as u32,
                    array: PrimvarArray {
                        width: run.values.width as usize,
                        values: scene.view(&run.values).to_vec(),
                    },
                })
                .collect();
        }
        Self { by_id }
    }

    /// Runs of `(first instance, width, values)` by primvar id.
    #[cfg(test)]
    pub(crate) fn from_runs(by_id: Vec<Vec<(u32, usize, Vec<f32>)>>) -> Self {
        let run = |(first, width, values)| InstanceRun {
            first,
            array: PrimvarArray { width, values },
        };
        Self {
            by_id: by_id
                .into_iter()
                .map(|runs| runs.into_iter().map(run).collect())
                .collect(),
        }
    }

    /// Primvar `id` of `instance` as rgba (as [`MeshPrimvars::eval`]);
    /// `None` when that instance has no value for it.
    pub(crate) fn eval(&self, id: u32, instance: u32) -> Option<Vec4> {
        let runs = self.by_id.get(id as usize)?;
        let run = &runs[runs
            .partition_point(|r| r.first <= instance)
            .checked_sub(1)?];
        let array = &run.array;
        let at = (instance - run.first) as usize * array.width;
        let element = array.values.get(at..at + array.width)?;
        Some(rgba(array.width, |k| element[k]))
    }
}

/// An element of `width` components as rgba: width 1 grey (v, v, v, 1),
/// width 2 (x, y, 0, 1), width 3 (x, y, z, 1).
fn rgba(width: usize, component: impl Fn(usize) -> f32) -> Vec4 {
    match width {
        1 => Vec3::splat(component(0)).extend(1.0),
        2 => Vec4::new(component(0), component(1), 0.0, 1.0),
        3 => Vec4::new(component(0), component(1), component(2), 1.0),
        _ => Vec4::new(component(0), component(1), component(2), component(3)),
    }
}

/// One mesh's primvars that material inputs read, by id (empty for a mesh
/// with none of them, the usual case: then it keeps no triangles either).
#[derive(Debug, Default)]
pub(crate) struct MeshPrimvars {
    /// The mesh's triangles (indices into its points).
    triangles: Vec<[u32; 3]>,
    /// By primvar id; `None` where the mesh lacks that primvar.
    arrays: Vec<Option<PrimvarArray>>,
}

/// One primvar's values: `width` floats per point.
#[derive(Debug)]
struct PrimvarArray {
    width: usize,
    values: Vec<f32>,
}

impl MeshPrimvars {
    /// Every scene mesh's primvars among `names`, by scene mesh index, then
    /// every points prim's and every curves prim's (the geometry's object
    /// indices). A point is a triangle of three times its index; a curve
    /// piece from vertex v is (v, v + 1, v + 1), which the piece's hit
    /// weights (fraction along it, 0) interpolate linearly.
    pub(crate) fn build_all(scene: &Scene, names: &PrimvarNames) -> Vec<Self> {
        let m = &scene.manifest;
        let shape = |primvars: &BTreeMap<String, Array<f32>>, triangles: &dyn Fn() -> Vec<_>| {
            let arrays = names.names.iter().enumerate().filter_map(|(id, name)| {
                let array = primvars.get(name)?;
                let values = scene.view(array).to_vec();
                Some((id as u32, array.width as usize, values))
            });
            let arrays: Vec<_> = arrays.collect();
            if arrays.is_empty() {
                Self::default()
            } else {
                Self::new(triangles(), arrays.into_iter())
            }
        };
        let meshes = m
            .meshes
            .iter()
            .map(|mesh| shape(&mesh.primvars, &|| scene.view(&mesh.triangles).to_vec()));
        let points = m.points.iter().map(|p| {
            shape(&p.primvars, &|| {
                (0..p.points.count as u32).map(|i| [i; 3]).collect()
            })
        });
        let curves = m.curves.iter().map(|c| {
            let pieces = || {
                scene
                    .piece_starts(c)
                    .iter()
                    .map(|&v| [v, v + 1, v + 1])
                    .collect()
            };
            shape(&c.primvars, &pieces)
        });
        meshes.chain(points).chain(curves).collect()
    }

    /// A mesh of `triangles` with `(id, width, values)` primvars
    /// (validated by the scene loader: width 1 to 4, one element per point).
    pub(crate) fn new(
        triangles: Vec<[u32; 3]>,
        arrays: impl Iterator<Item = (u32, usize, Vec<f32>)>,
    ) -> Self {
        let mut by_id: Vec<Option<PrimvarArray>> = Vec::new();
        for (id, width, values) in arrays {
            let id = id as usize;
            if by_id.len() <= id {
                by_id.resize_with(id + 1, || None);
            }
            by_id[id] = Some(PrimvarArray { width, values });
        }
        Self {
            triangles,
            arrays: by_id,
        }
    }

    /// Primvar `id` on `triangle` at `barycentrics` (weights of its second
    /// and third vertices) as rgba: width 1 grey (v, v, v, 1), width 2
    /// (x, y, 0, 1), width 3 (x, y, z, 1); `None` when the mesh lacks it.
    pub(crate) fn eval(&self, id: u32, triangle: u32, barycentrics: Vec2) -> Option<Vec4> {
        let array = self.arrays.get(id as usize)?.as_ref()?;
        let w = Vec3::new(
            1.0 - barycentrics.x - barycentrics.y,
            barycentrics.x,
            barycentrics.y,
        );
        let [a, b, c] = self.triangles[triangle as usize].map(|i| i as usize * array.width);
        let v = &array.values;
        let component = |k: usize| v[a + k] * w.x + v[b + k] * w.y + v[c + k] * w.z;
        Some(rgba(array.width, component))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instance_values_are_read_from_their_run_and_absent_outside_runs() {
        // Primvar 1 on instances 2 and 3 (width 3) and 10 (width 1).
        let p = InstancePrimvars::from_runs(vec![
            Vec::new(),
            vec![
                (2, 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
                (10, 1, vec![0.5]),
            ],
        ]);
        assert_eq!(p.eval(1, 2), Some(Vec4::new(1.0, 2.0, 3.0, 1.0)));
        assert_eq!(p.eval(1, 3), Some(Vec4::new(4.0, 5.0, 6.0, 1.0)));
        assert_eq!(p.eval(1, 10), Some(Vec4::new(0.5, 0.5, 0.5, 1.0)));
        for instance in [0, 1, 4, 9, 11, u32::MAX] {
            assert_eq!(p.eval(1, instance), None, "instance {instance}");
        }
        assert_eq!(p.eval(0, 2), None);
        assert_eq!(p.eval(7, 2), None);
    }
}
