// OpenSubdiv side of the bridge. Everything OpenSubdiv-specific stays in this
// file: building a Far::TopologyRefiner from a cage (the OpenSubdiv
// "far_tutorial_1_1" recipe with Far::TopologyDescriptor), uniform refinement,
// Far::PrimvarRefiner for positions and primvars level by level, and its
// Limit() for limit positions and tangents at the finest level's vertices.
// https://graphics.pixar.com/opensubdiv/docs/far_overview.html
#include "cirrus/ffi/guard.h"
#include "cirrus/ffi/opensubdiv/shim.h"
#include "cirrus/ffi/opensubdiv/bridge.rs.h"

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace cirrus {
namespace osd {

using namespace OpenSubdiv;

namespace {

// OpenSubdiv reports through process-wide callbacks; each thread collects its
// own messages, so meshes refined in parallel keep theirs apart.
thread_local std::string messages;

void collect(const char *message) {
  if (!messages.empty()) messages += "; ";
  messages += message;
}

void install_callbacks_once() {
  static std::once_flag flag;
  std::call_once(flag, [] {
    Far::SetErrorCallback([](Far::ErrorType, const char *message) { collect(message); });
    Far::SetWarningCallback(collect);
  });
}

// One value of `width` floats in a flat buffer: the interface PrimvarRefiner
// asks of a primvar (Clear and AddWithWeight), for any width.
struct Value {
  float *p;
  int width;
  void Clear() {
    for (int i = 0; i < width; ++i) p[i] = 0.0f;
  }
  void AddWithWeight(const Value &src, float weight) {
    for (int i = 0; i < width; ++i) p[i] += weight * src.p[i];
  }
};

struct Buffer {
  std::vector<float> data;
  int width;
  Buffer(size_t count, int width) : data(count * width), width(width) {}
  Value operator[](int i) { return Value{data.data() + size_t(i) * width, width}; }
  Value operator[](int i) const {
    return Value{const_cast<float *>(data.data()) + size_t(i) * width, width};
  }
};

const int *ints(const rust::Vec<uint32_t> &v) { return reinterpret_cast<const int *>(v.data()); }

template <typename T> rust::Vec<T> to_rust(const std::vector<T> &v) {
  rust::Vec<T> out;
  out.reserve(v.size());
  for (const T &x : v) out.push_back(x);
  return out;
}

// Refines `src` (values of the level below) level by level to the finest one.
template <typename Step> Buffer refine_levels(const Far::TopologyRefiner &refiner, Buffer src, Step step) {
  for (int level = 1; level <= refiner.GetMaxLevel(); ++level) {
    Buffer dst = step(level, src);
    src = std::move(dst);
  }
  return src;
}

} // namespace

struct CageRefiner::Impl {
  std::unique_ptr<Far::TopologyRefiner> refiner;
};

CageRefiner::CageRefiner(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CageRefiner::~CageRefiner() = default;

std::unique_ptr<CageRefiner> create_refiner(const Cage &cage) {
  return guard("OpenSubdiv", [&] {
    install_callbacks_once();
    messages.clear();
    Sdc::Options options;
    options.SetVtxBoundaryInterpolation(Sdc::Options::VtxBoundaryInterpolation(cage.boundary));
    options.SetFVarLinearInterpolation(Sdc::Options::FVarLinearInterpolation(cage.fvar_linear));
    options.SetTriangleSubdivision(Sdc::Options::TriangleSubdivision(cage.triangle_rule));
    Sdc::SchemeType scheme = cage.scheme == 0   ? Sdc::SCHEME_BILINEAR
                             : cage.scheme == 2 ? Sdc::SCHEME_LOOP
                                                : Sdc::SCHEME_CATMARK;

    std::vector<Far::TopologyDescriptor::FVarChannel> fvar;
    for (const CageChannel &channel : cage.channels) {
      if (!channel.face_varying) continue;
      Far::TopologyDescriptor::FVarChannel c;
      c.numValues = int(channel.values.size() / channel.width);
      c.valueIndices = ints(channel.indices);
      fvar.push_back(c);
    }
    Far::TopologyDescriptor desc;
    desc.numVertices = int(cage.vertex_count);
    desc.numFaces = int(cage.face_counts.size());
    desc.numVertsPerFace = ints(cage.face_counts);
    desc.vertIndicesPerFace = ints(cage.face_indices);
    desc.numCreases = int(cage.crease_weights.size());
    desc.creaseVertexIndexPairs = ints(cage.crease_pairs);
    desc.creaseWeights = cage.crease_weights.data();
    desc.numCorners = int(cage.corner_weights.size());
    desc.cornerVertexIndices = ints(cage.corner_vertices);
    desc.cornerWeights = cage.corner_weights.data();
    desc.numHoles = int(cage.holes.size());
    desc.holeIndices = ints(cage.holes);
    desc.numFVarChannels = int(fvar.size());
    desc.fvarChannels = fvar.data();

    using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
    std::unique_ptr<Far::TopologyRefiner> refiner(
        Factory::Create(desc, Factory::Options(scheme, options)));
    if (!refiner) {
      throw std::runtime_error(messages.empty() ? "topology refused" : messages);
    }
    auto impl = std::make_unique<CageRefiner::Impl>();
    impl->refiner = std::move(refiner);
    return std::make_unique<CageRefiner>(std::move(impl));
  });
}

Refined CageRefiner::refine(const Cage &cage, uint32_t level, bool limit) {
  return guard("OpenSubdiv", [&] {
    messages.clear();
    Far::TopologyRefiner &refiner = *impl_->refiner;
    Far::TopologyRefiner::UniformOptions uniform(static_cast<int>(level));
    uniform.fullTopologyInLastLevel = true;
    refiner.RefineUniform(uniform);
    if (!messages.empty()) throw std::runtime_error(messages);
    Far::PrimvarRefiner primvars(refiner);
    const Far::TopologyLevel &finest = refiner.GetLevel(refiner.GetMaxLevel());

    auto vertex_step = [&](int l, const Buffer &src) {
      Buffer dst(refiner.GetLevel(l).GetNumVertices(), src.width);
      primvars.Interpolate(l, src, dst);
      return dst;
    };
    Buffer cage_positions(cage.vertex_count, 3);
    std::copy(cage.positions.begin(), cage.positions.end(), cage_positions.data.begin());
    Buffer positions = refine_levels(refiner, std::move(cage_positions), vertex_step);

    Refined out;
    if (!limit || cage.scheme == 0) {
      out.positions = to_rust(positions.data);
    } else {
      int n = finest.GetNumVertices();
      Buffer limit(n, 3), du(n, 3), dv(n, 3);
      primvars.Limit(positions, limit, du, dv);
      out.positions = to_rust(limit.data);
      std::vector<float> normals(size_t(n) * 3);
      for (int v = 0; v < n; ++v) {
        const float *a = &du.data[size_t(v) * 3], *b = &dv.data[size_t(v) * 3];
        normals[size_t(v) * 3 + 0] = a[1] * b[2] - a[2] * b[1];
        normals[size_t(v) * 3 + 1] = a[2] * b[0] - a[0] * b[2];
        normals[size_t(v) * 3 + 2] = a[0] * b[1] - a[1] * b[0];
      }
      out.normals = to_rust(normals);
    }

    std::vector<int> kept;
    for (int f = 0; f < finest.GetNumFaces(); ++f) {
      if (finest.IsFaceHole(f)) continue;
      kept.push_back(f);
      Far::ConstIndexArray verts = finest.GetFaceVertices(f);
      out.face_counts.push_back(uint32_t(verts.size()));
      for (int i = 0; i < verts.size(); ++i) out.face_vertices.push_back(uint32_t(verts[i]));
      int base = f;
      for (int l = refiner.GetMaxLevel(); l > 0; --l) base = refiner.GetLevel(l).GetFaceParentFace(base);
      out.base_faces.push_back(uint32_t(base));
    }

    int fvar_channel = 0;
    for (const CageChannel &channel : cage.channels) {
      int width = int(channel.width);
      Buffer values(channel.values.size() / width, width);
      std::copy(channel.values.begin(), channel.values.end(), values.data.begin());
      RefinedChannel refined;
      if (channel.face_varying) {
        int c = fvar_channel++;
        Buffer fine = refine_levels(refiner, std::move(values), [&](int l, const Buffer &src) {
          Buffer dst(refiner.GetLevel(l).GetNumFVarValues(c), width);
          primvars.InterpolateFaceVarying(l, src, dst, c);
          return dst;
        });
        refined.values = to_rust(fine.data);
        for (int f : kept) {
          Far::ConstIndexArray idx = finest.GetFaceFVarValues(f, c);
          for (int i = 0; i < idx.size(); ++i) refined.indices.push_back(uint32_t(idx[i]));
        }
      } else {
        refined.values = to_rust(refine_levels(refiner, std::move(values), vertex_step).data);
        refined.indices = out.face_vertices;
      }
      out.channels.push_back(std::move(refined));
    }
    return out;
  });
}

} // namespace osd
} // namespace cirrus
