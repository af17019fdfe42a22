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
    // Per face corner, the point it becomes and, per point, its refined vertex
    // and the value index of each channel.
    let (corner_points, point_keys): (Vec<u32>, Vec<Vec<u32>>) = if fvar.is_empty() {
        let n = faces.positions.len() as u32;
        (faces.vertices.clone(), (0..n).map(|v| vec![v]).collect())
    } else {
        split_seams(&faces, &fvar)
    };
    let point_vertex = |p: usize| point_keys[p][0] as usize;
    let value_index = |c: usize, p: usize| match fvar.iter().position(|&f| f == c) {
        Some(k) => point_keys[p][k + 1] as usize,
        None => point_vertex(p),
    };
    let points: Vec<[f32; 3]> = (0..point_keys.len())
        .map(|p| faces.positions[point_vertex(p)])
        .collect();
    let (triangles, triangle_faces) = fan(&faces, &corner_points);
    let normals = faces.normals.as_ref().map(|limit| {
        let fallback = vertex_normals(&faces);
        (0..point_keys.len())
            .map(|p| {
                let v = point_vertex(p);
                let n = Vec3::from(limit[v]).normalize_or_zero();
                if n == Vec3::ZERO { fallback[v] } else { n }.to_array()
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
            (0..point_keys.len())
                .flat_map(|p| values[value_index(c, p) * w..][..w].iter().copied())
                .collect()
        })
        .collect();
    RefinedMesh {
        points,
        normals,
        triangles,
        triangle_faces,
        channels,
    }
}

/// Points for the distinct (vertex, face-varying value indices) keys of the
/// face corners: the point of each corner, and each point's key.
fn split_seams(faces: &Faces, fvar: &[usize]) -> (Vec<u32>, Vec<Vec<u32>>) {
    let mut ids: HashMap<Vec<u32>, u32> = HashMap::new();
    let mut keys = Vec::new();
    let corner_points = (0..faces.vertices.len())
        .map(|corner| {
            let key: Vec<u32> = std::iter::once(faces.vertices[corner])
                .chain(fvar.iter().map(|&c| faces.channels[c].1[corner]))
                .collect();
            *ids.entry(key).or_insert_with_key(|key| {
                keys.push(key.clone());
                keys.len() as u32 - 1
            })
        })
        .collect();
    (corner_points, keys)
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
