// OpenImageIO side of the bridge: writes multi-channel EXRs with per-channel
// half/float formats, compression and metadata, reads texture images, reads
// an EXR's named channels back, and writes labelled 8-bit sRGB PNGs.
#include "cirrus/ffi/guard.h"
#include "cirrus/ffi/oiio/shim.h"
#include "cirrus/ffi/oiio/bridge.rs.h"

#include <OpenImageIO/half.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace cirrus {
namespace oiio {

namespace {

// Label size in pixels (the em height OpenImageIO renders at).
constexpr int LABEL_FONT_SIZE = 14;

std::string or_default(std::string message, const char *fallback) {
  return message.empty() ? std::string(fallback) : message;
}

ChannelFormat channel_format(const OIIO::TypeDesc &type) {
  if (type == OIIO::TypeDesc::HALF) return ChannelFormat::Half;
  if (type == OIIO::TypeDesc::FLOAT) return ChannelFormat::Float;
  if (type == OIIO::TypeDesc::UINT) return ChannelFormat::Uint;
  throw std::runtime_error(std::string("channel of unsupported type ") + type.c_str());
}

// One stored value widened to float by value (a uint is not normalised).
float widen(const unsigned char *bytes, ChannelFormat format) {
  switch (format) {
  case ChannelFormat::Half: {
    half h;
    std::memcpy(&h, bytes, sizeof h);
    return float(h);
  }
  case ChannelFormat::Float: {
    float f;
    std::memcpy(&f, bytes, sizeof f);
    return f;
  }
  case ChannelFormat::Uint: {
    uint32_t u;
    std::memcpy(&u, bytes, sizeof u);
    return float(u);
  }
  }
  throw std::logic_error("unknown channel format");
}

// The first font OpenImageIO can render with: its own default (Droid Sans,
// when installed), else DejaVu Sans (Debian's fonts-dejavu-core); none when
// neither is found.
std::optional<std::string> label_font() {
  std::optional<std::string> found;
  for (const char *name : {"", "DejaVuSans"}) {
    if (OIIO::ImageBufAlgo::text_size("Ag", LABEL_FONT_SIZE, name).defined()) {
      found = name;
      break;
    }
  }
  (void)OIIO::geterror();  // drop the failed lookups' messages
  return found;
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
    if (uint64_t(req.x) + req.width > req.full_width ||
        uint64_t(req.y) + req.height > req.full_height) {
      throw std::invalid_argument("data window outside the display window");
    }
    OIIO::ImageSpec spec(int(req.width), int(req.height), int(nch), OIIO::TypeDesc::FLOAT);
    spec.x = int(req.x);
    spec.y = int(req.y);
    spec.full_x = 0;
    spec.full_y = 0;
    spec.full_width = int(req.full_width);
    spec.full_height = int(req.full_height);
    spec.attribute("PixelAspectRatio", req.pixel_aspect);
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

ImageData read_image(rust::Str path_str, uint64_t max_bytes) {
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
    // The pixels are held twice while read (here and in the Rust vector).
    const uint64_t values = uint64_t(spec.width) * uint64_t(spec.height) * uint64_t(spec.nchannels);
    if (values > max_bytes / (2 * sizeof(float))) {
      throw std::runtime_error(std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                               " pixels of " + std::to_string(spec.nchannels) + " channels need " +
                               std::to_string(values * 2 * sizeof(float) >> 20) +
                               " MiB to read; only " + std::to_string(max_bytes >> 20) +
                               " MiB are available");
    }
    std::vector<float> pixels(values);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data())) {
      throw std::runtime_error(or_default(in->geterror(), "read failed"));
    }
    in->close();
    out.pixels.reserve(pixels.size());
    for (float v : pixels) out.pixels.push_back(v);
    return out;
  });
}

