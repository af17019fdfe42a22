//! The names artists gave what the renderer draws, for Cryptomatte
//! (docs/conventions.md, "Cryptomatte names"): an object is an instance's
//! mesh named by the instance's own prim path (`/World/teapot_3/Geom`,
//! `/World/scatter[12]`, and inside a PointInstancer nested in another's
//! prototype `/World/outer[3]/inner[5]/Geom`), never by USD's
//! `/__Prototype_N`; its asset is the nearest `component` or `assembly`
//! model above it, else the object.
//!
//! Kept compact: per instance only its prototype and `source_index` (8
//! bytes); strings only per run of instances (`Instances::names`; a nested
//! instancer's indices once per run, not per copy) and per prototype part. Names are spelled in pieces, so hashing one allocates
//! nothing.

use super::format::NameRun;
use super::Scene;

/// How every placed mesh, points and curves prim of a scene is named.
pub struct InstanceNames {
    /// Per instance, its prototype.
    prototype: Vec<u32>,
    /// Per instance, its `source_index` (empty for files without names).
    source_index: Vec<u32>,
    /// The runs and the first instance of each; `None` for files written
    /// before names, whose objects are named by their mesh's path.
    runs: Option<(Vec<u64>, Vec<NameRun>)>,
    /// Per prototype, per mesh part.
    parts: Vec<Vec<PartName>>,
}

/// A prototype part's names.
struct PartName {
    /// Below the prototype root (`/Geom`), or, without runs, the whole name
    /// (the mesh's path).
    name: String,
    /// Its asset below the prototype root, when inside the prototype.
    asset: Option<String>,
}

impl InstanceNames {
    /// The names of `scene`'s placed meshes.
    pub fn new(scene: &Scene) -> Self {
        let m = &scene.manifest;
        let inst = &m.instances;
        let runs = inst.names.as_ref().map(|runs| {
            let starts = runs
                .iter()
                .scan(0u64, |first, run| {
                    let start = *first;
                    *first += run.count;
                    Some(start)
                })
                .collect();
            (starts, runs.clone())
        });
        let parts = m
            .prototypes
            .iter()
            .map(|p| {
                // In the order of `Hit::prototype_mesh`: meshes, points, curves.
                let meshes = p
                    .meshes
                    .iter()
                    .map(|x| (&x.names, &m.meshes[x.mesh as usize].path));
                let points = p
                    .points
                    .iter()
                    .map(|x| (&x.names, &m.points[x.points as usize].path));
                let curves = p
                    .curves
                    .iter()
                    .map(|x| (&x.names, &m.curves[x.curves as usize].path));
                meshes
                    .chain(points)
                    .chain(curves)
                    .map(|(names, path)| match (&runs, &names.name) {
                        (Some(_), Some(name)) => PartName {
                            name: name.clone(),
                            asset: names.asset.clone(),
                        },
                        _ => PartName {
                            name: path.clone(),
                            asset: None,
                        },
                    })
                    .collect()
            })
            .collect();
        let source_index = match runs {
            Some(_) => scene.view(&inst.source_index).to_vec(),
            None => Vec::new(),
        };
        Self {
            prototype: scene.view(&inst.prototype).to_vec(),
            source_index,
            runs,
            parts,
        }
    }

    /// Bytes the names of `instances` instances hold beside their strings:
    /// each one's prototype and `source_index`.
    pub fn bytes_for(instances: u64) -> u64 {
        8 * instances
    }

    /// Every placed mesh as (instance, part: an index into its prototype's
    /// meshes).
    pub fn placed(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.prototype.iter().enumerate().flat_map(|(i, &p)| {
            (0..self.parts[p as usize].len() as u32).map(move |part| (i as u32, part))
        })
    }

    /// Spells the object name of mesh `part` of `instance` into `out`.
    pub fn object(&self, instance: u32, part: u32, out: &mut dyn FnMut(&[u8])) {
        let name = self.part(instance, part);
        if let Some((run, index, position)) = self.run(instance) {
            run.root.spell(index, position, out);
        }
        out(name.name.as_bytes());
    }

    /// Spells the asset name of mesh `part` of `instance` into `out`: the
    /// nearest model inside the prototype, else above it, else the object
    /// name.
    pub fn asset(&self, instance: u32, part: u32, out: &mut dyn FnMut(&[u8])) {
        let name = self.part(instance, part);
        match (self.run(instance), &name.asset) {
            (Some((run, index, position)), Some(below_root)) => {
                run.root.spell(index, position, out);
                out(below_root.as_bytes());
            }
            (Some((run, index, position)), None) => match &run.asset {
                Some(asset) => asset.spell(index, position, out),
                None => self.object(instance, part, out),
            },
            (None, _) => self.object(instance, part, out),
        }
    }

    /// Whether `instance`'s asset is its object: no model above it.
    pub fn asset_is_object(&self, instance: u32, part: u32) -> bool {
        let asset_inside = self.part(instance, part).asset.is_some();
        self.run(instance)
            .is_none_or(|(run, ..)| !asset_inside && run.asset.is_none())
    }

    fn part(&self, instance: u32, part: u32) -> &PartName {
        &self.parts[self.prototype[instance as usize] as usize][part as usize]
    }

    /// `instance`'s run, `source_index` and position in the run; `None`
    /// without runs.
    fn run(&self, instance: u32) -> Option<(&NameRun, u32, u64)> {
        let (starts, runs) = self.runs.as_ref()?;
        let run = starts.partition_point(|&s| s <= u64::from(instance)) - 1;
        let position = u64::from(instance) - starts[run];
        Some((&runs[run], self.source_index[instance as usize], position))
    }
}
