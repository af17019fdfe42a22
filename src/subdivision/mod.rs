//! Subdivision surfaces through OpenSubdiv: a USD mesh's control cage refined
//! into ordinary triangles, with positions and normals on the limit surface
//! and primvars (texture coordinates among them) refined beside them.
//!
//! Schemes: Catmull-Clark (Catmull and Clark 1978, "Recursively generated
//! B-spline surfaces on arbitrary topological meshes"), Loop (Loop 1987,
//! "Smooth Subdivision Surfaces Based on Triangles") and bilinear (refined
//! without smoothing). Creases and corners follow DeRose, Kass and Truong 1998
//! ("Subdivision Surfaces in Character Animation"): semi-sharp edges of
//! sharpness s use the sharp rules for the first s levels. OpenSubdiv
//! implements all of them (`Far::TopologyRefiner`, `Far::PrimvarRefiner`,
//! <https://graphics.pixar.com/opensubdiv/docs/subdivision_surfaces.html>);
//! this module holds no subdivision rule of its own.
//!
//! One entry point, [`refine`]: a [`Cage`] (plain slices) at a level gives a
//! [`RefinedMesh`] (plain vectors). The level is uniform: each face of `n`
//! sides becomes `n` quads (Catmull-Clark, bilinear) at level 1 and each quad
//! four at every further level; Loop splits each triangle into four per
//! level. [`triangles_at`] counts the result without refining, so a level can
//! be refused before any memory is spent. Positions and normals are evaluated
//! on the limit surface at the finest vertices (`PrimvarRefiner::Limit`), so
//! the shading normals are the surface's own, not the facets'; primvars are
//! the refined values at the finest level.
//!
//! The module knows no scene format: `scene` builds the cage from its records
//! and stores the triangles back.

mod osd;
mod triangulate;

use serde::Deserialize;

/// Level used when neither the command line (`--subdiv-level`) nor the mesh
/// (`primvars:cirrus:subdivisionLevel`) names one.
pub const DEFAULT_LEVEL: u32 = 2;

/// Highest level refined: one more level multiplies the triangles by 4, and
/// level 8 already makes 131,072 triangles of every cage quad.
pub const MAX_LEVEL: u32 = 8;

/// USD's `subdivisionScheme` (of those that refine; `none` is never a cage).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum Scheme {
    /// Catmull-Clark: quads, any polygon (USD's default).
    CatmullClark,
    /// Loop: triangles only (OpenSubdiv refuses other faces).
    Loop,
    /// Bilinear: split like Catmull-Clark, without smoothing.
    Bilinear,
}

/// USD's `interpolateBoundary` (OpenSubdiv's `VtxBoundaryInterpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum Boundary {
    /// Boundary faces are not rendered smooth to the edge.
    None,
    /// Boundary edges are sharp.
    EdgeOnly,
    /// Boundary edges and corners are sharp (USD's default).
    EdgeAndCorner,
}

/// USD's `faceVaryingLinearInterpolation` (OpenSubdiv's `FVarLinearInterpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum FaceVaryingLinear {
    /// Smooth everywhere.
    None,
    /// Sharp corners only.
    CornersOnly,
    /// Sharp corners and junctions of 3 or more regions (USD's default).
    CornersPlus1,
    /// As `CornersPlus1`, also propagating corners.
    CornersPlus2,
    /// Sharp along every boundary.
    Boundaries,
    /// Linear everywhere.
    All,
}

/// USD's `triangleSubdivisionRule` (OpenSubdiv's `TriangleSubdivision`, Catmull-Clark only).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum TriangleRule {
    /// Catmull-Clark's own weights (USD's default).
    CatmullClark,
    /// Smoother weights on triangles.
    Smooth,
}

