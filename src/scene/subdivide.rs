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
use crate::subdivision::{self, Cage, Channel, RefinedMesh, Scheme, Surface, MAX_LEVEL};

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
    /// How the cages were loaded: [`Refinement::Cages`] until they are refined.
    pub refinement: Refinement,
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

/// One subdivision mesh as refinement would make it, counted from its cage
/// before anything is refined (the memory preflight's input).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlannedMesh {
    /// Index into the manifest's meshes.
    pub mesh: usize,
    /// The mesh's prim path.
    pub path: String,
    /// The level it would be refined to.
    pub level: u32,
    /// True when that level is the mesh's own (`primvars:cirrus:subdivisionLevel`).
    pub authored: bool,
    /// Triangles it would make: exact, [`subdivision::triangles_at`].
    pub triangles: u64,
    /// Bytes of its refined arrays, an upper bound: 16 per triangle (indices,
    /// material) and, per point, 12 (position), 12 (limit normal, not for
    /// bilinear), 8 (UV) and 4 per primvar float. Points: half the
    /// triangles (a closed quad or Loop mesh has about that many), plus
    /// `2^level` per cage face corner for face-varying seams.
    pub bytes: u64,
}

/// What refining `manifest`'s subdivision meshes as `refinement` asks
/// would make, mesh by mesh, every level capped at `cap` when given;
/// refuses a level above [`MAX_LEVEL`] (with the triangle count it would
/// make). Refines nothing: [`Refinement::Cages`] plans nothing.
pub(super) fn plan(
    path: &Path,
    manifest: &Manifest,
    blob: &Blob,
    refinement: Refinement,
    cap: Option<u32>,
) -> Result<Vec<PlannedMesh>, SceneError> {
    let Refinement::Level(default) = refinement else {
        return Ok(Vec::new());
    };
    let planned: Vec<PlannedMesh> = (manifest.meshes.iter().enumerate())
        .filter_map(|(i, mesh)| Some((i, mesh, mesh.subdivision.as_ref()?)))
        .map(|(i, mesh, cage)| {
            let level = cage.level.unwrap_or(default).min(cap.unwrap_or(u32::MAX));
            let face_counts = blob.view(&cage.face_counts);
            let triangles = subdivision::triangles_at(cage.scheme, face_counts, level);
            let seams = (cage.face_indices.count).saturating_mul(1 << level.min(MAX_LEVEL + 1));
            let points = (triangles / 2).saturating_add(seams);
            let normals = if cage.scheme == Scheme::Bilinear {
                0
            } else {
                12
            };
            let uvs = if mesh.uvs.is_some() { 8 } else { 0 };
            let floats: u64 = mesh.primvars.values().map(|p| u64::from(p.width)).sum();
            let per_point = 12 + normals + uvs + 4 * floats;
            PlannedMesh {
                mesh: i,
                path: mesh.path.clone(),
                level,
                authored: cage.level.is_some(),
                triangles,
                bytes: triangles
                    .saturating_mul(16)
                    .saturating_add(points.saturating_mul(per_point)),
            }
        })
        .collect();
    if let Some(too_deep) = planned.iter().find(|p| p.level > MAX_LEVEL) {
        return Err(SceneError::SubdivisionLevel {
            path: path.to_owned(),
            level: too_deep.level,
            from: if too_deep.authored {
                format!("primvars:cirrus:subdivisionLevel of {}", too_deep.path)
            } else {
                "--subdiv-level".to_owned()
            },
            triangles: planned
                .iter()
                .map(|p| p.triangles)
                .fold(0, u64::saturating_add),
        });
    }
    Ok(planned)
}

/// The summary of `manifest`'s cages loaded as `refinement` asks, before
/// any is refined.
pub(super) fn cages(manifest: &Manifest, refinement: Refinement) -> SubdivisionSummary {
    let cages = manifest.meshes.iter().filter(|m| m.subdivision.is_some());
    let cage_triangles = cages.clone().map(|m| m.triangles.count).sum();
    SubdivisionSummary {
        refinement,
        cages: cages.count(),
        cage_triangles,
        triangles: cage_triangles,
        ..SubdivisionSummary::default()
    }
}

/// Refines the subdivision meshes of `manifest` as `refinement` asks,
/// appending their arrays to `blob`; refuses a level above [`MAX_LEVEL`]
/// before refining anything (see [`plan`]).
pub(super) fn refine(
    path: &Path,
    manifest: &mut Manifest,
    blob: &mut Blob,
    refinement: Refinement,
) -> Result<SubdivisionSummary, SceneError> {
    let planned = plan(path, manifest, blob, refinement, None)?;
    let mut summary = cages(manifest, refinement);
    let start = Instant::now();
    let refined: Vec<_> = planned
        .par_iter()
        .map(|p| {
            let mesh = &manifest.meshes[p.mesh];
            let frame = refine_mesh(blob, mesh, blob.view(&mesh.points), p.level)?;
            let keys = refine_keys(blob, mesh, p.level)?;
            Ok::<_, subdivision::SubdivisionError>((frame, keys))
        })
        .collect();
    for (p, result) in planned.iter().zip(refined) {
        let mesh = &mut manifest.meshes[p.mesh];
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
