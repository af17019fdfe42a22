//! Reading `.vdb` files through the OpenVDB bridge (`ffi/openvdb/`): the grid
//! table, and float grids copied once into a [`SparseGrid`]. This is the only
//! module that talks to OpenVDB; C++ exceptions arrive here as `cxx::Exception`
//! and leave as [`VolumeError`] naming the file and grid.

#[path = "../../../ffi/openvdb/bridge.rs"]
mod bridge;

use std::path::{Path, PathBuf};

use glam::{DAffine3, DMat4, DVec3, IVec3, U64Vec3};

use super::sparse::{blocks_spanned, GridTransform, SparseGrid, Tile};
use bridge::ffi;

/// Why a VDB file or grid could not be used.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// A Volume prim's shading value out of its domain.
    #[error("volume {prim}: {message}")]
    Invalid {
        /// The Volume prim's path.
        prim: String,
        /// What is wrong, with the value.
        message: String,
    },
    /// The file cannot be reached (missing, unreadable).
    #[error("{path}: {message}", path = path.display())]
    Io {
        /// The VDB file.
        path: PathBuf,
        /// The OS's reason.
        message: String,
    },
    /// OpenVDB threw (not a VDB file, truncated, unsupported version...).
    #[error("{path}: OpenVDB: {message}", path = path.display())]
    OpenVdb {
        /// The VDB file.
        path: PathBuf,
        /// OpenVDB's exception text, with the grid when one was being read.
        message: String,
    },
    #[error("{path}: no grid named '{grid}'{which}; the file has: {available}",
        path = path.display(),
        which = if *index > 0 { format!(" (occurrence {index})") } else { String::new() })]
    /// No grid of that name (or not that many of them) in the file.
    NoSuchGrid {
        /// The VDB file.
        path: PathBuf,
        /// The grid name asked for.
        grid: String,
        /// Which occurrence of the name was asked for (0 = first).
        index: usize,
        /// The grids the file does hold, for the message.
        available: String,
    },
    #[error("{path}: grid '{grid}' holds '{value_type}' values; Cirrus needs a float grid here", path = path.display())]
    /// The grid holds another value type where a float grid is needed.
    NotFloat {
        /// The VDB file.
        path: PathBuf,
        /// The grid.
        grid: String,
        /// Its OpenVDB value type ("vec3s", "int32", ...).
        value_type: String,
    },
    /// A velocity field's grid is neither a vec3s grid nor one of three
    /// float grids `NAME.x`, `NAME.y`, `NAME.z`.
    #[error("{path}: grid '{grid}' holds '{value_type}' values; a velocity field needs a vec3s grid, or three float grids NAME.x, NAME.y, NAME.z", path = path.display())]
    NotVector {
        /// The VDB file.
        path: PathBuf,
        /// The grid.
        grid: String,
        /// Its OpenVDB value type.
        value_type: String,
    },
    /// The grid has no active voxels or tiles: nothing to render.
    #[error("{path}: grid '{grid}' is empty (no active voxels or tiles)", path = path.display())]
    EmptyGrid {
        /// The VDB file.
        path: PathBuf,
        /// The grid.
        grid: String,
    },
    /// The grid's transform is not affine (a frustum map).
    #[error("{path}: grid '{grid}' has a non-affine (frustum) transform, which Cirrus does not support", path = path.display())]
    NonLinearTransform {
        /// The VDB file.
        path: PathBuf,
        /// The grid.
        grid: String,
    },
    /// The grid's affine transform cannot be inverted (a zero scale).
    #[error("{path}: grid '{grid}' has a singular index-to-world transform (zero scale)", path = path.display())]
    SingularTransform {
        /// The VDB file.
        path: PathBuf,
        /// The grid.
        grid: String,
    },
    /// The tree cannot be laid out as a [`super::SparseGrid`].
    #[error("{path}: grid '{grid}': {source}", path = path.display())]
    Layout {
        /// The VDB file.
        path: PathBuf,
        /// The grid.
        grid: String,
        /// What is wrong with the tree.
        source: super::sparse::LayoutError,
    },
}

/// Which space sample points are given in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Space {
    /// Index space: voxel (i,j,k) at integer point (i,j,k).
    Index,
    /// World space: through the grid's index-to-world transform.
    World,
}