/// A control cage: topology, tags and the data refined over it.
#[derive(Clone, Debug)]
pub struct Cage<'a> {
    /// Which rules refine it.
    pub scheme: Scheme,
    /// Boundary rule.
    pub boundary: Boundary,
    /// How face-varying primvars are interpolated.
    pub face_varying: FaceVaryingLinear,
    /// Rule for triangles under Catmull-Clark.
    pub triangle_rule: TriangleRule,
    /// Vertex positions, scene units.
    pub positions: &'a [[f32; 3]],
    /// Vertices per face (`faceVertexCounts`).
    pub face_counts: &'a [u32],
    /// Each face's vertices in order, counter-clockwise seen from the front.
    pub face_indices: &'a [u32],
    /// Creased edges as vertex pairs, two entries per edge.
    pub crease_pairs: &'a [u32],
    /// Sharpness per creased edge (levels of sharp rules; 10 and above: infinitely sharp).
    pub crease_sharpness: &'a [f32],
    /// Sharp corner vertices.
    pub corners: &'a [u32],
    /// Sharpness per corner.
    pub corner_sharpness: &'a [f32],
    /// Faces that are holes: refined around, never rendered.
    pub holes: &'a [u32],
    /// Primvars refined with the surface.
    pub channels: Vec<Channel<'a>>,
}

/// One primvar over a cage: `width` floats per value.
#[derive(Clone, Debug)]
pub struct Channel<'a> {
    /// Floats per value.
    pub width: usize,
    /// The values, `width` floats each.
    pub values: &'a [f32],
    /// Face-varying: the value of each entry of `face_indices`. `None`: one
    /// value per vertex, refined with the vertex rules.
    pub indices: Option<&'a [u32]>,
}

/// A refined cage as triangles.
#[derive(Clone, Debug, Default)]
pub struct RefinedMesh {
    /// Positions on the limit surface (refined ones for bilinear), scene units.
    pub points: Vec<[f32; 3]>,
    /// Unit limit normals per point; `None` for bilinear (faceted, geometric
    /// normals) and off the limit surface.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Indices into `points`, counter-clockwise from the front.
    pub triangles: Vec<[u32; 3]>,
    /// The cage face each triangle comes from (for materials and GeomSubsets).
    pub triangle_faces: Vec<u32>,
    /// Per cage channel, in order: its values per point, `width` floats each.
    pub channels: Vec<Vec<f32>>,
}

/// Why a cage could not be refined.
#[derive(Debug, thiserror::Error)]
pub enum SubdivisionError {
    /// OpenSubdiv refused the topology or failed refining it; its messages.
    #[error("OpenSubdiv refused the cage: {0}")]
    Refused(String),
    /// An index or count of the cage that does not fit the rest.
    #[error("invalid cage: {0}")]
    Invalid(String),
}

/// Where [`refine`] puts the points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// On the limit surface, with limit normals: what renders.
    Limit,
    /// At the refined vertices of the level (the subdivision rules applied
    /// `level` times), without normals: what the rules' tests check.
    Refined,
}

/// The cage refined uniformly to `level` (at most [`MAX_LEVEL`]) as triangles.
pub fn refine(cage: &Cage, level: u32, surface: Surface) -> Result<RefinedMesh, SubdivisionError> {
    validate(cage)?;
    let faces = osd::refine(cage, level.min(MAX_LEVEL), surface == Surface::Limit)?;
    Ok(triangulate::triangles(cage, faces))
}

/// Triangles [`refine`] makes of faces of `face_counts` sides at `level`
/// (holes counted): exact, from the face counts alone.
pub fn triangles_at(scheme: Scheme, face_counts: &[u32], level: u32) -> u64 {
    let per_level = 4u64.saturating_pow(level.saturating_sub(1));
    face_counts
        .iter()
        .map(|&n| match (scheme, n, level) {
            (_, 0..=2, _) => 0,
            (_, n, 0) => u64::from(n) - 2,
            (Scheme::Loop, _, level) => 4u64.saturating_pow(level),
            (_, n, _) => 2 * u64::from(n) * per_level,
        })
        .fold(0, u64::saturating_add)
}

