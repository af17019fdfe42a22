//! The OpenSubdiv wrapper: a [`Cage`] copied into the bridge's plain structs,
//! refined by `ffi/opensubdiv/shim.cc`, and its refined faces copied back.

#[path = "../../ffi/opensubdiv/bridge.rs"]
mod bridge;

use bridge::ffi;

use super::{Boundary, Cage, FaceVaryingLinear, Scheme, SubdivisionError, TriangleRule};

/// The finest level's faces (holes left out) and the data on their vertices.
pub(super) struct Faces {
    /// Limit positions per refined vertex, scene units.
    pub(super) positions: Vec<[f32; 3]>,
    /// Unnormalised limit normals per refined vertex (zero where the limit
    /// tangents degenerate); `None` off the limit surface (and for bilinear).
    pub(super) normals: Option<Vec<[f32; 3]>>,
    /// Vertices per face.
    pub(super) counts: Vec<u32>,
    /// Each face's vertices.
    pub(super) vertices: Vec<u32>,
    /// The cage face of each face.
    pub(super) base_faces: Vec<u32>,
    /// Per cage channel: refined values, and the value index of each entry of `vertices`.
    pub(super) channels: Vec<(Vec<f32>, Vec<u32>)>,
}

/// OpenSubdiv's uniform refinement of `cage` to `level`, positions and
/// normals on the limit surface when `limit` (and the scheme smooths).
pub(super) fn refine(cage: &Cage, level: u32, limit: bool) -> Result<Faces, SubdivisionError> {
    let cage = bridge_cage(cage);
    let refused = |e: cxx::Exception| SubdivisionError::Refused(e.what().to_owned());
    let mut refiner = ffi::create_refiner(&cage).map_err(refused)?;
    let refined = refiner
        .pin_mut()
        .refine(&cage, level, limit)
        .map_err(refused)?;
    let triples = |v: &[f32]| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok(Faces {
        positions: triples(&refined.positions),
        normals: (!refined.normals.is_empty()).then(|| triples(&refined.normals)),
        counts: refined.face_counts,
        vertices: refined.face_vertices,
        base_faces: refined.base_faces,
        channels: refined
            .channels
            .into_iter()
            .map(|c| (c.values, c.indices))
            .collect(),
    })
}

/// The cage as the bridge's `Cage`, tags as OpenSubdiv's enum values.
fn bridge_cage(cage: &Cage) -> ffi::Cage {
    ffi::Cage {
        scheme: match cage.scheme {
            Scheme::Bilinear => 0,
            Scheme::CatmullClark => 1,
            Scheme::Loop => 2,
        },
        boundary: match cage.boundary {
            Boundary::None => 0,
            Boundary::EdgeOnly => 1,
            Boundary::EdgeAndCorner => 2,
        },
        fvar_linear: match cage.face_varying {
            FaceVaryingLinear::None => 0,
            FaceVaryingLinear::CornersOnly => 1,
            FaceVaryingLinear::CornersPlus1 => 2,
            FaceVaryingLinear::CornersPlus2 => 3,
            FaceVaryingLinear::Boundaries => 4,
            FaceVaryingLinear::All => 5,
        },
        triangle_rule: match cage.triangle_rule {
            TriangleRule::CatmullClark => 0,
            TriangleRule::Smooth => 1,
        },
        vertex_count: cage.positions.len() as u32,
        positions: cage.positions.iter().flatten().copied().collect(),
        face_counts: cage.face_counts.to_vec(),
        face_indices: cage.face_indices.to_vec(),
        crease_pairs: cage.crease_pairs.to_vec(),
        crease_weights: cage.crease_sharpness.to_vec(),
        corner_vertices: cage.corners.to_vec(),
        corner_weights: cage.corner_sharpness.to_vec(),
        holes: cage.holes.to_vec(),
        channels: cage
            .channels
            .iter()
            .map(|c| ffi::CageChannel {
                width: c.width as u32,
                face_varying: c.indices.is_some(),
                values: c.values.to_vec(),
                indices: c.indices.map_or_else(Vec::new, <[u32]>::to_vec),
            })
            .collect(),
    }
}
