// Stage 4 for the surface back half: the attention field (attention_field.h).
#include "saliency/attention_field.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <functional>
#include <numeric>
#include <string>

#include "core/bucket_sort.h"
#include "core/median.h"

namespace vpr {
namespace {

// x / median capped at `cap`; a median of 0 (mostly flat, CAD) takes the
// median of the positive values instead, and all-flat gives 1 everywhere.
std::vector<double> over_median(const float* x, size_t n, double cap) {
  // A degenerate face's curvature can overflow (its weighted mean becomes
  // inf): the median is taken over finite values, and an infinite value is
  // as strong as a cue gets, the cap.
  std::vector<double> finite;
  finite.reserve(n);
  for (size_t i = 0; i < n; ++i)
    if (std::isfinite(x[i])) finite.push_back(x[i]);
  const double ref = typical_positive_value(finite);
  std::vector<double> v(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const double t = x[i];
      v[i] = !std::isfinite(t) ? cap : ref > 0 ? std::min(t / ref, cap) : 1.0;
    }
  });
  return v;
}

// Vertices by value: a stable LSD radix sort on the values' bits (finite
// non-negative doubles order as their bit patterns do; -0.0 counts as +0.0),
// 11 bits a pass, passes every value agrees on skipped. Equal values come
// out by vertex. A few linear passes over the values, where a comparison
// sort through the index array reads them at random n log n times.
std::vector<uint32_t> order_by_value(const std::vector<double>& raw) {
  const size_t n = raw.size();
  std::vector<uint64_t> key(n), key_next(n);
  std::vector<uint32_t> order(n), order_next(n);
  for (size_t v = 0; v < n; ++v) {
    assert(raw[v] >= 0.0 && std::isfinite(raw[v]));  // as finish_attention_field makes them
    const double x = raw[v] == 0.0 ? 0.0 : raw[v];
    std::memcpy(&key[v], &x, sizeof x);
    order[v] = uint32_t(v);
  }
  constexpr int kBits = 11;
  constexpr size_t kBuckets = size_t(1) << kBits;
  std::vector<uint32_t> start(kBuckets + 1);
  for (int shift = 0; shift < 64; shift += kBits) {
    std::fill(start.begin(), start.end(), 0u);
    for (size_t i = 0; i < n; ++i) ++start[((key[i] >> shift) & (kBuckets - 1)) + 1];
    if (std::find(start.begin() + 1, start.end(), uint32_t(n)) != start.end()) continue;  // one digit for all
    std::partial_sum(start.begin(), start.end(), start.begin());
    for (size_t i = 0; i < n; ++i) {
      const uint32_t slot = start[(key[i] >> shift) & (kBuckets - 1)]++;
      key_next[slot] = key[i];
      order_next[slot] = order[i];
    }
    key.swap(key_next);
    order.swap(order_next);
  }
  return order;
}

}  // namespace

Status check_attention_field_args(const AttentionFieldOptions& o, size_t vertex_count, const float* curvature,
                                  FeaturePoints features) {
  if (!(o.coarse_sigma > 0.0f && o.coarse_sigma <= 0.5f))
    return invalid_argument("attention field: coarse_sigma = " + std::to_string(o.coarse_sigma) +
                            " of the diagonal, it must lie in (0, 0.5]");
  if (!(o.curvature_cap >= 1.0f) || !std::isfinite(o.curvature_cap))
    return invalid_argument("attention field: curvature_cap = " + std::to_string(o.curvature_cap) +
                            ", it must be finite and at least 1");
  if (!(o.view_bias >= 0.0f && o.view_bias <= 1.0f))
    return invalid_argument("attention field: view_bias = " + std::to_string(o.view_bias) + ", it must lie in [0, 1]");
  if (o.view_bias > 0.0f && !(dot(o.view_direction, o.view_direction) > 0.0f))
    return invalid_argument("attention field: view_direction is zero or not finite");
  if (!(o.concave_weight >= 0.0f && o.concave_weight <= 1.0f))
    return invalid_argument("attention field: concave_weight = " + std::to_string(o.concave_weight) +
                            ", it must lie in [0, 1]");
  if (!(o.min_importance > 0.0f && o.min_importance <= 1.0f))
    return invalid_argument("attention field: min_importance = " + std::to_string(o.min_importance) +
                            ", it must lie in (0, 1]");
  if (vertex_count > 0 && curvature == nullptr) return invalid_argument("attention field: no curvature given");
  if (features.count > 0 && features.xyz == nullptr)
    return invalid_argument("attention field: feature points are null");
  if (features.count >= (size_t(1) << 31))
    return resource_exhausted("attention field: " + std::to_string(features.count) +
                              " feature points, the limit is 2^31");
  if (vertex_count >= (size_t(1) << 31))
    return resource_exhausted("attention field: " + std::to_string(vertex_count) + " vertices, the limit is 2^31");
  return Status::Ok();
}

