//! cxx bridge to `shim.cc`: the only way Rust reaches OpenSubdiv. Mounted as a
//! private child of `src/subdivision/osd.rs`; nothing else may name it. Only
//! plain arrays cross: a control cage in, a uniformly refined mesh out.

#[cxx::bridge(namespace = "cirrus::osd")]
pub(super) mod ffi {
    /// A control cage as OpenSubdiv's `Far::TopologyDescriptor` takes it, with
    /// the `Sdc::Options` of USD's subdivision tags as small integers.
    struct Cage {
        /// `Sdc::SchemeType`: 0 bilinear, 1 Catmull-Clark, 2 Loop.
        scheme: u8,
        /// `Sdc::Options::VtxBoundaryInterpolation`: 0 none, 1 edge only, 2 edge and corner.
        boundary: u8,
        /// `Sdc::Options::FVarLinearInterpolation`: 0 none .. 5 all, in OpenSubdiv's order.
        fvar_linear: u8,
        /// `Sdc::Options::TriangleSubdivision`: 0 Catmull-Clark weights, 1 smooth.
        triangle_rule: u8,
        /// Cage vertices; `positions` holds 3 floats each.
        vertex_count: u32,
        positions: Vec<f32>,
        /// Vertices per face, then each face's vertex indices in order.
        face_counts: Vec<u32>,
        face_indices: Vec<u32>,
        /// Creased edges as vertex pairs (2 per edge) and one sharpness per edge.
        crease_pairs: Vec<u32>,
        crease_weights: Vec<f32>,
        /// Sharp corner vertices and their sharpness.
        corner_vertices: Vec<u32>,
        corner_weights: Vec<f32>,
        /// Faces that are holes.
        holes: Vec<u32>,
        /// Primvars refined beside the positions.
        channels: Vec<CageChannel>,
    }

    /// One primvar of the cage: `width` floats per value; per vertex, or
    /// face-varying through `indices` (one per entry of `face_indices`).
    struct CageChannel {
        width: u32,
        face_varying: bool,
        values: Vec<f32>,
        indices: Vec<u32>,
    }

    /// The cage refined uniformly: positions (and normals when asked for the
    /// limit) at the finest level's vertices, its faces less holes.
    struct Refined {
        /// 3 floats per refined vertex: limit positions, or refined ones.
        positions: Vec<f32>,
        /// 3 floats per refined vertex: cross product of the limit tangents,
        /// unnormalised (zero where they degenerate); empty unless on the limit.
        normals: Vec<f32>,
        /// Vertices per refined face, then their vertex indices.
        face_counts: Vec<u32>,
        face_vertices: Vec<u32>,
        /// Per refined face: the cage face it came from.
        base_faces: Vec<u32>,
        /// Per cage channel, in order: refined values and, per entry of
        /// `face_vertices`, the index of its value.
        channels: Vec<RefinedChannel>,
    }

    /// A refined primvar: `values` of the cage channel's width, and the value
    /// index of each refined face corner.
    struct RefinedChannel {
        values: Vec<f32>,
        indices: Vec<u32>,
    }

    unsafe extern "C++" {
        include!("cirrus/ffi/opensubdiv/shim.h");

        type CageRefiner;

        /// OpenSubdiv's topology refiner for `cage`; an error carries
        /// OpenSubdiv's own messages when it refuses the topology.
        fn create_refiner(cage: &Cage) -> Result<UniquePtr<CageRefiner>>;
        /// Refines uniformly to `level`; with `limit` (and not bilinear),
        /// positions and normals are evaluated on the limit surface.
        fn refine(
            self: Pin<&mut CageRefiner>,
            cage: &Cage,
            level: u32,
            limit: bool,
        ) -> Result<Refined>;
    }
}