ExrData read_exr(rust::Str path_str) {
  return guard("OpenImageIO", [&] {
    const std::string path(path_str);
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
      throw std::runtime_error(or_default(OIIO::geterror(), "cannot open image"));
    }
    const std::string format_name = in->format_name();
    if (format_name != "openexr") {
      throw std::runtime_error("not an OpenEXR file (OpenImageIO reads it as " + format_name + ")");
    }
    const OIIO::ImageSpec &spec = in->spec();
    if (spec.deep) {
      throw std::runtime_error("deep EXRs are not supported");
    }
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth > 1) {
      throw std::runtime_error("not a 2D image");
    }
    const size_t nch = size_t(spec.nchannels);
    ExrData out;
    out.width = uint32_t(spec.width);
    out.height = uint32_t(spec.height);
    // Byte offset of each channel inside one natively packed pixel.
    std::vector<size_t> offsets(nch);
    size_t pixel_bytes = 0;
    for (size_t c = 0; c < nch; ++c) {
      const OIIO::TypeDesc type = spec.channelformat(int(c));
      out.channels.push_back(ChannelInfo{rust::String::lossy(spec.channelnames[c]),
                                         channel_format(type)});
      offsets[c] = pixel_bytes;
      pixel_bytes += type.size();
    }
    // Native formats: OpenImageIO would normalise uint channels to [0, 1].
    const size_t npixels = size_t(spec.width) * spec.height;
    std::vector<unsigned char> native(npixels * pixel_bytes);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UNKNOWN, native.data())) {
      throw std::runtime_error(or_default(in->geterror(), "read failed"));
    }
    in->close();
    out.pixels.reserve(npixels * nch);
    for (size_t p = 0; p < npixels; ++p) {
      const unsigned char *pixel = native.data() + p * pixel_bytes;
      for (size_t c = 0; c < nch; ++c) {
        out.pixels.push_back(widen(pixel + offsets[c], out.channels[c].format));
      }
    }
    for (const auto &attr : spec.extra_attribs) {
      if (attr.type() == OIIO::TypeDesc::STRING) {
        out.strings.push_back(StringAttribute{rust::String::lossy(attr.name().string()),
                                              rust::String::lossy(attr.get_string())});
      }
    }
    return out;
  });
}

bool write_display_png(const DisplayPngRequest &req) {
  return guard("OpenImageIO", [&] {
    const std::string path(req.path);
    if (req.pixels.size() != size_t(req.width) * req.height * 3) {
      throw std::invalid_argument("pixel buffer size does not match width x height x 3");
    }
    OIIO::ImageBuf buf(OIIO::ImageSpec(int(req.width), int(req.height), 3, OIIO::TypeDesc::FLOAT));
    if (!buf.set_pixels(buf.roi(), OIIO::TypeDesc::FLOAT, req.pixels.data())) {
      throw std::runtime_error(or_default(buf.geterror(), "cannot fill image"));
    }
    if (!OIIO::ImageBufAlgo::colorconvert(buf, buf, "linear", "sRGB")) {
      throw std::runtime_error(or_default(buf.geterror(), "sRGB encoding failed"));
    }
    const std::optional<std::string> font = label_font();
    if (font) {
      const float white[3] = {1.0f, 1.0f, 1.0f};
      for (const auto &label : req.labels) {
        if (!OIIO::ImageBufAlgo::render_text(buf, label.x, label.y, std::string(label.text),
                                             LABEL_FONT_SIZE, *font, white,
                                             OIIO::ImageBufAlgo::TextAlignX::Left,
                                             OIIO::ImageBufAlgo::TextAlignY::Top, 1)) {
          throw std::runtime_error(or_default(buf.geterror(), "cannot draw a label"));
        }
      }
    }
    buf.set_write_format(OIIO::TypeDesc::UINT8);
    if (!buf.write(path)) {
      throw std::runtime_error(or_default(buf.geterror(), "write failed"));
    }
    return font.has_value();
  });
}

} // namespace oiio
} // namespace cirrus