/// Checks every index of `cage` against what it indexes: OpenSubdiv trusts them.
fn validate(cage: &Cage) -> Result<(), SubdivisionError> {
    let invalid = |what: String| Err(SubdivisionError::Invalid(what));
    let corners: u64 = cage.face_counts.iter().map(|&n| u64::from(n)).sum();
    if corners != cage.face_indices.len() as u64 {
        return invalid(format!(
            "face counts sum to {corners}, but there are {} face indices",
            cage.face_indices.len()
        ));
    }
    let below = |name: &str, indices: &[u32], len: usize| match indices
        .iter()
        .find(|&&i| i as usize >= len)
    {
        Some(i) => invalid(format!("{name} holds {i}, not below {len}")),
        None => Ok(()),
    };
    if let Some(face) = cage.face_counts.iter().position(|&n| n < 3) {
        let n = cage.face_counts[face];
        return invalid(format!("face {face} has {n} vertices: a degenerate cage"));
    }
    let vertices = cage.positions.len();
    below("face indices", cage.face_indices, vertices)?;
    below("crease pairs", cage.crease_pairs, vertices)?;
    below("corners", cage.corners, vertices)?;
    below("holes", cage.holes, cage.face_counts.len())?;
    if cage.crease_pairs.len() != 2 * cage.crease_sharpness.len()
        || cage.corners.len() != cage.corner_sharpness.len()
    {
        return invalid("crease or corner sharpness counts do not match their edges".into());
    }
    for (c, channel) in cage.channels.iter().enumerate() {
        let values = channel.values.len() / channel.width.max(1);
        if channel.width == 0 || channel.values.len() % channel.width != 0 {
            return invalid(format!(
                "channel {c}: {} floats are not values of width {}",
                channel.values.len(),
                channel.width
            ));
        }
        match channel.indices {
            Some(indices) if indices.len() != cage.face_indices.len() => {
                return invalid(format!(
                    "channel {c}: {} indices for {} face corners",
                    indices.len(),
                    cage.face_indices.len()
                ))
            }
            Some(indices) => below(&format!("channel {c} indices"), indices, values)?,
            None if values != vertices => {
                return invalid(format!(
                    "channel {c}: {values} values for {vertices} vertices"
                ))
            }
            None => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// The unit cube [0,1]^3 as six quads, counter-clockwise from outside.
    const CUBE_POINTS: [[f32; 3]; 8] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    const CUBE_FACES: [u32; 24] = [
        0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7,
    ];
    /// The cube's 12 edges as vertex pairs.
    const CUBE_EDGES: [u32; 24] = [
        0, 1, 1, 2, 2, 3, 3, 0, 4, 5, 5, 6, 6, 7, 7, 4, 0, 4, 1, 5, 2, 6, 3, 7,
    ];

    fn cube(scheme: Scheme) -> Cage<'static> {
        Cage {
            scheme,
            boundary: Boundary::EdgeAndCorner,
            face_varying: FaceVaryingLinear::CornersPlus1,
            triangle_rule: TriangleRule::CatmullClark,
            positions: &CUBE_POINTS,
            face_counts: &[4; 6],
            face_indices: &CUBE_FACES,
            crease_pairs: &[],
            crease_sharpness: &[],
            corners: &[],
            corner_sharpness: &[],
            holes: &[],
            channels: Vec::new(),
        }
    }

    fn assert_near(got: [f32; 3], want: [f32; 3], what: &str) {
        let off = (Vec3::from(got) - Vec3::from(want)).abs().max_element();
        assert!(off < 1e-6, "{what}: {got:?}, expected {want:?}");
    }

    /// Sorted copies of `points`, for comparing sets.
    fn sorted(points: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let mut v = points.to_vec();
        v.sort_by(|a, b| a.partial_cmp(b).unwrap());
        v
    }

    /// Level 1 of the cube against Catmull-Clark's rules worked by hand.
    /// Face points are face centres, e.g. (1/2, 1/2, 0). Edge points average
    /// the edge's ends and the two face points beside it: the edge
    /// (0,0,0)-(1,0,0) gives (1/2, 1/8, 1/8). Vertex points are
    /// (F + 2R + (n - 3) P) / n with valence n = 3, F the mean of the face
    /// points (1/3, 1/3, 1/3) and R of the edge midpoints (1/6, 1/6, 1/6): the
    /// corner (0,0,0) moves to (2/9, 2/9, 2/9).
    #[test]
    fn catmull_clark_level_1_matches_the_rules() {
        let refined = refine(&cube(Scheme::CatmullClark), 1, Surface::Refined).unwrap();
        assert_eq!(refined.points.len(), 8 + 12 + 6);
        assert_eq!(refined.triangles.len(), 48);
        assert_eq!(triangles_at(Scheme::CatmullClark, &[4; 6], 1), 48);
        let mut want = Vec::new();
        let cube = |c: f32, low: f32| if c == 0.0 { low } else { 1.0 - low };
        for corner in CUBE_POINTS {
            want.push(corner.map(|c| cube(c, 2.0 / 9.0)));
        }
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                let mut face = [0.5; 3];
                face[axis] = side;
                want.push(face);
            }
        }
        for pair in CUBE_EDGES.chunks(2) {
            let [a, b] = [pair[0], pair[1]].map(|v| CUBE_POINTS[v as usize]);
            want.push(std::array::from_fn(|k| {
                if a[k] == b[k] {
                    cube(a[k], 1.0 / 8.0)
                } else {
                    0.5
                }
            }));
        }
        for (got, want) in sorted(&refined.points).into_iter().zip(sorted(&want)) {
            assert_near(got, want, "level-1 point");
        }
    }

    /// The limit of a cage vertex of valence n on an all-quad mesh is
    /// (n^2 P + 4 sum(e_i) + sum(f_i)) / (n (n + 5)) (Halstead, Kass and
    /// DeRose 1993): for the cube's corner (0,0,0), (4 (1,1,1) + (2,2,2)) / 24
    /// = (1/4, 1/4, 1/4), at every level; the limit normal there is the diagonal.
    #[test]
    fn catmull_clark_cube_corners_reach_their_limit() {
        for level in 1..=5 {
            let refined = refine(&cube(Scheme::CatmullClark), level, Surface::Limit).unwrap();
            assert_eq!(
                refined.triangles.len() as u64,
                triangles_at(Scheme::CatmullClark, &[4; 6], level)
            );
            let normals = refined.normals.as_ref().unwrap();
            for (v, corner) in CUBE_POINTS.iter().enumerate() {
                let want = corner.map(|c| if c == 0.0 { 0.25 } else { 0.75 });
                assert_near(
                    refined.points[v],
                    want,
                    &format!("level {level} limit corner"),
                );
                let out = (Vec3::from(*corner) - Vec3::splat(0.5)).normalize();
                assert!(
                    Vec3::from(normals[v]).dot(out) > 1.0 - 1e-5,
                    "normal {:?}",
                    normals[v]
                );
            }
        }
    }

    /// Infinitely sharp creases on every edge (sharpness 10, DeRose et al.
    /// 1998) keep the cube a cube: every limit point lies on its surface and
    /// the corners stay where they are.
    #[test]
    fn fully_sharp_creases_reproduce_the_cube() {
        let cage = Cage {
            crease_pairs: &CUBE_EDGES,
            crease_sharpness: &[10.0; 12],
            ..cube(Scheme::CatmullClark)
        };
        let refined = refine(&cage, 3, Surface::Limit).unwrap();
        for (v, corner) in CUBE_POINTS.iter().enumerate() {
            assert_near(refined.points[v], *corner, "sharp corner");
        }
        for p in &refined.points {
            let on_face = p.iter().any(|&c| c.abs() < 1e-6 || (c - 1.0).abs() < 1e-6);
            let inside = p.iter().all(|&c| (-1e-6..=1.0 + 1e-6).contains(&c));
            assert!(on_face && inside, "{p:?} is off the cube");
        }
    }

    /// Face-varying texture coordinates split points along their seams; per
    /// vertex channels do not; every triangle keeps its cage face.
    #[test]
    fn face_varying_seams_split_points() {
        let uvs: Vec<f32> = (0..24)
            .flat_map(|c| [(c % 4) as f32, (c / 4) as f32])
            .collect();
        let indices: Vec<u32> = (0..24).collect();
        let cage = Cage {
            channels: vec![Channel {
                width: 2,
                values: &uvs,
                indices: Some(&indices),
            }],
            ..cube(Scheme::CatmullClark)
        };
        let refined = refine(&cage, 1, Surface::Limit).unwrap();
        assert_eq!(
            refined.points.len(),
            6 * 9,
            "every face its own 3x3 grid of points"
        );
        assert_eq!(refined.channels[0].len(), refined.points.len() * 2);
        let mut faces = refined.triangle_faces.clone();
        faces.dedup();
        assert_eq!(faces, (0..6).collect::<Vec<u32>>());
    }

    /// Loop splits each triangle of an octahedron into 4^L, and its limit
    /// surface is smooth (normals along the position from the centre at the
    /// six cage vertices, by symmetry); bilinear splits the cube's quads
    /// without moving anything off the cube and gives no normals (faceted).
    #[test]
    fn loop_and_bilinear_refine_as_their_rules_say() {
        let octahedron: [[f32; 3]; 6] = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let faces = [
            0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5,
        ];
        let cage = Cage {
            positions: &octahedron,
            face_counts: &[3; 8],
            face_indices: &faces,
            ..cube(Scheme::Loop)
        };
        let refined = refine(&cage, 2, Surface::Limit).unwrap();
        assert_eq!(
            refined.triangles.len() as u64,
            triangles_at(Scheme::Loop, &[3; 8], 2)
        );
        assert_eq!(refined.triangles.len(), 8 * 16);
        let normals = refined.normals.unwrap();
        for (v, (point, normal)) in refined.points.iter().zip(&normals).take(6).enumerate() {
            let radial = Vec3::from(*point).normalize();
            assert!(Vec3::from(*normal).dot(radial) > 1.0 - 1e-5, "vertex {v}");
        }
        let bilinear = refine(&cube(Scheme::Bilinear), 3, Surface::Limit).unwrap();
        assert!(bilinear.normals.is_none());
        for p in &bilinear.points {
            assert!(
                p.iter().any(|&c| c == 0.0 || c == 1.0),
                "{p:?} left the cube"
            );
        }
    }

    /// A hole (the right of two quads side by side) is refined around and
    /// never drawn: every triangle is of the left face, every point has a
    /// limit normal, and the left face's limit surface reaches no further
    /// right than the shared edge (x = 0).
    #[test]
    fn holes_are_left_out_on_the_limit_surface() {
        let points = [
            [-0.8, -0.8, 0.0],
            [0.0, -0.8, 0.0],
            [0.8, -0.8, 0.0],
            [-0.8, 0.8, 0.0],
            [0.0, 0.8, 0.0],
            [0.8, 0.8, 0.0],
        ];
        let cage = Cage {
            positions: &points,
            face_counts: &[4, 4],
            face_indices: &[0, 1, 4, 3, 1, 2, 5, 4],
            holes: &[1],
            ..cube(Scheme::CatmullClark)
        };
        for level in 1..=3 {
            let refined = refine(&cage, level, Surface::Limit).unwrap();
            assert_eq!(
                refined.triangles.len() as u64,
                triangles_at(Scheme::CatmullClark, &[4], level)
            );
            assert!(refined.triangle_faces.iter().all(|&f| f == 0));
            assert_eq!(refined.normals.unwrap().len(), refined.points.len());
            assert!(refined.points.iter().all(|p| p[0] <= 1e-6), "level {level}");
        }
    }

    /// Loop refuses quads; a bad index is refused before OpenSubdiv sees it.
    #[test]
    fn refusals_are_errors() {
        let loop_quads = refine(&cube(Scheme::Loop), 1, Surface::Limit);
        assert!(
            matches!(loop_quads, Err(SubdivisionError::Refused(_))),
            "{loop_quads:?}"
        );
        let bad = Cage {
            face_indices: &[0, 1, 2, 9],
            face_counts: &[4],
            ..cube(Scheme::CatmullClark)
        };
        assert!(matches!(
            refine(&bad, 1, Surface::Limit),
            Err(SubdivisionError::Invalid(_))
        ));
    }
}
