// C++ side of the OpenVDB bridge. Only plain structs and a pimpl handle appear
// here: OpenVDB's headers are included by shim.cc alone, so the generated cxx
// bridge never sees a template. Every function may throw; cxx turns the
// exception into a Rust `Err` because each one is declared as returning Result.
#pragma once
#include "rust/cxx.h"
#include <memory>

namespace cirrus {
namespace vdb {

struct GridInfo;
struct FloatGridData;

/// An open `.vdb` file. Holds the OpenVDB file object and a cache of the grid
/// metadata; the trees themselves are read on demand by `read_float_grid` and
/// `read_vec3_grid`.
class VdbFile {
public:
  struct Impl;
  explicit VdbFile(std::unique_ptr<Impl> impl);
  ~VdbFile();

  rust::Vec<GridInfo> grids() const;
  FloatGridData read_float_grid(uint32_t file_index) const;
  rust::Vec<FloatGridData> read_vec3_grid(uint32_t file_index) const;
  rust::Vec<float> box_sample(uint32_t file_index, rust::Slice<const double> points,
                              bool world_space) const;

private:
  std::unique_ptr<Impl> impl_;
};

std::unique_ptr<VdbFile> open_vdb(rust::Str path);

} // namespace vdb
} // namespace cirrus
