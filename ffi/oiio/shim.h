// C++ side of the OpenImageIO bridge: plain functions over plain structs.
// OpenImageIO's headers are included by shim.cc alone.
#pragma once
#include "rust/cxx.h"

namespace cirrus {
namespace oiio {

struct ExrRequest;
struct ImageData;

void write_exr(const ExrRequest &request);
ImageData read_image(rust::Str path);

} // namespace oiio
} // namespace cirrus
