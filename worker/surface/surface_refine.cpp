#include "surface/surface_refine.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "core/collect_in_order.h"
#include "core/step_marks.h"
#include "core/uninitialized_vector.h"
#include "core/vec3.h"
#include "surface/pinch_split.h"
#include "surface/rim_band.h"

namespace vpr {
namespace {

Vec3d at(const std::vector<double>& p, uint32_t i) {
  return {p[3 * size_t(i)], p[3 * size_t(i) + 1], p[3 * size_t(i) + 2]};
}

}  // namespace

StatusOr<RefinedSurface> refine_geometry(const Mesh& input, double max_edge, size_t max_vertices) {
  return refine_geometry(input, EdgeBounds{max_edge, 0, 0}, max_vertices);
}

StatusOr<RefinedSurface> refine_geometry(const Mesh& input, const EdgeBounds& bounds, size_t max_vertices,
                                         const MeshEdgesTwin& edge_rows) {
  const double max_edge = bounds.max_edge;
  if (!(max_edge > 0) || !std::isfinite(max_edge)) return invalid_argument("refine: max_edge must be positive");
  const bool banded = bounds.rim_max_edge > 0 && bounds.rim_max_edge < max_edge && bounds.rim_band > 0 &&
                      std::isfinite(bounds.rim_band);
  StepMarks marks("refine");
  RefinedSurface out;
  out.input_vertices = input.vertex_count();
  size_t count = 0;  // refined vertices
  // Weld exact duplicates (the lowest index wins, so a welded mesh keeps its
  // order): vertices sorted by position, then by index, so each run of equal
  // positions starts with the vertex that keeps it.
  const size_t n_in = input.vertex_count();
  struct Keyed {
    uint32_t key[3], v;
    bool operator<(const Keyed& o) const {
      return key[0] != o.key[0]   ? key[0] < o.key[0]
             : key[1] != o.key[1] ? key[1] < o.key[1]
             : key[2] != o.key[2] ? key[2] < o.key[2]
                                  : v < o.v;
    }
  };
  // A float's order as an integer's (+0 and -0 one position; a NaN only its own bits).
  auto order_key = [](float f) -> uint32_t {
    if (f == 0) return 0x80000000u;
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
  };
  std::vector<Keyed> sorted(n_in);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n_in, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v)
      sorted[v] = {{order_key(input.positions[3 * v]), order_key(input.positions[3 * v + 1]),
                    order_key(input.positions[3 * v + 2])},
                   uint32_t(v)};
  });
  tbb::parallel_sort(sorted.begin(), sorted.end());  // a total order: the same result on any thread count
  // Each run of equal positions is kept by its first entry's vertex: the
  // last run start at or before an entry, a running maximum; the kept
  // vertices numbered in index order, a running count (both parallel scans:
  // integers, one result; the two loops were serial steps of the
  // refinement, which the front half waits for).
  std::vector<uint32_t> keeper(n_in);
  auto starts_run = [&](size_t i) {
    return i == 0 || !std::equal(sorted[i].key, sorted[i].key + 3, sorted[i - 1].key);
  };
  tbb::parallel_scan(
      tbb::blocked_range<size_t>(0, n_in, 16384), size_t(0),
      [&](const tbb::blocked_range<size_t>& r, size_t lead, bool final) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          if (starts_run(i)) lead = i;
          if (final) keeper[sorted[i].v] = sorted[lead].v;
        }
        return lead;
      },
      [](size_t a, size_t b) { return std::max(a, b); });
  std::vector<uint32_t> weld(n_in);
  count = tbb::parallel_scan(
      tbb::blocked_range<size_t>(0, n_in, 16384), size_t(0),
      [&](const tbb::blocked_range<size_t>& r, size_t kept, bool final) {
        for (size_t v = r.begin(); v != r.end(); ++v)
          if (keeper[v] == v) {
            if (final) weld[v] = uint32_t(kept);
            ++kept;
          }
        return kept;
      },
      [](size_t a, size_t b) { return a + b; });
  out.mesh.positions.resize(3 * count);
  out.source.resize(count);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n_in, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      if (keeper[v] != v) {
        weld[v] = weld[keeper[v]];  // a keeper, numbered by the scan
        continue;
      }
      std::copy_n(input.positions.begin() + 3 * v, 3, out.mesh.positions.begin() + 3 * size_t(weld[v]));
      out.source[weld[v]] = uint32_t(v);
    }
  });
  marks.mark("weld");
  std::vector<double> pos(out.mesh.positions.begin(), out.mesh.positions.end());  // double while splitting
  // The faces kept: welded corners distinct and an area above zero (else no
  // surface to sample), in face order.
  out.face = collect_in_order<uint32_t>(input.face_count(), [&](size_t f, std::vector<uint32_t>* kept) {
    const uint32_t a = weld[input.indices[3 * f]], b = weld[input.indices[3 * f + 1]],
                   c = weld[input.indices[3 * f + 2]];
    if (a == b || b == c || c == a) return;
    const Vec3d pa = at(pos, a), pb = at(pos, b), pc = at(pos, c);
    if (norm(cross(pb - pa, pc - pa)) > 0) kept->push_back(uint32_t(f));
  });
  out.mesh.indices.resize(3 * out.face.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, out.face.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k != r.end(); ++k)
      for (int c = 0; c < 3; ++c) out.mesh.indices[3 * k + c] = weld[input.indices[3 * size_t(out.face[k]) + c]];
  });
  if (out.mesh.indices.empty()) return invalid_argument("refine: the mesh has no face of positive area");
  marks.mark("faces");
  // Pinched vertices and edges (sheets that meet at a vertex only, or three
  // or more faces on an edge): a copy per extra fan (surface/pinch_split.h).
  std::vector<std::pair<uint32_t, uint32_t>> open_edges;
  out.pinch_copies = split_pinched_vertices(&out.mesh.indices, &count, pos, banded ? &open_edges : nullptr);
  for (const auto& [copy, original] : out.pinch_copies)
    for (int c = 0; c < 3; ++c) pos.push_back(pos[3 * size_t(original) + c]);
  marks.mark("pinch");
  // Per vertex: whether it lies in the rim band (its edges take the finer
  // bound). A midpoint is tested where it is made: a long rim edge's
  // midpoints lie on the rim though its ends may be far from each other.
  // The band's grid holds fewer points than the rims would need vertices at
  // the finer bound (its points are radius / 2 apart, radius >= the bound in
  // the pipeline): past the bound the refinement could not finish anyway.
  if (banded && RimBand::points_needed(pos, open_edges, bounds.rim_band) > double(max_vertices))
    return resource_exhausted("refining the surface near its " + std::to_string(open_edges.size()) +
                              " open edges would need over " + std::to_string(max_vertices) + " vertices");
  const RimBand rim = banded ? RimBand(pos, open_edges, bounds.rim_band) : RimBand();
  std::vector<char> near_rim;
  auto mark_rim = [&](size_t begin, size_t end) {
    near_rim.resize(end, 0);
    if (rim.empty()) return;
    tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) near_rim[v] = rim.near(at(pos, uint32_t(v)));
    });
  };
  mark_rim(0, count);
  marks.mark("rim");

  // Passes of midpoint splits: each face keeps its corners' order, so the
  // refined faces keep the input's orientation. New vertices are numbered
  // in the order the face loop first meets their edge (face by face, corner
  // by corner); the rest of a pass is per face or per new vertex, in
  // parallel, so the result is the same on any thread count.
  const double max2 = max_edge * max_edge;
  const double rim2 = banded ? bounds.rim_max_edge * bounds.rim_max_edge : max2;
  auto length2 = [&](uint32_t a, uint32_t b) {
    const Vec3d d = at(pos, a) - at(pos, b);
    return dot(d, d);
  };
  auto too_long = [&](uint32_t a, uint32_t b) {
    const double l2 = length2(a, b);
    return l2 > max2 || (l2 > rim2 && (near_rim[a] || near_rim[b]));
  };
  // The finished surface's edge rows and corners: the twin's where it
  // answers (the same rows), else made here.
  auto make_rows = [&] {
    if (edge_rows) {
      const Status twin = edge_rows(out.mesh.indices, count, &out.edges, &out.corners);
      if (twin.ok()) {
        out.edges_twin = "gpu";
        return;
      }
      out.edges_twin = twin.to_string();
    }
    out.edges = mesh_edges(out.mesh.indices, count, &out.corners);
  };
  std::vector<uint32_t> fresh;  // the faces the last pass made
  // The passes' faces and per-face arrays, kept from pass to pass and each
  // written in full by a parallel loop before it is read: zero-filling them
  // on one thread, and copying the old contents as they grew, cost about as
  // much as the passes' parallel work on 16 threads.
  UninitializedVector<uint32_t> indices_now(out.mesh.indices.begin(), out.mesh.indices.end()), indices_next;
  UninitializedVector<uint32_t> face_now(out.face.begin(), out.face.end()), face_next;
  UninitializedVector<uint32_t> mid, slots;
  auto fill = [](UninitializedVector<uint32_t>* v, size_t n, uint32_t value) {
    resize_for_overwrite(v, n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 65536), [&](const tbb::blocked_range<size_t>& r) {
      std::fill(v->begin() + r.begin(), v->begin() + r.end(), value);
    });
  };
  for (int pass = 0; pass < 64; ++pass) {
    const size_t faces = indices_now.size() / 3;
    const uint32_t* idx = indices_now.data();
    // The long edges, found from their corners alone (the edge rows of the
    // whole surface, once per pass, cost most of a pass whose splits are
    // few: igea at 10,000 splits 7,000 and then 200 of 800,000 faces):
    // each corner whose edge to its successor is too long, keyed by the
    // edge's ends, sorted by (edge, corner), so a run is one edge and its
    // first entry the corner the face loop meets it at.
    struct LongCorner {
      uint64_t edge;
      uint32_t corner;
      bool operator<(const LongCorner& o) const { return edge != o.edge ? edge < o.edge : corner < o.corner; }
    };
    auto successor = [&](size_t h) { return idx[h - h % 3 + (h % 3 + 1) % 3]; };  // the next corner's vertex
    // Only the faces the last pass made can have a long edge: a face it left
    // whole had none, and lengths never change (the first pass looks at
    // every face).
    const size_t checked = pass == 0 ? faces : fresh.size();
    std::vector<LongCorner> corners =
        collect_in_order<LongCorner>(checked, [&](size_t k, std::vector<LongCorner>* list) {
          const size_t f = pass == 0 ? k : fresh[k];
          for (size_t h = 3 * f; h < 3 * f + 3; ++h) {
            const uint32_t a = idx[h], b = successor(h);
            if (too_long(a, b)) list->push_back({uint64_t(std::min(a, b)) << 32 | std::max(a, b), uint32_t(h)});
          }
        });
    if (corners.empty()) break;
    tbb::parallel_sort(corners.begin(), corners.end());  // distinct keys: one order on any thread count
    // Each edge's first corner, in corner order: the new vertices' order.
    // The run's start is marked at that corner, and the marks read back in
    // corner order (the faces checked are ascending), which sorts them.
    fill(&mid, 3 * faces, UINT32_MAX);  // per corner: its run's start, then its midpoint
    tbb::parallel_for(tbb::blocked_range<size_t>(0, corners.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i)
        if (i == 0 || corners[i].edge != corners[i - 1].edge) mid[corners[i].corner] = uint32_t(i);
    });
    const std::vector<std::pair<uint32_t, uint32_t>> first =  // (first corner, run's start in corners)
        collect_in_order<std::pair<uint32_t, uint32_t>>(checked, [&](size_t k, auto* list) {
          const size_t f = pass == 0 ? k : fresh[k];
          for (size_t h = 3 * f; h < 3 * f + 3; ++h)
            if (mid[h] != UINT32_MAX) list->push_back({uint32_t(h), mid[h]});
        });
    // Per face corner: the midpoint of its long edge, or UINT32_MAX.
    std::vector<uint32_t> ends(2 * first.size());  // per new vertex, its edge's two ends
    tbb::parallel_for(tbb::blocked_range<size_t>(0, first.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k != r.end(); ++k) {
        const uint32_t h = first[k].first;
        ends[2 * k] = idx[h];
        ends[2 * k + 1] = successor(h);
        for (size_t i = first[k].second; i < corners.size() && corners[i].edge == corners[first[k].second].edge; ++i)
          mid[corners[i].corner] = uint32_t(count + k);
      }
    });
    const size_t added = ends.size() / 2;
    if (count + added > max_vertices)
      return resource_exhausted("refining the surface to edges of " +
                                std::to_string(banded ? bounds.rim_max_edge : max_edge) + " would need over " +
                                std::to_string(max_vertices) + " vertices");
    // An eighth more room than this pass needs: the later passes add few
    // vertices, which then fit without copying every position again.
    if (pos.capacity() < 3 * (count + added)) pos.reserve(3 * (count + added) + 3 * (count + added) / 8);
    pos.resize(3 * (count + added));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, added, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const size_t a = ends[2 * i], b = ends[2 * i + 1], n = count + i;
        for (int c = 0; c < 3; ++c) pos[3 * n + c] = 0.5 * (pos[3 * a + c] + pos[3 * b + c]);
      }
    });
    out.midpoint_ends.insert(out.midpoint_ends.end(), ends.begin(), ends.end());
    out.pass_end.push_back(out.midpoint_ends.size() / 2);
    mark_rim(count, count + added);
    count += added;
    // A face with s split edges becomes s + 1 faces: each face's first slot,
    // a prefix sum over the faces (in parallel: integers, one result).
    resize_for_overwrite(&slots, faces + 1);  // every entry written below
    slots[0] = 0;
    auto pieces = [&](size_t f) {
      return uint32_t(1 + (mid[3 * f] != UINT32_MAX) + (mid[3 * f + 1] != UINT32_MAX) + (mid[3 * f + 2] != UINT32_MAX));
    };
    tbb::parallel_scan(
        tbb::blocked_range<size_t>(0, faces, 16384), uint32_t(0),
        [&](const tbb::blocked_range<size_t>& r, uint32_t sum, bool final) {
          for (size_t f = r.begin(); f != r.end(); ++f) {
            sum += pieces(f);
            if (final) slots[f + 1] = sum;
          }
          return sum;
        },
        [](uint32_t a, uint32_t b) { return a + b; });
    UninitializedVector<uint32_t>&indices = indices_next, &face = face_next;
    resize_for_overwrite(&indices, 3 * size_t(slots[faces]));  // every entry written below
    resize_for_overwrite(&face, slots[faces]);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, faces, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t f = r.begin(); f != r.end(); ++f) {
        const uint32_t v[3] = {idx[3 * f], idx[3 * f + 1], idx[3 * f + 2]};
        uint32_t m[3];
        int split = 0;
        for (int c = 0; c < 3; ++c) {
          m[c] = mid[3 * f + c];
          split += m[c] != UINT32_MAX;
        }
        size_t slot = slots[f];
        auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
          indices[3 * slot] = a;
          indices[3 * slot + 1] = b;
          indices[3 * slot + 2] = c;
          face[slot++] = face_now[f];
        };
        if (split == 0) {
          emit(v[0], v[1], v[2]);
        } else if (split == 3) {  // 1:4
          emit(v[0], m[0], m[2]);
          emit(v[1], m[1], m[0]);
          emit(v[2], m[2], m[1]);
          emit(m[0], m[1], m[2]);
        } else if (split == 1) {  // 1:2 across the split edge
          const int c = m[0] != UINT32_MAX ? 0 : m[1] != UINT32_MAX ? 1 : 2;
          emit(v[c], m[c], v[(c + 2) % 3]);
          emit(m[c], v[(c + 1) % 3], v[(c + 2) % 3]);
        } else {  // two split edges: the corner between them, then the quad by its shorter diagonal
          // e: the unsplit edge (v[e], v[e+1]); the corner opposite it, v[e+2], is cut off.
          const int e = m[0] == UINT32_MAX ? 0 : m[1] == UINT32_MAX ? 1 : 2;
          const uint32_t a = v[e], b = v[(e + 1) % 3], o = v[(e + 2) % 3];
          const uint32_t mb = m[(e + 1) % 3], ma = m[(e + 2) % 3];  // on (b, o) and (o, a)
          emit(ma, mb, o);
          if (length2(a, mb) < length2(b, ma)) {
            emit(a, b, mb);
            emit(a, mb, ma);
          } else {
            emit(a, b, ma);
            emit(b, mb, ma);
          }
        }
      }
    });
    fresh = collect_in_order<uint32_t>(faces, [&](size_t f, std::vector<uint32_t>* list) {
      if (slots[f + 1] - slots[f] > 1)
        for (uint32_t k = slots[f]; k < slots[f + 1]; ++k) list->push_back(k);
    });
    std::swap(indices_now, indices_next);
    std::swap(face_now, face_next);
    marks.mark("pass");
  }
  // No long edge left (or 64 passes ran out).
  out.mesh.indices.assign(indices_now.begin(), indices_now.end());
  out.face.assign(face_now.begin(), face_now.end());
  marks.mark("last_look");
  make_rows();
  marks.mark("edge_rows");
  out.mesh.positions.assign(pos.begin(), pos.end());
  return out;
}