VertexGrid build_vertex_grid(const float* vertices, const float* curvature, size_t n,
                             const AttentionFieldOptions& options) {
  VertexGrid g;
  float hi[3];
  for (int a = 0; a < 3; ++a) g.lo[a] = hi[a] = n ? vertices[a] : 0.0f;
  for (size_t v = 0; v < n; ++v)
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = std::min(g.lo[a], vertices[3 * v + a]);
      hi[a] = std::max(hi[a], vertices[3 * v + a]);
    }
  double diagonal2 = 0;
  for (int a = 0; a < 3; ++a) diagonal2 += double(hi[a] - g.lo[a]) * double(hi[a] - g.lo[a]);
  g.sigma = options.coarse_sigma * (diagonal2 > 0 ? float(std::sqrt(diagonal2)) : 1.0f);
  g.cell = 2.0f * g.sigma;
  // At most 256 cells a side: a coarser cell than asked only widens the scan.
  for (int a = 0; a < 3; ++a) g.cell = std::max(g.cell, (hi[a] - g.lo[a]) / 256.0f);
  for (int a = 0; a < 3; ++a) g.dims[a] = std::max(1, int((hi[a] - g.lo[a]) / g.cell) + 1);
  const size_t cells = size_t(g.dims[0]) * g.dims[1] * g.dims[2];
  std::vector<uint32_t> cell_of(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      int c[3];
      for (int a = 0; a < 3; ++a) {
        const int t = int((vertices[3 * v + a] - g.lo[a]) / g.cell);
        c[a] = std::clamp(t, 0, g.dims[a] - 1);
      }
      cell_of[v] = uint32_t((size_t(c[2]) * g.dims[1] + c[1]) * g.dims[0] + c[0]);
    }
  });
  // Vertices by cell, each cell's in index order (the serial counting sort's
  // order, whatever the schedule), then their positions and curvature.
  bucket_sort<uint32_t>(
      n, cells, [&](size_t v) { return cell_of[v]; }, [](size_t v) { return uint32_t(v); }, std::less<uint32_t>(),
      &g.cell_start, &g.order);
  g.sorted.resize(4 * n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      const uint32_t v = g.order[t];
      for (int a = 0; a < 3; ++a) g.sorted[4 * t + a] = vertices[3 * v + a];
      g.sorted[4 * t + 3] = curvature[v];
    }
  });
  return g;
}

VertexGrid bin_points(const VertexGrid& shape, const float* points, size_t count) {
  VertexGrid g;
  g.sigma = shape.sigma;
  g.cell = shape.cell;
  for (int a = 0; a < 3; ++a) {
    g.lo[a] = shape.lo[a];
    g.dims[a] = shape.dims[a];
  }
  const size_t cells = size_t(g.dims[0]) * g.dims[1] * g.dims[2];
  std::vector<uint32_t> cell_of(count);
  g.cell_start.assign(cells + 1, 0);
  for (size_t i = 0; i < count; ++i) {
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const float t = (points[3 * i + a] - g.lo[a]) / g.cell;  // a float compare: no int overflow far outside
      c[a] = t < 0.0f ? 0 : (t >= float(g.dims[a]) ? g.dims[a] - 1 : std::min(int(t), g.dims[a] - 1));
    }
    cell_of[i] = uint32_t((size_t(c[2]) * g.dims[1] + c[1]) * g.dims[0] + c[0]);
    ++g.cell_start[cell_of[i] + 1];
  }
  std::partial_sum(g.cell_start.begin(), g.cell_start.end(), g.cell_start.begin());
  std::vector<uint32_t> next(g.cell_start.begin(), g.cell_start.end() - 1);
  g.order.resize(count);
  g.sorted.resize(4 * count);
  for (size_t i = 0; i < count; ++i) {
    const uint32_t t = next[cell_of[i]]++;
    g.order[t] = uint32_t(i);
    for (int a = 0; a < 3; ++a) g.sorted[4 * t + a] = points[3 * i + a];
    g.sorted[4 * t + 3] = 1.0f;
  }
  return g;
}

