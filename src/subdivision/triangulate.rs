//! Refined faces to triangles: quads (and level-0 polygons) fanned, vertices
//! split where a face-varying primvar has a seam, normals normalised.

use std::collections::HashMap;

use glam::Vec3;

use super::osd::Faces;
use super::{Cage, RefinedMesh};

/// `faces` as a [`RefinedMesh`]. Without face-varying channels the refined
/// vertices are the points; with them, each distinct (vertex, value indices)
/// combination of a face corner is one point, so seams stay sharp.
pub(super) fn triangles(cage: &Cage, faces: Faces) -> RefinedMesh {
    let fvar: Vec<usize> = (0..cage.channels.len())
        .filter(|&c| cage.channels[c].indices.is_some())
        .collect();
    let points = Points::split(&faces, &fvar);
    let (triangles, triangle_faces) = fan(&faces, &points.of_corner);
    let normals = faces.normals.as_ref().map(|limit| {
        let fallback = vertex_normals(&faces);
        points
            .vertex
            .iter()
            .map(|&v| {
                let n = Vec3::from(limit[v as usize]).normalize_or_zero();
                if n == Vec3::ZERO {
                    fallback[v as usize]
                } else {
                    n
                }
                .to_array()
            })
            .collect()
    });
    let channels = cage
        .channels
        .iter()
        .zip(&faces.channels)
        .enumerate()
        .map(|(c, (channel, (values, _)))| {
            let w = channel.width;
            let k = fvar.iter().position(|&f| f == c);
            (0..points.vertex.len())
                .flat_map(|p| {
                    let i = match k {
                        Some(k) => points.values[p * fvar.len() + k],
                        None => points.vertex[p],
                    } as usize;
                    values[i * w..][..w].iter().copied()
                })
                .collect()
        })
        .collect();
    RefinedMesh {
        points: points
            .vertex
            .iter()
            .map(|&v| faces.positions[v as usize])
            .collect(),
        normals,
        triangles,
        triangle_faces,
        channels,
    }
}

/// The output points of the refined face corners.
struct Points {
    /// Per face corner, its point.
    of_corner: Vec<u32>,
    /// Per point, its refined vertex.
    vertex: Vec<u32>,
    /// Per point, its value index in each face-varying channel (stride: their number).
    values: Vec<u32>,
}

impl Points {
    /// One point per distinct (vertex, face-varying value indices) of the
    /// corners, numbered in corner order (without face-varying channels, in
    /// vertex order, skipping the vertices no corner uses: a hole's). Keys are combined one channel at a
    /// time through a table indexed by value (OpenSubdiv gives each refined
    /// value one vertex, so a hash map is only the fallback), never hashing
    /// a key per corner: the chess set has 25 million corners.
    fn split(faces: &Faces, fvar: &[usize]) -> Self {
        let mut of_corner = faces.vertices.clone();
        for &c in fvar {
            let (values, indices) = &faces.channels[c];
            of_corner = combine(&of_corner, indices, values.len());
        }
        let n = of_corner.iter().max().map_or(0, |&m| m as usize + 1);
        let mut vertex = vec![u32::MAX; n];
        let mut values = vec![0; n * fvar.len()];
        for (corner, &p) in of_corner.iter().enumerate() {
            let p = p as usize;
            if vertex[p] == u32::MAX {
                vertex[p] = faces.vertices[corner];
                for (k, &c) in fvar.iter().enumerate() {
                    values[p * fvar.len() + k] = faces.channels[c].1[corner];
                }
            }
        }
        // Vertices of hole faces alone are no corner's: number them out,
        // keeping the order of the rest.
        let used: Vec<usize> = (0..n).filter(|&p| vertex[p] != u32::MAX).collect();
        if used.len() < n {
            let mut renumbered = vec![u32::MAX; n];
            for (new, &p) in used.iter().enumerate() {
                renumbered[p] = new as u32;
            }
            of_corner
                .iter_mut()
                .for_each(|p| *p = renumbered[*p as usize]);
            values = used
                .iter()
                .flat_map(|&p| values[p * fvar.len()..][..fvar.len()].iter().copied())
                .collect();
            vertex = used.iter().map(|&p| vertex[p]).collect();
        }
        Self {
            of_corner,
            vertex,
            values,
        }
    }
}

/// Ids numbering the distinct pairs (`a[i]`, `b[i]`) in order of first
/// appearance; `b` values are below `b_len`.
fn combine(a: &[u32], b: &[u32], b_len: usize) -> Vec<u32> {
    let mut first = vec![(u32::MAX, 0u32); b_len];
    let mut others: HashMap<(u32, u32), u32> = HashMap::new();
    let mut next = 0u32;
    let mut new_id = || {
        next += 1;
        next - 1
    };
    a.iter()
        .zip(b)
        .map(|(&a, &b)| match first[b as usize] {
            (u32::MAX, _) => {
                let id = new_id();
                first[b as usize] = (a, id);
                id
            }
            (seen, id) if seen == a => id,
            _ => *others.entry((a, b)).or_insert_with(&mut new_id),
        })
        .collect()
}

/// Each face fanned from its first corner into triangles of points, with
/// the cage face of each triangle.
fn fan(faces: &Faces, corner_points: &[u32]) -> (Vec<[u32; 3]>, Vec<u32>) {
    let mut triangles = Vec::with_capacity(faces.vertices.len());
    let mut bases = Vec::with_capacity(faces.vertices.len());
    let mut start = 0;
    for (&count, &base) in faces.counts.iter().zip(&faces.base_faces) {
        let corners = &corner_points[start..start + count as usize];
        for k in 1..corners.len().saturating_sub(1) {
            triangles.push([corners[0], corners[k], corners[k + 1]]);
            bases.push(base);
        }
        start += count as usize;
    }
    (triangles, bases)
}

/// Area-weighted normals of the refined faces around each vertex: where the
/// limit tangents degenerate (a collapsed cage edge), the normal still faces out.
fn vertex_normals(faces: &Faces) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; faces.positions.len()];
    let mut start = 0;
    for &count in &faces.counts {
        let face = &faces.vertices[start..start + count as usize];
        let p = |i: usize| Vec3::from(faces.positions[face[i] as usize]);
        let area: Vec3 = (1..face.len().saturating_sub(1))
            .map(|k| (p(k) - p(0)).cross(p(k + 1) - p(0)))
            .sum();
        face.iter().for_each(|&v| normals[v as usize] += area);
        start += count as usize;
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}
