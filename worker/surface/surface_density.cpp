#include "surface/surface_density.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/median.h"
#include "core/vec3.h"

namespace vpr {
StatusOr<DensityMode> parse_density_mode(const std::string& name) {
  if (name == "perception") return DensityMode::kPerception;
  if (name == "curvature") return DensityMode::kCurvature;
  if (name == "uniform") return DensityMode::kUniform;
  if (name == "paper") return DensityMode::kPaper;
  return invalid_argument("density '" + name + "' is not one of perception, curvature, uniform, paper");
}

const char* density_mode_name(DensityMode mode) {
  switch (mode) {
    case DensityMode::kPerception:
      return "perception";
    case DensityMode::kCurvature:
      return "curvature";
    case DensityMode::kUniform:
      return "uniform";
    case DensityMode::kPaper:
      return "paper";
  }
  return "perception";
}

std::vector<double> mean_curvature(const Mesh& mesh) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<Vec3d> normal(nf);
  std::vector<double> area(nv, 0.0), integral(nv, 0.0);
  struct Half {
    uint64_t key;
    uint32_t face;
  };
  std::vector<Half> halves;
  halves.reserve(3 * nf);
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* t = &mesh.indices[3 * f];
    const Vec3d a = load3d(mesh.positions.data(), t[0]), b = load3d(mesh.positions.data(), t[1]),
                c = load3d(mesh.positions.data(), t[2]);
    const Vec3d n = cross(b - a, c - a);
    const double len = norm(n);
    normal[f] = len > 0 ? n * (1.0 / len) : Vec3d{0, 0, 0};
    for (int k = 0; k < 3; ++k) area[t[k]] += len / 6.0;
    for (int k = 0; k < 3; ++k) {
      const uint64_t u = t[k], w = t[(k + 1) % 3];
      halves.push_back({u < w ? (u << 32 | w) : (w << 32 | u), uint32_t(f)});
    }
  }
  std::sort(halves.begin(), halves.end(), [](const Half& x, const Half& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  for (size_t i = 0; i < halves.size();) {
    size_t j = i;
    while (j < halves.size() && halves[j].key == halves[i].key) ++j;
    // The largest angle between the normals of the edge's faces (two on a manifold edge).
    double angle = 0;
    for (size_t p = i; p < j; ++p)
      for (size_t q = p + 1; q < j; ++q)
        angle = std::max(angle, std::acos(std::clamp(dot(normal[halves[p].face], normal[halves[q].face]), -1.0, 1.0)));
    const uint32_t u = uint32_t(halves[i].key >> 32), w = uint32_t(halves[i].key);
    const double length = norm(load3d(mesh.positions.data(), u) - load3d(mesh.positions.data(), w));
    integral[u] += 0.25 * angle * length;
    integral[w] += 0.25 * angle * length;
    i = j;
  }
  std::vector<double> h(nv, 0.0);
  for (size_t v = 0; v < nv; ++v) h[v] = area[v] > 0 ? integral[v] / area[v] : 0.0;
  return h;
}

std::vector<float> vertex_density(const Mesh& mesh, const std::vector<float>& importance, DensityMode mode) {
  if (mode == DensityMode::kUniform || mode == DensityMode::kPaper) return std::vector<float>(mesh.vertex_count(), 1.0f);
  return vertex_density(mean_curvature(mesh), importance, mode);
}

std::vector<float> vertex_density(const std::vector<double>& h, const std::vector<float>& importance,
                                  DensityMode mode) {
  const size_t nv = h.size();
  std::vector<float> d(nv, 1.0f);
  if (mode == DensityMode::kUniform || mode == DensityMode::kPaper) return d;
  const double ref = typical_positive_value(h);  // mostly flat (CAD): the typical curved vertex sets the scale
  if (ref > 0)
    for (size_t v = 0; v < nv; ++v) {
      const double ratio = h[v] / ref;  // NaN only for inf / inf (a degenerate input): the strongest
      d[v] = float(std::isnan(ratio) ? 3.0 : std::clamp(std::sqrt(ratio), 0.3, 3.0));
    }
  if (mode == DensityMode::kPerception && importance.size() == nv) {
    std::vector<double> imp(importance.begin(), importance.end());
    const double mid = median_of(imp);
    if (mid > 0)
      for (size_t v = 0; v < nv; ++v) d[v] *= float(std::clamp(std::sqrt(double(importance[v]) / mid), 0.5, 2.0));
  }
  return d;
}

void smooth_over_edges(const Mesh& mesh, int iterations, int channels, int channel, std::vector<float>* values) {
  smooth_over_edges(mesh_edges(mesh), iterations, channels, channel, values);
}

void smooth_over_edges(const MeshEdges& edges, int iterations, int channels, int channel, std::vector<float>* values) {
  const size_t nv = edges.vertex_count(), k = size_t(channels);
  // The channel in its own arrays (one read per neighbour, not a strided
  // one); each vertex sums its neighbours in ascending order, in double, so
  // the result is the same on any thread count.
  std::vector<float> now(nv), next(nv);
  for (size_t v = 0; v < nv; ++v) now[v] = (*values)[k * v + channel];
  for (int it = 0; it < iterations; ++it) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) {
        const size_t n = edges.degree(uint32_t(v));
        if (n == 0) {
          next[v] = now[v];
          continue;
        }
        double sum = 0;
        for (const uint32_t* w = edges.begin(uint32_t(v)); w != edges.end(uint32_t(v)); ++w) sum += now[*w];
        next[v] = float(0.5 * now[v] + 0.5 * sum / double(n));
      }
    });
    now.swap(next);
  }
  for (size_t v = 0; v < nv; ++v) (*values)[k * v + channel] = now[v];
}

}  // namespace vpr
