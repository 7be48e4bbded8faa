#include "surface/surface_density.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <future>
#include <numeric>
#include <utility>

#include "core/bucket_sort.h"
#include "core/median.h"
#include "core/mesh_parts.h"
#include "core/step_marks.h"
#include "core/vec3.h"
#include "surface/curvature_terms.h"

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
  std::vector<double> h;
  mean_curvatures(mesh, 1.0, &h, nullptr);
  return h;
}

namespace {

// Six times the signed volume of the tetrahedron from o to face f.
double face_volume6(const Mesh& mesh, size_t f, Vec3d o) {
  const float* p = mesh.positions.data();
  const uint32_t* t = &mesh.indices[3 * f];
  return dot(load3d(p, t[0]) - o, cross(load3d(p, t[1]) - o, load3d(p, t[2]) - o));
}

}  // namespace

double signed_volume(const Mesh& mesh) {
  const Aabb box = bounding_box(mesh);
  const Vec3d o{0.5 * (double(box.lo[0]) + box.hi[0]), 0.5 * (double(box.lo[1]) + box.hi[1]),
                0.5 * (double(box.lo[2]) + box.hi[2])};
  double v = 0;
  for (size_t f = 0; f < mesh.face_count(); ++f) v += face_volume6(mesh, f, o);
  return v / 6.0;
}

std::vector<char> faces_outwards(const Mesh& mesh) {
  const size_t nf = mesh.face_count();
  size_t parts = 0;
  const std::vector<uint32_t> part = face_parts(mesh, &parts);
  const float* p = mesh.positions.data();
  // Each part's bounding box: a min and max, the same in any order, so each
  // thread boxes its own faces and the boxes are merged (one loop where
  // parts are so many that a box per part per thread costs more).
  using Box = std::pair<Vec3d, Vec3d>;
  const Box empty{Vec3d{HUGE_VAL, HUGE_VAL, HUGE_VAL}, Vec3d{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}};
  auto include = [](Box& b, const Vec3d& lo, const Vec3d& hi) {
    b.first = {std::min(b.first.x, lo.x), std::min(b.first.y, lo.y), std::min(b.first.z, lo.z)};
    b.second = {std::max(b.second.x, hi.x), std::max(b.second.y, hi.y), std::max(b.second.z, hi.z)};
  };
  auto grow = [&](std::vector<Box>& box, size_t lo, size_t hi) {
    for (size_t f = lo; f < hi; ++f)
      if (part[f] != UINT32_MAX)
        for (int c = 0; c < 3; ++c) {
          const Vec3d x = load3d(p, mesh.indices[3 * f + c]);
          include(box[part[f]], x, x);
        }
  };
  std::vector<Box> box(parts, empty);
  if (parts <= 1024) {
    tbb::enumerable_thread_specific<std::vector<Box>> local([&] { return std::vector<Box>(parts, empty); });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 16384),
                      [&](const tbb::blocked_range<size_t>& r) { grow(local.local(), r.begin(), r.end()); });
    for (const std::vector<Box>& mine : local)
      for (size_t k = 0; k < parts; ++k) include(box[k], mine[k].first, mine[k].second);
  } else {
    grow(box, 0, nf);
  }
  // Each face's term in parallel, then summed in face order: the same bits as
  // one loop adding them as it goes.
  std::vector<double> term(nf, 0.0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f)
      if (part[f] != UINT32_MAX) term[f] = face_volume6(mesh, f, 0.5 * (box[part[f]].first + box[part[f]].second));
  });
  std::vector<double> volume(parts, 0.0);
  for (size_t f = 0; f < nf; ++f)
    if (part[f] != UINT32_MAX) volume[part[f]] += term[f];
  std::vector<char> out(nf, 1);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) out[f] = part[f] == UINT32_MAX || volume[part[f]] >= 0;
  });
  return out;
}

