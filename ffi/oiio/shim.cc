// OpenImageIO side of the bridge: writes multi-channel EXRs with per-channel
// half/float formats, compression and metadata, and reads texture images.
#include "cirrus/ffi/guard.h"
#include "cirrus/ffi/oiio/shim.h"
#include "cirrus/ffi/oiio/bridge.rs.h"

#include <OpenImageIO/imageio.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace cirrus {
namespace oiio {

namespace {


std::string or_default(std::string message, const char *fallback) {
  return message.empty() ? std::string(fallback) : message;
}

} // namespace

void write_exr(const ExrRequest &req) {
  guard("OpenImageIO", [&] {
    const std::string path(req.path);
    const size_t nch = req.channel_names.size();
    if (nch == 0 || req.channel_half.size() != nch) {
      throw std::invalid_argument("channel names and formats disagree");
    }
    if (req.pixels.size() != size_t(req.width) * req.height * nch) {
      throw std::invalid_argument("pixel buffer size does not match width x height x channels");
    }
    OIIO::ImageSpec spec(int(req.width), int(req.height), int(nch), OIIO::TypeDesc::FLOAT);
    spec.channelnames.clear();
    spec.channelformats.clear();
    for (size_t c = 0; c < nch; ++c) {
      spec.channelnames.push_back(std::string(req.channel_names[c]));
      spec.channelformats.push_back(req.channel_half[c] ? OIIO::TypeDesc::HALF
                                                        : OIIO::TypeDesc::FLOAT);
    }
    // OIIO guesses alpha and depth from names; we name channels ourselves.
    spec.alpha_channel = -1;
    spec.z_channel = -1;
    for (size_t c = 0; c < nch; ++c) {
      if (spec.channelnames[c] == "A") spec.alpha_channel = int(c);
    }
    spec.attribute("compression", std::string(req.compression));
    for (const auto &s : req.strings) {
      spec.attribute(std::string(s.name), std::string(s.value));
    }
    for (const auto &m : req.matrices) {
      spec.attribute(std::string(m.name), OIIO::TypeMatrix44, m.values.data());
    }

    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
      throw std::runtime_error(or_default(OIIO::geterror(), "no image writer for this extension"));
    }
    if (!out->open(path, spec)) {
      throw std::runtime_error(or_default(out->geterror(), "cannot open for writing"));
    }
    if (!out->write_image(OIIO::TypeDesc::FLOAT, req.pixels.data())) {
      const std::string err = out->geterror();
      out->close();
      throw std::runtime_error(or_default(err, "write failed"));
    }
    if (!out->close()) {
      throw std::runtime_error(or_default(out->geterror(), "close failed"));
    }
  });
}

ImageData read_image(rust::Str path_str) {
  return guard("OpenImageIO", [&] {
    const std::string path(path_str);
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
      throw std::runtime_error(or_default(OIIO::geterror(), "cannot open image"));
    }
    const OIIO::ImageSpec &spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth > 1) {
      throw std::runtime_error("not a 2D image");
    }
    ImageData out;
    out.width = uint32_t(spec.width);
    out.height = uint32_t(spec.height);
    out.channels = uint32_t(spec.nchannels);
    out.alpha_channel = spec.alpha_channel;
    const std::string space = spec.get_string_attribute("oiio:ColorSpace");
    out.is_srgb = space == "sRGB" || (space.empty() && spec.format == OIIO::TypeDesc::UINT8);
    std::vector<float> pixels(size_t(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data())) {
      throw std::runtime_error(or_default(in->geterror(), "read failed"));
    }
    in->close();
    out.pixels.reserve(pixels.size());
    for (float v : pixels) out.pixels.push_back(v);
    return out;
  });
}

} // namespace oiio
} // namespace cirrus