AttentionPrep prepare_attention(const float* vertices, const float* curvature, size_t n,
                                const AttentionFieldOptions& options) {
  AttentionPrep prep;
  prep.grid = build_vertex_grid(vertices, curvature, n, options);
  prep.fine = over_median(curvature, n, options.curvature_cap);
  return prep;
}

void finish_attention_field(const float* vertices, const std::vector<double>& fine, const float* coarse,
                            const float* density, const float* visibility, size_t n, const AttentionFieldOptions& o,
                            std::vector<float>* importance) {
  assert(fine.size() == n);
  const std::vector<double> wide = over_median(coarse, n, o.curvature_cap);
  // The image cue over its median (of the vertices near any feature when most
  // are near none), capped like the curvature maps; all three averaged.
  const std::vector<double> image = density ? over_median(density, n, o.curvature_cap) : std::vector<double>();
  // Nearness along the view direction, 0 at the far end of the model, 1 at the near one.
  const Vec3d d{o.view_direction.x, o.view_direction.y, o.view_direction.z};
  std::vector<double> along(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v)
      along[v] = d.x * vertices[3 * v] + d.y * vertices[3 * v + 1] + d.z * vertices[3 * v + 2];
  });
  double lo = 0, hi = 0;
  for (size_t v = 0; v < n; ++v) {
    lo = v ? std::min(lo, along[v]) : along[v];
    hi = v ? std::max(hi, along[v]) : along[v];
  }
  std::vector<double> raw(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      const double nearness = hi > lo ? (along[v] - lo) / (hi - lo) : 1.0;
      const double cues = density ? (fine[v] + wide[v] + image[v]) / 3.0 : 0.5 * (fine[v] + wide[v]);
      raw[v] = std::sqrt(cues) * (1.0 - o.view_bias + o.view_bias * nearness);
      if (visibility) raw[v] *= std::clamp(double(visibility[v]), 0.0, 1.0);
      // A cue that is not a number (the curvature of a face with a zero-length
      // edge) counts as no cue: NaN would break the sort's ordering below.
      if (!std::isfinite(raw[v])) raw[v] = 0.0;
    }
  });
  // Rank normalization: equal raw values share their mean rank.
  const std::vector<uint32_t> by_value = order_by_value(raw);
  importance->assign(n, 1.0f);
  const double span = 1.0 - double(o.min_importance);
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && raw[by_value[j]] == raw[by_value[i]]) ++j;
    const double rank = n > 1 ? 0.5 * double(i + j - 1) / double(n - 1) : 1.0;
    for (size_t t = i; t < j; ++t) (*importance)[by_value[t]] = float(o.min_importance + span * rank);
    i = j;
  }
}

namespace cpu {

Status attention_field(const float* vertices, const float* curvature, const float* visibility, FeaturePoints features,
                       size_t n, const AttentionFieldOptions& options, std::vector<float>* importance,
                       const ExecContext&, const AttentionPrep* prep) {
  assert(importance != nullptr);
  VPR_RETURN_IF_ERROR(check_attention_field_args(options, n, curvature, features));
  importance->clear();
  if (n == 0) return Status::Ok();
  AttentionPrep own;
  if (!prep) own = prepare_attention(vertices, curvature, n, options);
  const VertexGrid& grid = prep ? prep->grid : own.grid;
  assert(grid.order.size() == n);
  std::vector<float> coarse(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v)
      coarse[v] = coarse_curvature_mean(grid.sorted.data(), grid.cell_start.data(), grid.lo, grid.cell, grid.dims,
                                        vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2], grid.sigma);
  });
  std::vector<float> density;
  if (use_image_cue(options, features)) {
    const VertexGrid points = bin_points(grid, features.xyz, features.count);
    density.resize(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v)
        density[v] =
            feature_point_density(points.sorted.data(), points.cell_start.data(), points.lo, points.cell, points.dims,
                                  vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2], points.sigma);
    });
  }
  finish_attention_field(vertices, prep ? prep->fine : own.fine, coarse.data(),
                         density.empty() ? nullptr : density.data(), visibility, n, options, importance);
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