// The sums run in parallel with the same bits as one thread adding edge by
// edge in (lower vertex, upper vertex) order and face by face: each vertex
// gathers its own terms in that order (the faces it is a corner of, in face
// order; its edges to lower vertices, then to higher ones, each ascending).
void mean_curvatures(const Mesh& mesh, double concave_weight, std::vector<double>* mean,
                     std::vector<double>* weighted) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  const float* p = mesh.positions.data();
  const uint32_t* idx = mesh.indices.data();
  StepMarks marks("mean_curvatures");
  // Which way each part faces (for the concave edges' weight): its parts are
  // found by one serial union-find over the faces, so on its own thread
  // beside the sorts below (1M faces: a fifth of the curvature's time on 2
  // cores, which the sorts' threads left idle).
  const bool weigh = weighted != nullptr;
  std::future<std::vector<char>> outwards_beside;
  if (weigh && concave_weight != 1.0)
    outwards_beside = std::async(std::launch::async, [&mesh] { return faces_outwards(mesh); });
  std::vector<Vec3d> normal(nf);
  std::vector<double> twice_area(nf);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) face_normal_area(p, &idx[3 * f], &normal[f], &twice_area[f]);
  });
  // Corner i of face i / 3 and its half-edge to the next corner.
  auto from = [&](size_t i) { return idx[i]; };
  auto to = [&](size_t i) { return idx[i - i % 3 + (i % 3 + 1) % 3]; };
  // Each vertex's faces, in face order.
  std::vector<uint32_t> corner_start, corner_face;
  bucket_sort<uint32_t>(
      3 * nf, nv, from, [](size_t i) { return uint32_t(i / 3); }, std::less<uint32_t>(), &corner_start, &corner_face);
  marks.mark("normals_corners");
  // The half-edges by lower vertex, each bucket in (upper vertex, face) order.
  struct Half {
    uint32_t upper, face;
  };
  std::vector<uint32_t> start;
  std::vector<Half> halves;
  bucket_sort<Half>(
      3 * nf, nv, [&](size_t i) { return std::min(from(i), to(i)); },
      [&](size_t i) {
        return Half{std::max(from(i), to(i)), uint32_t(i / 3)};
      },
      [](const Half& x, const Half& y) { return x.upper != y.upper ? x.upper < y.upper : x.face < y.face; }, &start,
      &halves);
  marks.mark("halves");
  // Edges: runs of equal (lower, upper), numbered in that order.
  std::vector<uint32_t> edge_start(nv + 1, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v)
      for (uint32_t i = start[v]; i < start[v + 1]; ++i)
        edge_start[v + 1] += i == start[v] || halves[i].upper != halves[i - 1].upper;
  });
  std::partial_sum(edge_start.begin(), edge_start.end(), edge_start.begin());
  const size_t ne = edge_start[nv];
  std::vector<uint32_t> edge_begin(ne + 1), edge_lower(ne);
  edge_begin[ne] = uint32_t(3 * nf);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      uint32_t e = edge_start[v];
      for (uint32_t i = start[v]; i < start[v + 1]; ++i)
        if (i == start[v] || halves[i].upper != halves[i - 1].upper) {
          edge_lower[e] = uint32_t(v);
          edge_begin[e++] = i;
        }
    }
  });
  // Each edge's term, 1/4 |dihedral angle| x length; weighted: the same
  // times concave_weight where the edge is concave (an edge of two faces
  // that run along it in opposite directions, the far corner of one below the
  // other's plane, for a part facing outwards: a part with a negative signed
  // volume turns the test round; an edge whose faces disagree on their
  // orientation keeps its whole term).
  marks.mark("edges");
  const std::vector<char> outwards = outwards_beside.valid() ? outwards_beside.get() : std::vector<char>();
  marks.mark("outwards_wait");
  const auto face_of = [&](uint32_t i) { return halves[i].face; };
  std::vector<double> term(ne), weighted_term(weigh ? ne : 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ne, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t e = r.begin(); e != r.end(); ++e) {
      const double angle = edge_angle(edge_min_cosine(normal.data(), face_of, edge_begin[e], edge_begin[e + 1]));
      edge_curvature_terms(p, idx, normal.data(), face_of, edge_begin[e], edge_begin[e + 1], edge_lower[e],
                           halves[edge_begin[e]].upper, angle, weigh, concave_weight, outwards.data(), &term[e],
                           weigh ? &weighted_term[e] : nullptr);
    }
  });
  marks.mark("terms");
  // Each vertex's edges to lower vertices, ascending.
  std::vector<uint32_t> down_start, down;
  bucket_sort<uint32_t>(
      ne, nv, [&](size_t e) { return halves[edge_begin[e]].upper; }, [](size_t e) { return uint32_t(e); },
      std::less<uint32_t>(), &down_start, &down);
  // Per vertex, the sum of its edges' terms over its area, for each term array.
  const auto upper_of = [&](uint32_t e) { return halves[edge_begin[e]].upper; };
  auto per_vertex = [&](const std::vector<double>& t, std::vector<double>* h) {
    h->assign(nv, 0.0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) {
        const VertexCurvatureRows rows{twice_area.data(), corner_face.data(), corner_start[v],  corner_start[v + 1],
                                       down.data(),       down_start[v],      down_start[v + 1], edge_lower.data(),
                                       edge_start[v],     edge_start[v + 1]};
        (*h)[v] = vertex_curvature(uint32_t(v), rows, t.data(), upper_of);
      }
    });
  };
  marks.mark("down");
  if (mean) per_vertex(term, mean);
  if (weighted) per_vertex(weighted_term, weighted);
  marks.mark("per_vertex");
}

