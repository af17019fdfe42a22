// C++ side of the OpenSubdiv bridge. Only plain structs and a pimpl handle appear
// here: OpenSubdiv's headers are included by shim.cc alone, so the generated cxx
// bridge never sees a template. Every function may throw; cxx turns the
// exception into a Rust `Err` because each one is declared as returning Result.
#pragma once
#include "rust/cxx.h"
#include <memory>

namespace cirrus {
namespace osd {

struct Cage;
struct Refined;

/// OpenSubdiv's `Far::TopologyRefiner` built from one cage.
class CageRefiner {
public:
  struct Impl;
  explicit CageRefiner(std::unique_ptr<Impl> impl);
  ~CageRefiner();

  Refined refine(const Cage &cage, uint32_t level, bool limit);

private:
  std::unique_ptr<Impl> impl_;
};

std::unique_ptr<CageRefiner> create_refiner(const Cage &cage);

} // namespace osd
} // namespace cirrus