/// One grid's metadata as the file describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct GridInfo {
    /// The grid's name (several grids may share one).
    pub name: String,
    /// OpenVDB's value type name ("float", "vec3s", "int32", ...).
    pub value_type: String,
    /// OpenVDB's grid class ("fog volume", "level set", ...).
    pub grid_class: String,
    /// World units per voxel along each index axis.
    pub voxel_size: DVec3,
    /// Inclusive index bounds of active voxels and tiles: min corner (min > max when empty).
    pub index_min: IVec3,
    /// Inclusive max corner of the active bounds.
    pub index_max: IVec3,
    /// Active voxels, tiles counted voxel by voxel.
    pub active_voxel_count: u64,
    /// OpenVDB's in-memory size of the tree, bytes (the file's
    /// `file_mem_bytes` metadata, else measured on the read tree).
    pub tree_bytes: u64,
    /// Index-to-world affine map; `None` for non-affine (frustum) maps.
    pub world_from_index: Option<DAffine3>,
}

impl GridInfo {
    /// The most 8^3 leaves the tree can hold, from the grid table alone:
    /// its in-memory size over one float leaf's (512 `f32` and masks, about
    /// 2.1 kB; internal nodes make this an upper bound), at most the leaves
    /// the active box can touch and at least the active voxels over 512.
    pub fn leaves(&self) -> u64 {
        const TREE_BYTES_PER_LEAF: u64 = 2112;
        (self.tree_bytes / TREE_BYTES_PER_LEAF)
            .min(blocks_spanned(self.dims(), 8))
            .max(self.active_voxel_count.div_ceil(512))
    }

    /// Bytes reading this grid holds at its peak beside the layout it
    /// builds: OpenVDB's tree and the bridge's flat copy of the leaves'
    /// values (2 kB each).
    pub fn read_bytes(&self) -> u64 {
        self.tree_bytes + self.leaves() * 2048
    }

    /// Voxels along each axis of the active bounds (zero when empty).
    pub fn dims(&self) -> U64Vec3 {
        (self.index_max - self.index_min + IVec3::ONE)
            .max(IVec3::ZERO)
            .as_u64vec3()
    }
}

/// An open `.vdb` file and its grid table.
pub struct VdbFile {
    path: PathBuf,
    handle: cxx::UniquePtr<ffi::VdbFile>,
    grids: Vec<GridInfo>,
}

impl VdbFile {
    /// Opens `path` and reads its grid table (metadata only, no trees).
    pub fn open(path: impl AsRef<Path>) -> Result<Self, VolumeError> {
        let path = path.as_ref().to_path_buf();
        if let Err(e) = std::fs::metadata(&path) {
            return Err(VolumeError::Io {
                path,
                message: e.to_string(),
            });
        }
        let path_str = path.to_string_lossy();
        let ovdb = |e: cxx::Exception| VolumeError::OpenVdb {
            path: path.clone(),
            message: e.what().to_owned(),
        };
        let handle = ffi::open_vdb(&path_str).map_err(ovdb)?;
        let grids = handle
            .grids()
            .map_err(ovdb)?
            .into_iter()
            .map(GridInfo::from)
            .collect();
        Ok(Self {
            path,
            handle,
            grids,
        })
    }

    /// The file this was opened from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Every grid in file order, duplicates of a name included.
    pub fn grids(&self) -> &[GridInfo] {
        &self.grids
    }

    /// Position in [`Self::grids`] of the `index`-th (from 0) grid called `name`.
    pub fn find(&self, name: &str, index: usize) -> Result<usize, VolumeError> {
        self.grids
            .iter()
            .enumerate()
            .filter(|(_, g)| g.name == name)
            .nth(index)
            .map(|(i, _)| i)
            .ok_or_else(|| VolumeError::NoSuchGrid {
                path: self.path.clone(),
                grid: name.to_owned(),
                index,
                available: self.describe_grids(),
            })
    }

    /// Reads the `index`-th float grid called `name` into a [`SparseGrid`]:
    /// one call across the FFI, then the C++ tree is dropped.
    pub fn read_float_grid(&self, name: &str, index: usize) -> Result<SparseGrid, VolumeError> {
        let (at, transform) = self.checked(name, index, "float")?;
        let data = self
            .handle
            .read_float_grid(at as u32)
            .map_err(|e| self.openvdb_error(name, e))?;
        self.sparse(name, data, transform)
    }

    /// Reads the `index`-th vec3s grid called `name` as three float
    /// [`SparseGrid`]s, its x, y and z components (sharing the grid's
    /// transform): one call across the FFI.
    pub fn read_vector_grid(
        &self,
        name: &str,
        index: usize,
    ) -> Result<[SparseGrid; 3], VolumeError> {
        let (at, transform) = self.checked(name, index, "vec3s")?;
        let data = self
            .handle
            .read_vec3_grid(at as u32)
            .map_err(|e| self.openvdb_error(name, e))?;
        let mut components = data.into_iter().map(|d| self.sparse(name, d, transform));
        let mut next = || {
            components
                .next()
                .expect("the bridge returns three components")
        };
        Ok([next()?, next()?, next()?])
    }

