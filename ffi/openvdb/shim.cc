// OpenVDB side of the bridge. Everything OpenVDB-specific stays in this file:
// opening files, listing grid metadata, flattening a float tree into plain
// arrays (copied once into Rust), and OpenVDB's own BoxSampler for the tests
// that check the Rust sampler against it.
#include "cirrus/ffi/guard.h"
#include "cirrus/ffi/openvdb/shim.h"
#include "cirrus/ffi/openvdb/bridge.rs.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace cirrus {
namespace vdb {

namespace {


void initialize_once() {
  static std::once_flag flag;
  std::call_once(flag, [] { openvdb::initialize(); });
}

openvdb::FloatGrid::Ptr as_float_grid(const openvdb::GridBase::Ptr &base) {
  auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  if (!grid) {
    throw std::runtime_error("grid '" + base->getName() + "' has value type '" +
                             base->valueType() + "', not float");
  }
  return grid;
}

} // namespace

struct VdbFile::Impl {
  openvdb::io::File file;
  openvdb::GridPtrVec metadata;     // file order, metadata and transform only
  std::vector<bool> name_is_unique; // per entry: no other grid shares its name

  explicit Impl(const std::string &path) : file(path) {}

  openvdb::GridBase::Ptr read(uint32_t file_index) {
    if (file_index >= metadata.size()) {
      throw std::out_of_range("grid index " + std::to_string(file_index) + " out of range");
    }
    if (name_is_unique[file_index]) {
      return file.readGrid(metadata[file_index]->getName());
    }
    // OpenVDB's readGrid(name) returns the first of several grids sharing a
    // name, whatever suffix is asked for; only reading them all in file order
    // reaches the others. Files with duplicate names pay for it; others do not.
    return (*file.getGrids())[file_index];
  }
};

VdbFile::VdbFile(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VdbFile::~VdbFile() = default;

std::unique_ptr<VdbFile> open_vdb(rust::Str path) {
  return guard("OpenVDB", [&] {
    initialize_once();
    auto impl = std::make_unique<VdbFile::Impl>(std::string(path));
    // No delayed loading: it memory-maps the file and defers errors to first access.
    impl->file.open(/*delayLoad=*/false);
    impl->metadata = *impl->file.readAllGridMetadata();
    std::map<std::string, int> count;
    for (const auto &grid : impl->metadata) ++count[grid->getName()];
    for (const auto &grid : impl->metadata) impl->name_is_unique.push_back(count[grid->getName()] == 1);
    return std::make_unique<VdbFile>(std::move(impl));
  });
}

rust::Vec<GridInfo> VdbFile::grids() const {
  return guard("OpenVDB", [&] {
    rust::Vec<GridInfo> out;
    for (size_t i = 0; i < impl_->metadata.size(); ++i) {
      const openvdb::GridBase::Ptr &meta = impl_->metadata[i];
      GridInfo info;
      info.name = meta->getName();
      info.value_type = meta->valueType();
      info.grid_class = openvdb::GridBase::gridClassToString(meta->getGridClass());
      const openvdb::Vec3d vs = meta->voxelSize();
      info.voxel_size = {vs.x(), vs.y(), vs.z()};

      // Files written by OpenVDB carry the active bounds and count as metadata;
      // older or foreign files may not, and then the tree must be read.
      openvdb::Coord lo, hi;
      int64_t count = 0, tree_bytes = 0;
      auto bmin = meta->getMetadata<openvdb::Vec3IMetadata>(openvdb::GridBase::META_FILE_BBOX_MIN);
      auto bmax = meta->getMetadata<openvdb::Vec3IMetadata>(openvdb::GridBase::META_FILE_BBOX_MAX);
      auto vcount = meta->getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_VOXEL_COUNT);
      auto mem = meta->getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_MEM_BYTES);
      if (bmin && bmax && vcount && mem) {
        lo = openvdb::Coord(bmin->value());
        hi = openvdb::Coord(bmax->value());
        count = vcount->value();
        tree_bytes = mem->value();
      } else {
        openvdb::GridBase::Ptr full = impl_->read(static_cast<uint32_t>(i));
        const openvdb::CoordBBox box = full->evalActiveVoxelBoundingBox();
        lo = box.min();
        hi = box.max();
        count = static_cast<int64_t>(full->activeVoxelCount());
        tree_bytes = static_cast<int64_t>(full->memUsage());
      }
      if (count == 0) { // OpenVDB stores an inverted sentinel box for empty grids
        lo = openvdb::Coord(0);
        hi = openvdb::Coord(-1);
      }
      info.index_bbox_min = {lo.x(), lo.y(), lo.z()};
      info.index_bbox_max = {hi.x(), hi.y(), hi.z()};
      info.active_voxel_count = static_cast<uint64_t>(count);
      info.tree_bytes = static_cast<uint64_t>(std::max<int64_t>(tree_bytes, 0));

      const openvdb::math::MapBase::ConstPtr map = meta->transform().baseMap();
      info.is_linear = map->isLinear();
      info.world_from_index = {};
      if (info.is_linear) {
        // OpenVDB multiplies row vectors (p' = p * M, translation in row 3);
        // transpose into the column-vector convention used on the Rust side.
        const openvdb::Mat4d m = map->getAffineMap()->getMat4();
        for (int r = 0; r < 4; ++r)
          for (int c = 0; c < 4; ++c)
            info.world_from_index[r * 4 + c] = m(c, r);
      }
      out.push_back(std::move(info));
    }
    return out;
  });
}

