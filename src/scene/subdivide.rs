//! Subdivision at load: every mesh with a `subdivision` record is refined
//! once (instances share it) by `crate::subdivision`, and its arrays in the
//! [`Manifest`] are replaced by the refined triangles appended to the blob,
//! so geometry, lights, `cirrus info` and the memory estimate all see the
//! refined surface. A cage OpenSubdiv refuses keeps its triangulated cage,
//! with one warning naming the mesh.

use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;

use super::format::{Manifest, Mesh, Subdivision, NO_MATERIAL};
use super::load::{Blob, SceneError};
use crate::subdivision::{self, Cage, Channel, RefinedMesh, Surface, MAX_LEVEL};

/// How meshes with a subdivision record are loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refinement {
    /// Refined to this level, unless the mesh names its own
    /// (`primvars:cirrus:subdivisionLevel`); `--subdiv-level`.
    Level(u32),
    /// Left as their triangulated cages (faceted, as before subdivision
    /// existed): the "before" of benchmarks.
    Cages,
}

impl Default for Refinement {
    fn default() -> Self {
        Self::Level(subdivision::DEFAULT_LEVEL)
    }
}

/// What refinement did to a scene, for `cirrus info` and the benchmarks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SubdivisionSummary {
    /// Meshes with a subdivision record.
    pub cages: usize,
    /// Of those, meshes refined.
    pub refined: usize,
    /// Their triangles before refinement (the triangulated cages).
    pub cage_triangles: u64,
    /// Their triangles after (the cages' where refinement was refused).
    pub triangles: u64,
    /// Wall-clock seconds refining, in parallel over meshes.
    pub seconds: f64,
    /// One line per mesh that fell back to its cage, naming it.
    pub warnings: Vec<String>,
}

impl std::fmt::Display for SubdivisionSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} of {} cage(s) refined: {} cage triangles -> {} triangles ({:.2} s)",
            self.refined, self.cages, self.cage_triangles, self.triangles, self.seconds
        )
    }
}

/// Refines the subdivision meshes of `manifest` as `refinement` asks,
/// appending their arrays to `blob`; refuses a level above [`MAX_LEVEL`]
/// (with the triangle count it would make) before refining anything.
pub(super) fn refine(
    path: &Path,
    manifest: &mut Manifest,
    blob: &mut Blob,
    refinement: Refinement,
) -> Result<SubdivisionSummary, SceneError> {
    let cages: Vec<usize> = (0..manifest.meshes.len())
        .filter(|&i| manifest.meshes[i].subdivision.is_some())
        .collect();
    let mut summary = SubdivisionSummary {
        cages: cages.len(),
        cage_triangles: cages
            .iter()
            .map(|&i| manifest.meshes[i].triangles.count)
            .sum(),
        ..SubdivisionSummary::default()
    };
    summary.triangles = summary.cage_triangles;
    let Refinement::Level(default) = refinement else {
        return Ok(summary);
    };
    let level_of = |mesh: &Mesh| {
        mesh.subdivision
            .as_ref()
            .and_then(|s| s.level)
            .unwrap_or(default)
    };
    let estimate: u64 = cages
        .iter()
        .map(|&i| {
            let mesh = &manifest.meshes[i];
            let cage = mesh.subdivision.as_ref().expect("a cage");
            subdivision::triangles_at(cage.scheme, blob.view(&cage.face_counts), level_of(mesh))
        })
        .fold(0, u64::saturating_add);
    if let Some(&i) = cages
        .iter()
        .find(|&&i| level_of(&manifest.meshes[i]) > MAX_LEVEL)
    {
        let mesh = &manifest.meshes[i];
        let authored = mesh.subdivision.as_ref().and_then(|s| s.level).is_some();
        return Err(SceneError::SubdivisionLevel {
            path: path.to_owned(),
            level: level_of(mesh),
            from: if authored {
                format!("primvars:cirrus:subdivisionLevel of {}", mesh.path)
            } else {
                "--subdiv-level".to_owned()
            },
            triangles: estimate,
        });
    }
    let start = Instant::now();
    let refined: Vec<_> = cages
        .par_iter()
        .map(|&i| {
            let mesh = &manifest.meshes[i];
            let frame = refine_mesh(blob, mesh, blob.view(&mesh.points), level_of(mesh))?;
            let keys = refine_keys(blob, mesh, level_of(mesh))?;
            Ok::<_, subdivision::SubdivisionError>((frame, keys))
        })
        .collect();
    for (&i, result) in cages.iter().zip(refined) {
        let mesh = &mut manifest.meshes[i];
        match result {
            Ok((refined, keys)) => {
                summary.refined += 1;
                summary.triangles += refined.triangles.len() as u64;
                summary.triangles -= mesh.triangles.count;
                store(blob, mesh, refined);
                store_keys(blob, mesh, keys);
            }
            Err(error) => {
                let warning = format!(
                    "mesh {}: not refined, rendered as its polygons: {error}",
                    mesh.path
                );
                log::warn!("{warning}");
                summary.warnings.push(warning);
            }
        }
    }
    summary.seconds = start.elapsed().as_secs_f64();
    Ok(summary)
}

