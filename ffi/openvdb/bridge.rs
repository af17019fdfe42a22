//! cxx bridge to `shim.cc`: the only way Rust reaches OpenVDB. Mounted as a
//! private child of `src/volumes/grid/vdb.rs`; nothing else may name it.

#[cxx::bridge(namespace = "cirrus::vdb")]
pub(super) mod ffi {
    /// One grid's metadata, as stored in the file (no tree is read for it).
    struct GridInfo {
        name: String,
        /// OpenVDB value type name: "float", "vec3s", "int32", ...
        value_type: String,
        /// "fog volume", "level set", "staggered", or "unknown".
        grid_class: String,
        /// World units per voxel along each index axis.
        voxel_size: [f64; 3],
        /// Inclusive index-space bounds of the active voxels and tiles.
        index_bbox_min: [i32; 3],
        index_bbox_max: [i32; 3],
        /// Active voxels, counting every voxel covered by an active tile.
        active_voxel_count: u64,
        /// OpenVDB's in-memory size of the tree, bytes (the file's
        /// `file_mem_bytes`, else measured on the read tree).
        tree_bytes: u64,
        /// Index-to-world affine map, row-major, acting on column vectors:
        /// `p_world = M * [i, j, k, 1]`. Only meaningful when `is_linear`.
        world_from_index: [f64; 16],
        /// False for frustum and other non-affine maps.
        is_linear: bool,
    }

    /// A float tree (or one component of a vec3s tree) flattened into
    /// plain arrays, copied once.
    struct FloatGridData {
        background: f32,
        /// Origin (min corner) of each 8^3 leaf, 3 values per leaf.
        leaf_origins: Vec<i32>,
        /// 512 values per leaf, in OpenVDB's order: offset = x*64 + y*8 + z.
        /// Inactive voxels keep their stored value, as OpenVDB's samplers see it.
        leaf_values: Vec<f32>,
        /// Min corner of each tile (active, or inactive with a non-background value).
        tile_origins: Vec<i32>,
        /// Edge length of each tile in voxels (8, 128 or 4096 for the standard tree).
        tile_dims: Vec<u32>,
        tile_values: Vec<f32>,
        tile_active: Vec<bool>,
        /// OpenVDB's own `memUsage()` of the tree, for the memory benchmark.
        tree_mem_bytes: u64,
    }

    unsafe extern "C++" {
        include!("cirrus/ffi/openvdb/shim.h");

        type VdbFile;

        fn open_vdb(path: &str) -> Result<UniquePtr<VdbFile>>;
        fn grids(self: &VdbFile) -> Result<Vec<GridInfo>>;
        /// `file_index` is the grid's position in `grids()`.
        fn read_float_grid(self: &VdbFile, file_index: u32) -> Result<FloatGridData>;
        /// A vec3s grid as its x, y and z components, each flattened like a
        /// float grid (same leaves and tiles).
        fn read_vec3_grid(self: &VdbFile, file_index: u32) -> Result<Vec<FloatGridData>>;
        /// OpenVDB's `GridSampler<BoxSampler>` at (x,y,z) triples, index space
        /// (`isSample`) or world space (`wsSample`). Tests and benchmarks only.
        fn box_sample(
            self: &VdbFile,
            file_index: u32,
            points: &[f64],
            world_space: bool,
        ) -> Result<Vec<f32>>;
    }
}