namespace {

// Flattens a tree into plain arrays, one scalar per voxel and tile: `component`
// turns each stored value into the float copied (the value itself for a float
// tree, one of the three components for a vec3s tree).
template <typename TreeT, typename Component>
FloatGridData flatten(const TreeT &tree, Component component) {
  FloatGridData out;
  out.background = component(tree.background());
  out.tree_mem_bytes = static_cast<uint64_t>(tree.memUsage());

  out.leaf_origins.reserve(tree.leafCount() * 3);
  out.leaf_values.reserve(tree.leafCount() * TreeT::LeafNodeType::SIZE);
  for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
    const openvdb::Coord o = leaf->origin();
    out.leaf_origins.push_back(o.x());
    out.leaf_origins.push_back(o.y());
    out.leaf_origins.push_back(o.z());
    for (openvdb::Index i = 0; i < TreeT::LeafNodeType::SIZE; ++i) {
      out.leaf_values.push_back(component(leaf->getValue(i)));
    }
  }

  // Tiles live above the leaf level: stop the iterator one level short of voxels.
  typename TreeT::ValueAllCIter tile = tree.cbeginValueAll();
  tile.setMaxDepth(TreeT::ValueAllCIter::LEAF_DEPTH - 1);
  for (; tile; ++tile) {
    const bool active = tile.isValueOn();
    const auto value = tile.getValue();
    if (!active && openvdb::math::isExactlyEqual(value, tree.background())) continue;
    const openvdb::CoordBBox box = tile.getBoundingBox();
    out.tile_origins.push_back(box.min().x());
    out.tile_origins.push_back(box.min().y());
    out.tile_origins.push_back(box.min().z());
    out.tile_dims.push_back(static_cast<uint32_t>(box.dim().x()));
    out.tile_values.push_back(component(value));
    out.tile_active.push_back(active);
  }
  return out;
}

} // namespace

FloatGridData VdbFile::read_float_grid(uint32_t file_index) const {
  return guard("OpenVDB", [&] {
    openvdb::FloatGrid::Ptr grid = as_float_grid(impl_->read(file_index));
    return flatten(grid->tree(), [](float v) { return v; });
  });
}

rust::Vec<FloatGridData> VdbFile::read_vec3_grid(uint32_t file_index) const {
  return guard("OpenVDB", [&] {
    openvdb::GridBase::Ptr base = impl_->read(file_index);
    auto grid = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base);
    if (!grid) {
      throw std::runtime_error("grid '" + base->getName() + "' has value type '" +
                               base->valueType() + "', not vec3s");
    }
    rust::Vec<FloatGridData> out;
    for (int c = 0; c < 3; ++c) {
      out.push_back(flatten(grid->tree(), [c](const openvdb::Vec3s &v) { return v[c]; }));
    }
    return out;
  });
}

rust::Vec<float> VdbFile::box_sample(uint32_t file_index, rust::Slice<const double> points,
                                     bool world_space) const {
  return guard("OpenVDB", [&] {
    openvdb::FloatGrid::Ptr grid = as_float_grid(impl_->read(file_index));
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(*grid);
    rust::Vec<float> out;
    out.reserve(points.size() / 3);
    for (size_t i = 0; i + 2 < points.size(); i += 3) {
      const openvdb::Vec3R p(points[i], points[i + 1], points[i + 2]);
      out.push_back(world_space ? sampler.wsSample(p) : sampler.isSample(p));
    }
    return out;
  });
}

} // namespace vdb
} // namespace cirrus