Status carry_values(const std::vector<float>& value, int channels, RefinedSurface* out) {
  const size_t k = size_t(channels);
  if (channels < 1 || value.size() != k * out->input_vertices)
    return invalid_argument("refine: `channels` values per vertex expected");
  out->channels = channels;
  std::vector<float>& v = out->value;
  v.assign(k * out->mesh.vertex_count(), 0.0f);
  for (size_t i = 0; i < out->source.size(); ++i)
    for (size_t c = 0; c < k; ++c) v[k * i + c] = value[k * out->source[i] + c];
  size_t count = out->source.size();
  for (const auto& [copy, original] : out->pinch_copies) {
    for (size_t c = 0; c < k; ++c) v[k * count + c] = v[k * original + c];
    ++count;
  }
  // Pass by pass: a pass's midpoints read only vertices made before it.
  size_t begin = 0;
  for (size_t end : out->pass_end) {
    tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const size_t a = out->midpoint_ends[2 * i], b = out->midpoint_ends[2 * i + 1], n = count + i;
        for (size_t c = 0; c < k; ++c) v[k * n + c] = 0.5f * (v[k * a + c] + v[k * b + c]);
      }
    });
    begin = end;
  }
  return Status::Ok();
}

StatusOr<RefinedSurface> refine_surface(const Mesh& input, const std::vector<float>& value, int channels,
                                        double max_edge, size_t max_vertices) {
  return refine_surface(input, value, channels, EdgeBounds{max_edge, 0, 0}, max_vertices);
}

StatusOr<RefinedSurface> refine_surface(const Mesh& input, const std::vector<float>& value, int channels,
                                        const EdgeBounds& bounds, size_t max_vertices) {
  if (channels < 1 || value.size() != size_t(channels) * input.vertex_count())
    return invalid_argument("refine: `channels` values per vertex expected");
  VPR_ASSIGN_OR_RETURN(RefinedSurface out, refine_geometry(input, bounds, max_vertices));
  VPR_RETURN_IF_ERROR(carry_values(value, channels, &out));
  return out;
}

}  // namespace vpr