/// A deforming cage's keys (`motion.points`, key-major), each refined like
/// the frame: the same topology with that key's points, so the refined
/// vertices correspond key to key and lerp between keys as the cage's do
/// (up to the limit surface's own non-linearity, which key spacing bounds).
/// Empty for a mesh that does not deform.
fn refine_keys(
    blob: &Blob,
    mesh: &Mesh,
    level: u32,
) -> Result<Vec<RefinedMesh>, subdivision::SubdivisionError> {
    let Some(motion) = &mesh.motion else {
        return Ok(Vec::new());
    };
    let n = mesh.points.count as usize;
    blob.view(&motion.points)
        .chunks_exact(n)
        .map(|key| refine_mesh(blob, mesh, key, level))
        .collect()
}

/// Replaces a deforming mesh's keys by its refined `keys`' points and
/// normals, appended to `blob` (nothing for a mesh that does not deform).
fn store_keys(blob: &mut Blob, mesh: &mut Mesh, keys: Vec<RefinedMesh>) {
    let Some(motion) = &mut mesh.motion else {
        return;
    };
    let points: Vec<[f32; 3]> = keys.iter().flat_map(|k| k.points.iter().copied()).collect();
    motion.points = blob.push(&points);
    motion.normals = mesh.normals.is_some().then(|| {
        let normals: Vec<[f32; 3]> = keys
            .iter()
            .flat_map(|k| k.normals.iter().flatten().copied())
            .collect();
        blob.push(&normals)
    });
}

/// One mesh's cage (from its record and its per-point arrays) refined with
/// the mesh's `points` (its own, or one key's).
fn refine_mesh(
    blob: &Blob,
    mesh: &Mesh,
    points: &[[f32; 3]],
    level: u32,
) -> Result<RefinedMesh, subdivision::SubdivisionError> {
    let cage = mesh.subdivision.as_ref().expect("a cage");
    let face_indices = blob.view(&cage.face_indices);
    let corner_points = blob.view(&cage.corner_points);
    // Welded: the mesh's points are the cage's vertices, per-point data is per vertex.
    let welded = corner_points == face_indices && points.len() == cage.vertex_count as usize;
    let positions: Vec<[f32; 3]> = if welded {
        points.to_vec()
    } else {
        let mut positions = vec![[0.0; 3]; cage.vertex_count as usize];
        for (&v, &p) in face_indices.iter().zip(corner_points) {
            positions[v as usize] = points[p as usize];
        }
        positions
    };
    let channels = per_point(blob, mesh)
        .into_iter()
        .map(|(width, values)| Channel {
            width,
            values,
            indices: (!welded).then_some(corner_points),
        })
        .collect();
    let cage = Cage {
        scheme: cage.scheme,
        boundary: cage.interpolate_boundary,
        face_varying: cage.face_varying_linear_interpolation,
        triangle_rule: cage.triangle_subdivision_rule,
        positions: &positions,
        face_counts: blob.view(&cage.face_counts),
        face_indices,
        crease_pairs: blob.view(&cage.crease_pairs),
        crease_sharpness: blob.view(&cage.crease_sharpness),
        corners: blob.view(&cage.corners),
        corner_sharpness: blob.view(&cage.corner_sharpness),
        holes: blob.view(&cage.holes),
        channels,
    };
    subdivision::refine(&cage, level, Surface::Limit)
}

/// The mesh's per-point primvars as (width, flat values), in the order
/// [`store`] writes them back: every per-point float array (UVs, then the
/// material primvars by name) but positions and normals (a subdivision surface's normals are its limit normals).
fn per_point<'a>(blob: &'a Blob, mesh: &Mesh) -> Vec<(usize, &'a [f32])> {
    let mut arrays = Vec::new();
    if let Some(uvs) = &mesh.uvs {
        arrays.push((2, bytemuck::cast_slice(blob.view(uvs))));
    }
    for primvar in mesh.primvars.values() {
        arrays.push((primvar.width as usize, blob.view(primvar)));
    }
    arrays
}

/// Replaces `mesh`'s arrays by `refined`'s, appended to `blob`.
fn store(blob: &mut Blob, mesh: &mut Mesh, refined: RefinedMesh) {
    let cage: &Subdivision = mesh.subdivision.as_ref().expect("a cage");
    let face_materials = blob.view(&cage.face_materials);
    let materials: Vec<u32> = refined
        .triangle_faces
        .iter()
        .map(|&f| {
            face_materials
                .get(f as usize)
                .copied()
                .unwrap_or(NO_MATERIAL)
        })
        .collect();
    let mut channels = refined.channels.into_iter();
    if mesh.uvs.is_some() {
        let uvs: Vec<[f32; 2]> = bytemuck::cast_slice(&channels.next().expect("uvs")).to_vec();
        mesh.uvs = Some(blob.push(&uvs));
    }
    for primvar in mesh.primvars.values_mut() {
        let width = primvar.width;
        let mut refined = blob.push(&channels.next().expect("a primvar"));
        refined.count /= u64::from(width);
        refined.width = width;
        *primvar = refined;
    }
    mesh.points = blob.push(&refined.points);
    mesh.triangles = blob.push(&refined.triangles);
    mesh.normals = refined.normals.as_deref().map(|n| blob.push(n));
    mesh.triangle_materials = blob.push(&materials);
}