Status check_attention_boost(const AttentionBoost& b) {
  char text[128];
  if (!(b.top > 0 && b.top <= 1)) {
    std::snprintf(text, sizeof text, "attention top share (--attention-top) %g is outside (0, 1]", b.top);
    return invalid_argument(text);
  }
  if (!(b.boost >= 1 && b.boost <= 4)) {
    std::snprintf(text, sizeof text, "attention boost (--attention-boost) %g is outside [1, 4]", b.boost);
    return invalid_argument(text);
  }
  return Status::Ok();
}

std::vector<float> vertex_density(const Mesh& mesh, const std::vector<float>& importance, DensityMode mode,
                                  const AttentionBoost& boost) {
  if (mode == DensityMode::kUniform || mode == DensityMode::kPaper)
    return std::vector<float>(mesh.vertex_count(), 1.0f);
  return vertex_density(mean_curvature(mesh), importance, mode, boost);
}

std::vector<float> vertex_density(const std::vector<double>& h, const std::vector<float>& importance, DensityMode mode,
                                  const AttentionBoost& boost) {
  const size_t nv = h.size();
  std::vector<float> d(nv, 1.0f);
  if (mode == DensityMode::kUniform || mode == DensityMode::kPaper) return d;
  const double ref = typical_positive_value(h);  // mostly flat (CAD): the typical curved vertex sets the scale
  if (ref > 0)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) {
        const double ratio = h[v] / ref;  // NaN only for inf / inf (a degenerate input): the strongest
        d[v] = float(std::isnan(ratio) ? 3.0 : std::clamp(std::sqrt(ratio), 0.3, 3.0));
      }
    });
  if (mode == DensityMode::kPerception && importance.size() == nv && nv > 0) {
    // Ranks by importance (non-finite values lowest, then by index: one
    // order on every machine); a run of equal values shares its mean rank.
    // Sorted as (key, index) pairs on the job's threads: the pairs are all
    // distinct, so there is one sorted order; an index sort reading
    // importance[] through its comparator, on one thread, was most of the
    // 10 ms the 1M-triangle job's density stage spent here on an H100 host.
    std::vector<std::pair<float, uint32_t>> ranked(nv);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v)
        ranked[v] = {std::isfinite(importance[v]) ? importance[v] : -INFINITY, uint32_t(v)};
    });
    tbb::parallel_sort(ranked.begin(), ranked.end());
    const double last = double(std::max<size_t>(nv - 1, 1));
    for (size_t i = 0; i < nv;) {
      size_t j = i + 1;
      while (j < nv && ranked[j].first == ranked[i].first) ++j;
      const double q = 0.5 * double(i + j - 1) / last;
      const double above = q - (1.0 - boost.top);
      if (above > 0) {
        const float f = float(std::pow(boost.boost, std::min(above / boost.top, 1.0)));
        for (size_t k = i; k < j; ++k) d[ranked[k].second] *= f;
      }
      i = j;
    }
  }
  return d;
}

void smooth_over_edges(const Mesh& mesh, int iterations, int channels, int channel, std::vector<float>* values) {
  smooth_over_edges(mesh_edges(mesh), iterations, channels, channel, values);
}

bool smooth_over_edges(const MeshEdges& edges, int iterations, int channels, int channel, std::vector<float>* values,
                       const ScalarEdgeSmoothing& device) {
  const size_t nv = edges.vertex_count(), k = size_t(channels);
  // The channel in its own array (one read per neighbour, not a strided
  // one); each vertex sums its neighbours in ascending order, in double
  // (smoothed_scalar), so the result is the same on any thread count and
  // either twin.
  std::vector<float> now(nv);
  for (size_t v = 0; v < nv; ++v) now[v] = (*values)[k * v + channel];
  std::vector<float> smoothed = now;
  const bool on_device = device && device(edges, iterations, &smoothed).ok();
  if (!on_device) {
    smoothed = std::move(now);
    (void)cpu::smooth_over_edges(edges, iterations, &smoothed);  // one value per vertex: cannot fail
  }
  for (size_t v = 0; v < nv; ++v) (*values)[k * v + channel] = smoothed[v];
  return on_device;
}

}  // namespace vpr
