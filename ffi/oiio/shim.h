// C++ side of the OpenImageIO bridge: plain functions over plain structs.
// OpenImageIO's headers are included by shim.cc alone.
#pragma once
#include "rust/cxx.h"

namespace cirrus {
namespace oiio {

struct ExrRequest;
struct ImageData;
struct ExrData;
struct DisplayPngRequest;

void write_exr(const ExrRequest &request);
ImageData read_image(rust::Str path, uint64_t max_bytes);
ExrData read_exr(rust::Str path);
bool write_display_png(const DisplayPngRequest &request);

} // namespace oiio
} // namespace cirrus