    /// The position of the `index`-th grid called `name` and its affine
    /// transform, after checking that it holds `value_type` values.
    fn checked(
        &self,
        name: &str,
        index: usize,
        value_type: &str,
    ) -> Result<(usize, GridTransform), VolumeError> {
        let at = self.find(name, index)?;
        let info = &self.grids[at];
        let grid = name.to_owned();
        if info.value_type != value_type {
            return Err(if value_type == "float" {
                VolumeError::NotFloat {
                    path: self.path.clone(),
                    grid,
                    value_type: info.value_type.clone(),
                }
            } else {
                VolumeError::NotVector {
                    path: self.path.clone(),
                    grid,
                    value_type: info.value_type.clone(),
                }
            });
        }
        let Some(world_from_index) = info.world_from_index else {
            return Err(VolumeError::NonLinearTransform {
                path: self.path.clone(),
                grid,
            });
        };
        let transform =
            GridTransform::new(world_from_index).ok_or_else(|| VolumeError::SingularTransform {
                path: self.path.clone(),
                grid: grid.clone(),
            })?;
        Ok((at, transform))
    }

    /// The [`SparseGrid`] of one flattened tree (a float grid, or one
    /// component of a vector grid) of the grid `name`.
    fn sparse(
        &self,
        name: &str,
        data: ffi::FloatGridData,
        transform: GridTransform,
    ) -> Result<SparseGrid, VolumeError> {
        let grid = name.to_owned();
        if data.leaf_origins.is_empty() && !data.tile_active.contains(&true) {
            return Err(VolumeError::EmptyGrid {
                path: self.path.clone(),
                grid,
            });
        }
        let leaf_origins: Vec<IVec3> = data
            .leaf_origins
            .chunks_exact(3)
            .map(IVec3::from_slice)
            .collect();
        let tiles: Vec<Tile> = (0..data.tile_values.len())
            .map(|t| Tile {
                origin: IVec3::from_slice(&data.tile_origins[3 * t..3 * t + 3]),
                edge: data.tile_dims[t],
                value: data.tile_values[t],
                active: data.tile_active[t],
            })
            .collect();
        SparseGrid::build(
            data.background,
            &leaf_origins,
            data.leaf_values,
            &tiles,
            transform,
        )
        .map_err(|source| VolumeError::Layout {
            path: self.path.clone(),
            grid,
            source,
        })
    }

    /// OpenVDB's own `memUsage()` for a float grid's tree, in bytes (benchmarks).
    pub fn openvdb_tree_bytes(&self, name: &str, index: usize) -> Result<u64, VolumeError> {
        let at = self.find(name, index)?;
        let data = self
            .handle
            .read_float_grid(at as u32)
            .map_err(|e| self.openvdb_error(name, e))?;
        Ok(data.tree_mem_bytes)
    }

    /// OpenVDB's own `BoxSampler` at `points` in the given space: the reference
    /// the Rust sampler is tested against. Reads the grid on every call; not for rendering.
    pub fn openvdb_trilinear(
        &self,
        name: &str,
        index: usize,
        points: &[DVec3],
        space: Space,
    ) -> Result<Vec<f32>, VolumeError> {
        let at = self.find(name, index)?;
        let flat: Vec<f64> = points.iter().flat_map(|p| p.to_array()).collect();
        self.handle
            .box_sample(at as u32, &flat, space == Space::World)
            .map_err(|e| self.openvdb_error(name, e))
    }

    fn openvdb_error(&self, grid: &str, e: cxx::Exception) -> VolumeError {
        VolumeError::OpenVdb {
            path: self.path.clone(),
            message: format!("grid '{grid}': {}", e.what()),
        }
    }

    fn describe_grids(&self) -> String {
        if self.grids.is_empty() {
            return "no grids".to_owned();
        }
        let names: Vec<String> = self
            .grids
            .iter()
            .map(|g| format!("'{}' ({})", g.name, g.value_type))
            .collect();
        names.join(", ")
    }
}

impl From<ffi::GridInfo> for GridInfo {
    fn from(g: ffi::GridInfo) -> Self {
        // The bridge hands the matrix row-major; glam stores columns.
        let world_from_index = g
            .is_linear
            .then(|| DAffine3::from_mat4(DMat4::from_cols_array(&g.world_from_index).transpose()));
        GridInfo {
            name: g.name,
            value_type: g.value_type,
            grid_class: g.grid_class,
            voxel_size: DVec3::from_array(g.voxel_size),
            index_min: IVec3::from_array(g.index_bbox_min),
            index_max: IVec3::from_array(g.index_bbox_max),
            active_voxel_count: g.active_voxel_count,
            tree_bytes: g.tree_bytes,
            world_from_index,
        }
    }
}
