#include "surface/surface_cvt.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <future>
#include <mutex>
#include <numeric>
#include <queue>
#include <string>
#include <unordered_map>

#include "core/collect_in_order.h"
#include "core/rng.h"
#include "core/step_marks.h"
#include "core/vec3.h"
#include "core/vertex_ranges.h"
#include "surface/cell_growth.h"
#include "surface/cvt_sweep_kernels.h"
#include "surface/edge_parts.h"
#include "surface/edge_smoothing.h"
#include "surface/morton_order.h"

namespace vpr {
namespace {

// A cell holds no element whose normal is more than 100 degrees from the
// way the cell faces (its seed's normal while the cells grow, the mean of
// its elements' normals in the sweeps): a cell that faces both ways wraps a
// thin part or the rim of a thin plate, and its dual vertex cannot stand for
// both sides. 100 rather than 90 degrees, so that a cell may still cover a
// right-angled crease or a cube's corner.
constexpr double kFacing = kCvtFacing;  // cos 100 degrees

// Vertex adjacency in compressed rows, neighbours sorted; faces[i]: how
// many faces the edge to neighbor[i] has (1: a boundary edge).
using Adjacency = MeshEdges;

struct Cluster {
  double m = 0;
  Vec3d s{0, 0, 0};  // sum m x
  Vec3d t{0, 0, 0};  // sum m a n: the normal half of the six-dimensional position (anisotropy)
  Vec3d n{0, 0, 0};  // sum m n, unit normals: which way the cell faces
  size_t size = 0;
  // -|(s, t)|^2 / m: the cluster's energy less sum m |(x, a n)|^2, which no move changes.
  double energy() const { return m > 0 ? -(dot(s, s) + dot(t, t)) / m : 0.0; }
};

double total_energy(const std::vector<Cluster>& clusters, double constant) {
  double e = constant;
  for (const Cluster& c : clusters) e += c.energy();
  return e;
}

// How many groups v's neighbours in cluster `c` form (cvt_sweep_kernels.h).
size_t neighbour_groups(const Adjacency& adj, const std::vector<uint32_t>& label, uint32_t v, uint32_t c) {
  return cvt_neighbour_groups(adj.offset.data(), adj.neighbor.data(), label.data(), v, c);
}

// Boundary loops of the surface: per vertex, the loop of boundary edges
// (edges with one face) it lies on, or UINT32_MAX; per loop, its vertices.
void boundary_loops(const Adjacency& adj, std::vector<uint32_t>* loop_of, std::vector<std::vector<uint32_t>>* loops) {
  const size_t nv = adj.offset.size() - 1;
  auto on_boundary = [&](uint32_t v) {
    for (uint32_t i = adj.offset[v]; i < adj.offset[v + 1]; ++i)
      if (adj.faces[i] == 1) return true;
    return false;
  };
  loop_of->assign(nv, UINT32_MAX);
  loops->clear();
  // The boundary's vertices found in parallel, in order (most surfaces have
  // few or none); the walks from them in that order, as over every vertex.
  const std::vector<uint32_t> boundary = collect_in_order<uint32_t>(nv, [&](size_t v, std::vector<uint32_t>* out) {
    if (on_boundary(uint32_t(v))) out->push_back(uint32_t(v));
  });
  for (const uint32_t s : boundary) {
    if ((*loop_of)[s] != UINT32_MAX) continue;
    const uint32_t id = uint32_t(loops->size());
    loops->emplace_back();
    std::vector<uint32_t> stack = {s};
    (*loop_of)[s] = id;
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      loops->back().push_back(v);
      for (uint32_t i = adj.offset[v]; i < adj.offset[v + 1]; ++i)
        if (adj.faces[i] == 1 && (*loop_of)[adj.neighbor[i]] == UINT32_MAX) {
          (*loop_of)[adj.neighbor[i]] = id;
          stack.push_back(adj.neighbor[i]);
        }
    }
    std::sort(loops->back().begin(), loops->back().end());
  }
}

// `k` vertices of a boundary loop spread along it: farthest-point picks by
// hops over the loop's edges, from its lowest vertex.
std::vector<uint32_t> spread_on_loop(const Adjacency& adj, const std::vector<uint32_t>& loop_of,
                                     const std::vector<uint32_t>& loop, size_t k) {
  std::vector<uint32_t> picks;
  if (loop.empty()) return picks;
  const uint32_t id = loop_of[loop[0]];
  std::unordered_map<uint32_t, uint32_t> hops;  // to the nearest pick
  for (uint32_t v : loop) hops[v] = UINT32_MAX;
  uint32_t next = loop[0];
  while (picks.size() < std::min(k, loop.size())) {
    picks.push_back(next);
    std::vector<uint32_t> frontier = {next};
    hops[next] = 0;
    for (uint32_t d = 1; !frontier.empty(); ++d) {
      std::vector<uint32_t> more;
      for (uint32_t v : frontier)
        for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w)
          if (loop_of[*w] == id && hops[*w] > d) {
            hops[*w] = d;
            more.push_back(*w);
          }
      frontier = std::move(more);
    }
    uint32_t best = 0;
    for (uint32_t v : loop)  // loop is sorted: ties go to the lowest vertex
      if (hops[v] != UINT32_MAX && hops[v] > best) best = hops[v], next = v;
    if (best == 0) break;
  }
  return picks;
}

// Cells whose dual vertex would not be a manifold vertex: the dual
// triangles are the cell triples of faces with three cells (as in
// cluster_mesh.cpp); a cell is defective when its link (the edges opposite
// it in its triangles) is not one path or cycle, when it shares an edge
// with a cell that more than two triangles use, when its three cells meet
// at two separate places, or when the cell itself rings something (not a
// disk, nor two). Sorted, each once. (Its
// sorts are of plain values in their natural order, so tbb::parallel_sort
// gives one result on any thread count.)
std::vector<uint32_t> defective_cells(const Mesh& mesh, const Adjacency& adj, const std::vector<uint32_t>& label,
                                      uint32_t count) {
  // (cells, face) for each face with three cells: its triple point.
  std::vector<std::array<uint32_t, 4>> corners = collect_in_order<std::array<uint32_t, 4>>(
      mesh.face_count(), [&](size_t f, std::vector<std::array<uint32_t, 4>>* out) {
        std::array<uint32_t, 3> t = {label[mesh.indices[3 * f]], label[mesh.indices[3 * f + 1]],
                                     label[mesh.indices[3 * f + 2]]};
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || t[0] == UINT32_MAX || t[1] == UINT32_MAX ||
            t[2] == UINT32_MAX)
          return;
        std::sort(t.begin(), t.end());
        out->push_back({t[0], t[1], t[2], uint32_t(f)});
      });
  tbb::parallel_sort(corners.begin(), corners.end());
  std::vector<char> bad(count, 0);
  std::vector<std::array<uint32_t, 3>> tris;
  tris.reserve(corners.size());
  std::vector<uint32_t> corner_parent;
  for (size_t i = 0; i < corners.size();) {
    size_t j = i;
    while (j < corners.size() && std::equal(corners[j].begin(), corners[j].begin() + 3, corners[i].begin())) ++j;
    tris.push_back({corners[i][0], corners[i][1], corners[i][2]});
    // Three cells that meet at two separate places (faces of the triple
    // joined by no chain of shared corners): two of them share two arcs of
    // boundary, so together they ring a thin part, and the dual, which keeps
    // one triangle per triple, would pinch the part there (a rod with two
    // cells around comes back as several closed pieces).
    if (j - i > 32) {
      // A triple point spread over that many faces is no point: split
      // (and the pairwise test below stays cheap on any input).
      bad[corners[i][0]] = bad[corners[i][1]] = bad[corners[i][2]] = 1;
    } else if (j - i > 1) {
      corner_parent.resize(j - i);
      std::iota(corner_parent.begin(), corner_parent.end(), 0u);
      auto find = [&](uint32_t a) {
        while (corner_parent[a] != a) a = corner_parent[a] = corner_parent[corner_parent[a]];
        return a;
      };
      size_t groups = j - i;
      for (size_t a = i; a < j; ++a)
        for (size_t b = a + 1; b < j; ++b) {
          const uint32_t* fa = &mesh.indices[3 * size_t(corners[a][3])];
          const uint32_t* fb = &mesh.indices[3 * size_t(corners[b][3])];
          const bool touch = std::any_of(fa, fa + 3, [&](uint32_t v) { return v == fb[0] || v == fb[1] || v == fb[2]; });
          const uint32_t ra = find(uint32_t(a - i)), rb = find(uint32_t(b - i));
          if (touch && ra != rb) corner_parent[ra] = rb, --groups;
        }
      if (groups > 1) bad[corners[i][0]] = bad[corners[i][1]] = bad[corners[i][2]] = 1;
    }
    i = j;
  }
  // Edges of more than two triangles.
  std::vector<uint64_t> edges;
  edges.reserve(3 * tris.size());
  for (const auto& t : tris) {
    edges.push_back(uint64_t(t[0]) << 32 | t[1]);
    edges.push_back(uint64_t(t[1]) << 32 | t[2]);
    edges.push_back(uint64_t(t[0]) << 32 | t[2]);
  }
  tbb::parallel_sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i > 2) bad[edges[i] >> 32] = bad[uint32_t(edges[i])] = 1;
    i = j;
  }
  // Links: (cell, u, w) for each triangle corner.
  std::vector<std::array<uint32_t, 3>> link;
  link.reserve(3 * tris.size());
  for (const auto& t : tris) {
    link.push_back({t[0], t[1], t[2]});
    link.push_back({t[1], t[0], t[2]});
    link.push_back({t[2], t[0], t[1]});
  }
  tbb::parallel_sort(link.begin(), link.end());
  std::vector<uint32_t> ends, parent;
  for (size_t i = 0; i < link.size();) {
    size_t j = i;
    while (j < link.size() && link[j][0] == link[i][0]) ++j;
    const uint32_t cell = link[i][0];
    ends.clear();
    for (size_t k = i; k < j; ++k) ends.insert(ends.end(), {link[k][1], link[k][2]});
    std::sort(ends.begin(), ends.end());
    bool ok = true;
    for (size_t a = 0; a < ends.size() && ok;) {  // degree at most 2
      size_t b = a;
      while (b < ends.size() && ends[b] == ends[a]) ++b;
      ok = b - a <= 2;
      a = b;
    }
    ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
    if (ok) {  // one component
      parent.resize(ends.size());
      std::iota(parent.begin(), parent.end(), 0u);
      auto find = [&](uint32_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
      };
      size_t groups = ends.size();
      for (size_t k = i; k < j; ++k) {
        const uint32_t a = uint32_t(std::lower_bound(ends.begin(), ends.end(), link[k][1]) - ends.begin());
        const uint32_t b = uint32_t(std::lower_bound(ends.begin(), ends.end(), link[k][2]) - ends.begin());
        const uint32_t ra = find(a), rb = find(b);
        if (ra != rb) parent[ra] = rb, --groups;
      }
      ok = groups == 1;
    }
    if (!ok) bad[cell] = 1;
    i = j;
  }
  // A cell that rings something (Euler characteristic V - E + F of its own
  // elements, edges and faces below 1: an annulus or worse) and is in no
  // dual triangle: the sweeps keep a cell's topology, but the cells grown
  // from the seeds can close into a band around a thin part, which meets its
  // neighbours in whole circles and so in no dual triangle: the dual would
  // cut the part there. (A ring that is in dual triangles either has a link
  // of two pieces, caught above, or encloses a cell that is in none, which
  // the dual drops and which costs nothing but that vertex: a rod's cap.)
  std::vector<char> in_triangle(count, 0);
  for (const auto& t : tris) in_triangle[t[0]] = in_triangle[t[1]] = in_triangle[t[2]] = 1;
  // Counts, so in any order: the elements and faces in parallel, each
  // thread adding a run of one cell's terms at once (atomics: a per-thread
  // array would cost the cell count per thread). Ranges of cells, each
  // reading every element and face, read them up to eight times over: 9 ms
  // of igea's 10,000-vertex job on an H200.
  std::vector<std::atomic<int64_t>> euler(count);
  for (auto& e : euler) e.store(0, std::memory_order_relaxed);
  struct Run {  // a run of terms of one cell, added when the cell changes
    std::vector<std::atomic<int64_t>>* sums;
    uint32_t cell = UINT32_MAX;
    int64_t sum = 0;
    void add(uint32_t c, int64_t d) {
      if (c != cell) flush(), cell = c;
      sum += d;
    }
    void flush() {
      if (cell != UINT32_MAX && sum != 0) (*sums)[cell].fetch_add(sum, std::memory_order_relaxed);
      sum = 0;
    }
  };
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(label.size()), 8192),
                    [&](const tbb::blocked_range<uint32_t>& r) {
                      Run run{&euler};
                      for (uint32_t u = r.begin(); u != r.end(); ++u) {
                        const uint32_t c = label[u];
                        if (c >= count) continue;
                        int64_t d = 1;  // the element, less its edges to later elements of its cell
                        for (const uint32_t* w = adj.begin(u); w != adj.end(u); ++w) d -= *w > u && label[*w] == c;
                        run.add(c, d);
                      }
                      run.flush();
                    });
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.face_count(), 8192), [&](const tbb::blocked_range<size_t>& r) {
    Run run{&euler};
    for (size_t f = r.begin(); f != r.end(); ++f) {
      const uint32_t* t = &mesh.indices[3 * f];
      const uint32_t c = label[t[0]];
      if (c < count && label[t[1]] == c && label[t[2]] == c) run.add(c, 1);
    }
    run.flush();
  });
  for (uint32_t c = 0; c < count; ++c)
    if (euler[c] < 1 && !in_triangle[c]) bad[c] = 1;
  std::vector<uint32_t> out;
  for (uint32_t c = 0; c < count; ++c)
    if (bad[c]) out.push_back(c);
  return out;
}

// The steepest ramp of the anisotropic offset beside a sharp vertex, in
// offset per unit of length along the surface (anisotropic_offsets). Chosen
// on the referee's 30 cases and on scans at 10,000 to 50,000 vertices
// (docs/quality.md): 1.5 changes four of the 30 (those whose ramp was
// steeper) within their seed-to-seed noise and leaves no cell to split on the
// scans; 2 left horse at 20,000 with 11, and 1 changed 14 of the 30 with no
// mean for the better.
constexpr double kMaxTaperSlope = 1.5;

// The normal half of each element's position in R^6, (x, a n) (Levy and
// Bonneel 2012): a cell then pays for the spread of its normals as for the
// spread of its positions, so cells stretch along the directions in which the
// surface turns least (a cylinder's axis) and shrink across those in which it
// turns most. Two changes to their construction, both measured in
// docs/quality.md:
// - The normals are smoothed over the edges first (each pass half its own,
//   half its neighbours' mean; k / 2 passes for k elements per cell, so
//   about half a cell's width), so that a scan's noise does not fray the
//   cells into slivers.
// - The offset tapers to zero within about two cells' widths (2 sqrt(k)
//   hops, more where that ramp would be steeper than kMaxTaperSlope) of a
//   sharp vertex (a face normal more than 15 degrees from its
//   vertex normal: a dihedral angle over about 30 degrees, the dual's
//   crease): there the crease is kept by the dual's quadric placement
//   (cluster_mesh.h), which needs cells that cover the crease, while in R^6
//   a cell across a crease pays for the jump in normal and the cells' walls
//   would line up with the crease instead.
// smooth: the passes' twin (CvtOptions::device_smoothing), or empty for the CPU's.
// cache: offsets made before with the same passes, taper and anisotropy
// (CvtOptions::surface_cache), or where to keep these; null: none.
Status anisotropic_offsets(const Mesh& mesh, const Adjacency& adj, const std::vector<Vec3d>& x,
                           const std::vector<Vec3d>& vertex_normal, uint32_t count, double anisotropy,
                           const EdgeSmoothing& smooth, CvtSurfaceCache* cache, std::vector<Vec3d>* offsets) {
  const size_t nv = x.size();
  std::vector<Vec3d>& y = *offsets;
  y.assign(nv, Vec3d{0, 0, 0});
  if (!(anisotropy > 0)) return Status::Ok();
  StepMarks marks("cvt_offsets");
  const double per_cell = double(nv) / std::max<uint32_t>(count, 1);
  const int passes = int(std::clamp(std::lround(per_cell / 2), 1L, 64L));
  // The taper's ramp adds anisotropy / taper to every hop's length in R^6;
  // over a hop of mean length e that is a slope of anisotropy / (taper e),
  // which grows as the elements shrink (more output vertices). Past about 2
  // the cells across the ramps round a scan's scattered sharp vertices are
  // squeezed into slivers whose dual vertex is not a manifold, and the
  // topology step splits and merges them for many more sweeps (horse at
  // 10,000: slope 2.4, 14 cells; bunny at 20,000: 2.7, 189; igea at 50,000:
  // 4.0, 1,270 cells and 130 more sweeps, the CVT 3.6 times as long). The
  // ramp is made longer where needed to keep its slope at most
  // kMaxTaperSlope (each vertex's row summed in parallel, the rows in
  // order: the same sum on any thread count).
  std::vector<double> row_sum(nv, 0.0);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t v = r.begin(); v != r.end(); ++v)
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w) row_sum[v] += norm(x[*w] - x[v]);
  });
  const double edge_sum = std::accumulate(row_sum.begin(), row_sum.end(), 0.0);
  const size_t edge_count = adj.neighbor.size();
  const double mean_edge = edge_count ? edge_sum / double(edge_count) : 0.0;
  const double slope_hops = mean_edge > 0 ? std::ceil(anisotropy / (kMaxTaperSlope * mean_edge)) : 1.0;
  const int taper = int(std::clamp(std::max(std::lround(2 * std::sqrt(per_cell)), long(std::min(slope_hops, 1e6))), 1L, 256L));
  marks.mark("edge_lengths");
  if (cache && cache->passes == passes && cache->taper == taper && cache->anisotropy == anisotropy &&
      cache->offsets.size() == nv) {
    y = cache->offsets;
    return Status::Ok();
  }
  // Hops to the nearest sharp vertex, up to `taper`. Which corners are sharp
  // is decided per face in parallel; the distances do not depend on the
  // order the sharp vertices are listed in.
  std::vector<std::atomic<int>> hops(nv);
  auto walk = [&] {
    constexpr double kCos15 = 0.9659258262890683;
    std::vector<uint8_t> sharp_corners(mesh.face_count(), 0);  // bit k: corner k is sharp
    tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.face_count(), 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t f = r.begin(); f != r.end(); ++f) {
        const uint32_t* t = &mesh.indices[3 * f];
        const Vec3d n = cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]);
        const double len = norm(n);
        if (!(len > 0)) continue;
        for (int k = 0; k < 3; ++k)
          if (dot(n, vertex_normal[t[k]]) < kCos15 * len) sharp_corners[f] |= uint8_t(1u << k);
      }
    });
    // A breadth-first walk, a ring at a time, each ring in parallel: a vertex
    // is claimed (an atomic exchange) by the first of the ring's vertices to
    // reach it. Which one does changes only the order in which the next ring
    // is listed, never a vertex's hops (a scan's many sharp vertices made the
    // serial walk 9 ms of igea's 10,000-vertex job on an H200).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) hops[v].store(taper, std::memory_order_relaxed);
    });
    auto claim = [&](uint32_t v, int d) {
      int now_hops = hops[v].load(std::memory_order_relaxed);
      while (now_hops > d)
        if (hops[v].compare_exchange_weak(now_hops, d, std::memory_order_relaxed)) return true;
      return false;
    };
    std::vector<uint32_t> frontier =
        collect_in_order<uint32_t>(mesh.face_count(), [&](size_t f, std::vector<uint32_t>* out) {
          for (int k = 0; k < 3; ++k)
            if ((sharp_corners[f] >> k & 1) && claim(mesh.indices[3 * f + k], 0)) out->push_back(mesh.indices[3 * f + k]);
        }, 8192);
    for (int d = 1; d < taper && !frontier.empty(); ++d)
      frontier = collect_in_order<uint32_t>(frontier.size(), [&](size_t i, std::vector<uint32_t>* out) {
        for (const uint32_t* w = adj.begin(frontier[i]); w != adj.end(frontier[i]); ++w)
          if (claim(*w, d)) out->push_back(*w);
      }, 2048);
  };
  // Jacobi passes (edge_smoothing.h): the same bits on any thread count and
  // either twin. With the passes on a device the walk runs on its own thread
  // meanwhile, where the host would wait (igea at 10,000 on an H200: 9 ms of
  // walk beside 6.5 ms of passes); on the CPU one after the other, both being
  // parallel loops.
  std::vector<Vec3d> now = vertex_normal;
  if (smooth) {
    std::future<void> walked = std::async(std::launch::async, walk);
    const Status smoothed = smooth(adj, passes, &now);
    marks.mark("smooth");
    walked.get();
    marks.mark("walk_wait");
    VPR_RETURN_IF_ERROR(smoothed);
  } else {
    VPR_RETURN_IF_ERROR(cpu::smooth_over_edges(adj, passes, &now));
    walk();
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      const double len = norm(now[v]);
      if (len > 0) y[v] = now[v] * (anisotropy * double(hops[v].load(std::memory_order_relaxed)) / (double(taper) * len));
    }
  });
  marks.mark("place");
  if (cache) {
    cache->passes = passes;
    cache->taper = taper;
    cache->anisotropy = anisotropy;
    cache->offsets = y;
  }
  return Status::Ok();
}

// The sweeps' slabs (see surface_cvt's sweep loop): elements cut along the
// longest axis of their bounding box into `slabs` runs of equal count (ties
// by index), each run's elements in ascending order; `sequential`: the
// elements a slab may not move (on a boundary loop, or with a neighbour two
// or more slabs away), ascending.
struct SlabSchedule {
  uint32_t slabs = 1;
  std::vector<uint32_t> slab_of;
  std::vector<std::vector<uint32_t>> elements;
  std::vector<uint32_t> sequential;
  std::vector<char> last;  // per element: in `sequential`
};

// About six cells' widths per slab along the axis at 10,000 cells (a square
// root of the count across), fewer slabs for fewer cells; even, so the two
// colours alternate.
uint32_t slab_count(uint32_t count) {
  return 2 * std::clamp<uint32_t>(uint32_t(std::sqrt(double(count)) / 12), 1, 16);
}

SlabSchedule slab_schedule(const std::vector<Vec3d>& x, const Adjacency& adj, const std::vector<uint32_t>& label,
                           const std::vector<uint32_t>& loop_of, uint32_t count) {
  SlabSchedule s;
  const size_t nv = x.size();
  s.slabs = slab_count(count);
  auto coordinate = [](const Vec3d& p, int k) { return k == 0 ? p.x : k == 1 ? p.y : p.z; };
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v = 0; v < nv; ++v)
    if (label[v] != UINT32_MAX)
      for (int k = 0; k < 3; ++k)
        lo[k] = std::min(lo[k], coordinate(x[v], k)), hi[k] = std::max(hi[k], coordinate(x[v], k));
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
  std::vector<std::pair<double, uint32_t>> order =
      collect_in_order<std::pair<double, uint32_t>>(nv, [&](size_t v, std::vector<std::pair<double, uint32_t>>* out) {
        if (label[v] != UINT32_MAX) out->push_back({coordinate(x[v], axis), uint32_t(v)});
      });
  tbb::parallel_sort(order.begin(), order.end());  // distinct pairs: one order on any thread count
  s.slab_of.assign(nv, UINT32_MAX);
  s.elements.assign(s.slabs, {});
  s.last.assign(nv, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) s.slab_of[order[i].second] = uint32_t(i * s.slabs / order.size());
  });
  // Which elements a slab may move, per element in parallel; the lists in
  // element order.
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 8192), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t v = r.begin(); v != r.end(); ++v) {
      if (s.slab_of[v] == UINT32_MAX) continue;
      bool alone = loop_of[v] == UINT32_MAX;
      for (const uint32_t* w = adj.begin(v); w != adj.end(v) && alone; ++w)
        alone = s.slab_of[*w] == UINT32_MAX ||
                (s.slab_of[*w] + 1 >= s.slab_of[v] && s.slab_of[*w] <= s.slab_of[v] + 1);
      s.last[v] = !alone;
    }
  });
  for (uint32_t v = 0; v < nv; ++v)
    if (s.slab_of[v] != UINT32_MAX) (s.last[v] ? s.sequential : s.elements[s.slab_of[v]]).push_back(v);
  return s;
}

}  // namespace

std::vector<double> vertex_areas(const Mesh& mesh, const VertexCorners* corners) {
  std::vector<double> area(mesh.vertex_count(), 0.0);
  auto third_of = [&](const uint32_t* t) {
    const Vec3d a = load3d(mesh.positions.data(), t[0]), b = load3d(mesh.positions.data(), t[1]),
                c = load3d(mesh.positions.data(), t[2]);
    return norm(cross(b - a, c - a)) / 6.0;
  };
  if (corners && corners->built(mesh.vertex_count())) {
    // A vertex's corners ascend (face order; a face holding it twice gives
    // two corners in a row), as the ranges below meet them.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.vertex_count(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v)
        for (uint32_t i = corners->offset[v]; i < corners->offset[v + 1]; ++i) {
          const uint32_t h = corners->corner[i];
          area[v] += third_of(&mesh.indices[h - h % 3]);
        }
    });
    return area;
  }
  in_vertex_ranges(mesh.vertex_count(), [&](uint32_t lo, uint32_t hi) {  // each vertex's faces in face order
    for (size_t f = 0; f < mesh.face_count(); ++f) {
      const uint32_t* t = &mesh.indices[3 * f];
      const bool mine[3] = {t[0] >= lo && t[0] < hi, t[1] >= lo && t[1] < hi, t[2] >= lo && t[2] < hi};
      if (!mine[0] && !mine[1] && !mine[2]) continue;
      const double third = third_of(t);
      for (int k = 0; k < 3; ++k)
        if (mine[k]) area[t[k]] += third;
    }
  });
  return area;
}

Status surface_cvt(const Mesh& mesh, const std::vector<double>& mass, uint32_t count, const CvtOptions& options,
                   std::vector<uint32_t>* label, CvtStats* stats) {
  return surface_cvt(mesh, mesh_edges(mesh), mass, count, options, label, stats);
}

Status surface_cvt(const Mesh& mesh, const MeshEdges& adj, const std::vector<double>& mass_in, uint32_t count,
                   const CvtOptions& options, std::vector<uint32_t>* label_out, CvtStats* stats) {
  const size_t nv = mesh.vertex_count();
  std::vector<double> mass = mass_in;  // raised where cells are split for topology
  if (mass.size() != nv) return invalid_argument("surface CVT: one mass per vertex expected");
  if (adj.vertex_count() != nv) return invalid_argument("surface CVT: edges of another mesh");
  if (count < 1) return invalid_argument("surface CVT: at least one cluster");
  StepMarks marks("cvt");
  std::vector<Vec3d> x(nv);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) x[v] = load3d(mesh.positions.data(), v);
  });
  // A cache of an earlier run on this surface is held for this run's reads
  // and fills (the normals and offsets).
  std::unique_lock<std::mutex> cache_lock;
  CvtSurfaceCache* cache = options.surface_cache;
  if (cache) cache_lock = std::unique_lock<std::mutex>(cache->mutex);
  std::vector<Vec3d> vertex_normal;  // unit, area-weighted
  if (cache && cache->normal.size() == nv) {
    vertex_normal = cache->normal;
  } else {
    vertex_normal.assign(nv, Vec3d{0, 0, 0});
    // Each vertex's face normals summed in face order (a face that holds the
    // vertex twice, twice in a row): from the corners by vertex when given
    // (one read of each vertex's own faces), else by vertex ranges, each
    // reading every face (core/vertex_ranges.h). The same sums.
    auto face_normal = [&](const uint32_t* t) { return cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]); };
    if (options.corners && options.corners->built(nv)) {
      const VertexCorners& vc = *options.corners;
      tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t v = r.begin(); v != r.end(); ++v)
          for (uint32_t i = vc.offset[v]; i < vc.offset[v + 1]; ++i) {
            const uint32_t h = vc.corner[i];
            vertex_normal[v] = vertex_normal[v] + face_normal(&mesh.indices[h - h % 3]);
          }
      });
    } else {
      in_vertex_ranges(nv, [&](uint32_t lo, uint32_t hi) {
        for (size_t f = 0; f < mesh.face_count(); ++f) {
          const uint32_t* t = &mesh.indices[3 * f];
          const bool mine[3] = {t[0] >= lo && t[0] < hi, t[1] >= lo && t[1] < hi, t[2] >= lo && t[2] < hi};
          if (!mine[0] && !mine[1] && !mine[2]) continue;
          const Vec3d n = face_normal(t);
          for (int k = 0; k < 3; ++k)
            if (mine[k]) vertex_normal[t[k]] = vertex_normal[t[k]] + n;
        }
      });
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v)
        if (norm(vertex_normal[v]) > 0) vertex_normal[v] = vertex_normal[v] * (1.0 / norm(vertex_normal[v]));
    });
    if (cache) cache->normal = vertex_normal;
  }
  // The normal half of each element's position in R^6 (zero: isotropic),
  // and the plan below (the parts, their quotas, the boundary loops and the
  // seeds), which do not depend on each other. On a GPU job, whose host
  // would wait for the device's smoothing passes, the plan is made on its
  // own thread meanwhile (igea at 10,000 on an H200: 17 ms of it beside 13
  // of offsets); on the CPU one after the other, both being parallel loops.
  std::vector<Vec3d> y;
  EdgeParts found;
  size_t parts = 0;
  std::vector<uint32_t> loop_of, label(nv, UINT32_MAX), seeds;
  std::vector<std::vector<uint32_t>> loops;
  uint32_t start_cells = 0;
  auto plan = [&]() -> Status {
    StepMarks plan_marks("cvt_plan");
    // Connected parts (elements with mass only; isolated vertices have none),
    // numbered by lowest element (edge_parts.h); each part's mass summed in
    // element order.
    found = edge_parts(adj);
    plan_marks.mark("parts");
    const std::vector<uint32_t>& part = found.part;
    const std::vector<std::vector<uint32_t>>& part_elements = found.elements;
    std::vector<double> part_mass(part_elements.size(), 0.0);
    for (uint32_t v = 0; v < nv; ++v)
      if (part[v] != UINT32_MAX) part_mass[part[v]] += mass[v];
    parts = part_mass.size();
    size_t elements = 0;
    for (const auto& e : part_elements) elements += e.size();
    if (elements < count)
      return invalid_argument("surface CVT: " + std::to_string(count) +
                              " clusters need at least as many elements, got " + std::to_string(elements));

    // Clusters per part: a part's relative error depends on its own cluster
    // count, not on its size (curvature scales as 1/size), so a share of the
    // target in proportion to mass alone leaves small parts a few flat cells.
    // Each part gets (1 - s) of the target by mass plus s shared equally
    // (s = equal_part_share), at least min_per_part (or all its elements)
    // where the target allows; largest remainders first. One part, or parts of
    // equal mass, get exactly the mass share.
    const double total_mass = std::accumulate(part_mass.begin(), part_mass.end(), 0.0);
    // Groups of parts joined at a split pinch share one equal share, split
    // between them by mass (each group's parts joined, the root its lowest part).
    std::vector<uint32_t> group(parts);
    std::iota(group.begin(), group.end(), 0u);
    auto root = [&](uint32_t p) {
      while (group[p] != p) p = group[p] = group[group[p]];
      return p;
    };
    for (const auto& [a, b] : options.joined_elements) {
      if (a >= nv || b >= nv || part[a] == UINT32_MAX || part[b] == UINT32_MAX) continue;
      const uint32_t ra = root(part[a]), rb = root(part[b]);
      if (ra != rb) group[std::max(ra, rb)] = std::min(ra, rb);
    }
    std::vector<double> group_mass(parts, 0.0);
    size_t groups = 0;
    for (uint32_t p = 0; p < parts; ++p) {
      group_mass[root(p)] += part_mass[p];
      groups += root(p) == p;
    }
    std::vector<uint32_t> quota(parts, 0);
    {
      std::vector<uint32_t> floor_of(parts);
      uint64_t floors = 0;
      for (size_t p = 0; p < parts; ++p) {
        floor_of[p] = uint32_t(std::min<size_t>(options.min_per_part, part_elements[p].size()));
        floors += floor_of[p];
      }
      const bool minimum_fits = floors <= count;
      uint64_t assigned = 0;
      std::vector<std::pair<double, size_t>> remainder;
      for (size_t p = 0; p < parts; ++p) {
        const double by_mass = total_mass > 0 ? part_mass[p] / total_mass : 1.0 / double(parts);
        const double equal = options.equal_part_share;
        const double in_group = group_mass[root(uint32_t(p))] > 0 ? part_mass[p] / group_mass[root(uint32_t(p))] : 1.0;
        const double share = double(count) * ((1.0 - equal) * by_mass + equal / double(groups) * in_group);
        quota[p] = std::min<uint32_t>(uint32_t(share), uint32_t(part_elements[p].size()));
        if (minimum_fits) quota[p] = std::max(quota[p], floor_of[p]);
        assigned += quota[p];
        remainder.push_back({share - std::floor(share), p});
      }
      std::sort(remainder.begin(), remainder.end(),
                [](auto a, auto b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
      // Too many (the minimum took some): take back from the largest parts; too few: give by remainder.
      while (assigned > count) {
        size_t largest = 0;
        for (size_t p = 1; p < parts; ++p)
          if (quota[p] > quota[largest]) largest = p;
        --quota[largest];
        --assigned;
      }
      for (size_t i = 0; assigned < count; i = (i + 1) % parts) {
        const size_t p = remainder[i].second;
        if (quota[p] < part_elements[p].size()) {
          ++quota[p];
          ++assigned;
        }
      }
      if (stats) {
        stats->parts = parts;
        stats->parts_below_minimum = 0;
        for (size_t p = 0; p < parts; ++p) stats->parts_below_minimum += quota[p] < floor_of[p];
      }
    }

    // Boundary loops: each gets min_per_loop seeds spread along it (so the
    // dual keeps it open), taken from its part's quota.
    plan_marks.mark("quotas");
    boundary_loops(adj, &loop_of, &loops);
    plan_marks.mark("loops");
    // A warm start (CvtOptions::start_label) takes the earlier run's cells as
    // they are; otherwise seeds, and cells grown from them.
    if (options.start_label) {
      if (options.start_label->size() != nv)
        return invalid_argument("surface CVT: one start label per element expected");
      for (uint32_t v = 0; v < nv; ++v) {
        const uint32_t l = (*options.start_label)[v];
        if (l != UINT32_MAX && (l >= nv || adj.degree(v) == 0))
          return invalid_argument("surface CVT: the start labels are not of this surface");
        if (l != UINT32_MAX) start_cells = std::max(start_cells, l + 1);
      }
    }
    if (start_cells == 0) {
      for (const auto& loop : loops) {
        const uint32_t p = part[loop[0]];
        const size_t k = std::min<size_t>(options.min_per_loop, quota[p]);
        if (k < options.min_per_loop) continue;  // the part's quota cannot keep it open
        for (uint32_t v : spread_on_loop(adj, loop_of, loop, k)) {
          label[v] = uint32_t(seeds.size());
          seeds.push_back(v);
          --quota[p];
        }
      }
      // The rest: per part, stratified in proportion to mass. Along the part's
      // elements in Morton order (morton_order.h) the mass accumulates to M; a
      // seed goes where it crosses (u + k) M / q, k = 0 .. q - 1, one offset u
      // per part (Philox keyed by the seed: the same on every machine and thread
      // count). Each stretch of the curve holding M / q of the mass is a compact
      // piece of the surface, so the seeds start spread evenly by mass, where
      // independent draws clump and leave gaps. Against independent draws on
      // the 15 shared models at two counts each (30 runs, 2026-11-27): the
      // sweeps start at 14-21% lower energy and end lower in 27 of 30 runs
      // (median -0.8%, from -4.6% to +0.7%), in 25% fewer sweeps (798 against
      // 1,062), with 131 topology splits in all, not 222 (docs/quality.md).
      const Aabb box = bounding_box(mesh);
      const Vec3d lo{box.lo[0], box.lo[1], box.lo[2]};
      const double extent = std::max({double(box.hi[0]) - lo.x, double(box.hi[1]) - lo.y, double(box.hi[2]) - lo.z});
      auto weight = [&](uint32_t v) { return std::max(mass[v], 1e-300); };  // every element holds some of the curve
      for (size_t p = 0; p < parts; ++p) {
        if (quota[p] == 0) continue;
        const std::vector<uint32_t> order = morton_order(x, part_elements[p], lo, extent);
        // The weights along the curve gathered in parallel first: the two
        // walks below then read them in a row, where reading mass[order[i]]
        // missed the cache at every element (igea 1M at 20,000 on an H100
        // host: 13 ms of seeds, the longer side of the offsets beside).
        std::vector<double> along(order.size());
        tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 8192), [&](const tbb::blocked_range<size_t>& r) {
          for (size_t i = r.begin(); i != r.end(); ++i) along[i] = weight(order[i]);
        });
        double total = 0;
        for (const double w : along) total += w;
        const Philox4 r = random4(options.seed, p, 0);
        const double offset = (double(r.v[0]) + double(r.v[1]) / 4294967296.0) / 4294967296.0;  // [0, 1)
        const double step = total / quota[p];
        double below = 0;  // mass of order[0 .. i)
        size_t i = 0;
        for (uint32_t k = 0; k < quota[p]; ++k) {
          const double u = (offset + k) * step;
          while (i + 1 < order.size() && below + along[i] <= u) below += along[i++];
          // A taken element (a loop's seed, or a heavy element that holds
          // several steps): the next free one along the curve (always exists:
          // quota <= size).
          size_t j = i;
          while (label[order[j]] != UINT32_MAX) j = (j + 1) % order.size();
          label[order[j]] = uint32_t(seeds.size());
          seeds.push_back(order[j]);
        }
      }
    }
    plan_marks.mark("seeds");
    return Status::Ok();
  };
  marks.mark("normals_parts_seeds");
  std::future<Status> planned;
  if (options.device_smoothing) planned = std::async(std::launch::async, plan);
  const Status offsets =
      anisotropic_offsets(mesh, adj, x, vertex_normal, count, options.anisotropy, options.device_smoothing, cache, &y);
  if (cache_lock) cache_lock.unlock();
  const Status planned_status = planned.valid() ? planned.get() : offsets.ok() ? plan() : Status::Ok();
  VPR_RETURN_IF_ERROR(offsets);
  VPR_RETURN_IF_ERROR(planned_status);
  marks.mark("offsets_plan");
  const std::vector<uint32_t>& part = found.part;
  const bool warm = start_cells > 0;
  if (warm) {
    label = *options.start_label;
  } else {
    // Grow the cells from the seeds over the edges to the nearest seed
    // (cell_growth.h), on the device beside the sweeps' when given.
    CellGrowthInput grow;
    grow.edges = &adj;
    grow.x = x.data();
    grow.normal = vertex_normal.data();
    grow.seeds = &seeds;
    VPR_RETURN_IF_ERROR(options.device_growth ? options.device_growth(grow, &label) : cpu::grow_cells(grow, &label));
  }

  marks.mark("growth");
  uint32_t clusters_now = warm ? start_cells : count;
  std::vector<Cluster> clusters;
  double constant = 0;  // sum m |(x, a n)|^2

  // Elements per (cluster, loop), and clusters per loop: a cluster may not
  // give up its last element on a loop that has only min_per_loop clusters.
  std::unordered_map<uint64_t, uint32_t> on_loop;
  std::vector<uint32_t> loop_clusters(loops.size(), 0);
  auto loop_key = [](uint32_t cluster, uint32_t loop) { return uint64_t(cluster) << 32 | loop; };
  // loops_of_cluster: how many loops each cluster meets (one at most, or two
  // loops would join at its dual vertex).
  std::vector<uint32_t> loops_of_cluster(clusters_now, 0);
  auto loop_add = [&](uint32_t v, uint32_t cluster) {
    if (loop_of[v] == UINT32_MAX) return;
    if (on_loop[loop_key(cluster, loop_of[v])]++ == 0) ++loop_clusters[loop_of[v]], ++loops_of_cluster[cluster];
  };
  auto loop_remove = [&](uint32_t v, uint32_t cluster) {
    if (loop_of[v] == UINT32_MAX) return;
    if (--on_loop[loop_key(cluster, loop_of[v])] == 0) --loop_clusters[loop_of[v]], --loops_of_cluster[cluster];
  };
  // The cells' sums and loop counts from the labels.
  auto rebuild = [&]() {
    clusters.assign(clusters_now, Cluster{});
    on_loop.clear();
    std::fill(loop_clusters.begin(), loop_clusters.end(), 0);
    loops_of_cluster.assign(clusters_now, 0);
    // Each cell's sums over its elements in element order, by ranges of
    // cells, one per thread (core/vertex_ranges.h); the constant's terms in
    // parallel and their sum in element order: the bits of one loop.
    in_vertex_ranges(
        clusters_now,
        [&](uint32_t lo, uint32_t hi) {
          for (uint32_t v = 0; v < nv; ++v) {
            const uint32_t l = label[v];
            if (l < lo || l >= hi) continue;  // another range's, or unlabelled
            Cluster& c = clusters[l];
            c.m += mass[v];
            c.s = c.s + x[v] * mass[v];
            c.t = c.t + y[v] * mass[v];
            c.n = c.n + vertex_normal[v] * mass[v];
            ++c.size;
          }
        },
        256);
    std::vector<double> term(nv);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 8192), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t v = r.begin(); v != r.end(); ++v)
        term[v] = label[v] == UINT32_MAX ? 0.0 : mass[v] * (dot(x[v], x[v]) + dot(y[v], y[v]));
    });
    constant = 0;
    for (uint32_t v = 0; v < nv; ++v)
      if (label[v] != UINT32_MAX) constant += term[v];
    // The loops' counts (integers: any order).
    for (const std::vector<uint32_t>& loop : loops)
      for (uint32_t v : loop)
        if (label[v] != UINT32_MAX) loop_add(v, label[v]);
  };
  rebuild();
  std::vector<double> energy = {total_energy(clusters, constant)};
  auto loop_keeps = [&](uint32_t v, uint32_t from, uint32_t to) {
    const uint32_t l = loop_of[v];
    if (l == UINT32_MAX) return true;
    if (loops_of_cluster[to] > 0) {
      const auto it = on_loop.find(loop_key(to, l));
      if (it == on_loop.end() || it->second == 0) return false;
    }  // `to` is on another loop
    return loop_clusters[l] > options.min_per_loop || on_loop[loop_key(from, l)] > 1;
  };

  // Sweeps: for every edge between two cells, the better of moving either
  // end into the other cell, when it lowers E and keeps both cells disks.
  auto gain = [&](uint32_t v, uint32_t from, uint32_t to) {
    const Cluster& a = clusters[from];
    const Cluster& b = clusters[to];
    const double m = mass[v];
    if (a.size <= 1 || !(a.m - m > 0)) return 0.0;
    const Vec3d sa = a.s - x[v] * m, sb = b.s + x[v] * m;
    const Vec3d ta = a.t - y[v] * m, tb = b.t + y[v] * m;
    const double after = -(dot(sa, sa) + dot(ta, ta)) / (a.m - m) - (dot(sb, sb) + dot(tb, tb)) / (b.m + m);
    return a.energy() + b.energy() - after;  // > 0: E falls
  };
  // v may join `to` only facing the way `to` faces (see kFacing).
  auto faces_with = [&](uint32_t v, uint32_t to) {
    return dot(vertex_normal[v], clusters[to].n) >= kFacing * norm(clusters[to].n);
  };
  auto allowed = [&](uint32_t v, uint32_t from, uint32_t to) {
    return faces_with(v, to) && neighbour_groups(adj, label, v, from) == 1 && neighbour_groups(adj, label, v, to) == 1 &&
           loop_keeps(v, from, to);
  };
  auto move = [&](uint32_t v, uint32_t to) {
    Cluster& a = clusters[label[v]];
    Cluster& b = clusters[to];
    a.m -= mass[v];
    a.s = a.s - x[v] * mass[v];
    a.t = a.t - y[v] * mass[v];
    a.n = a.n - vertex_normal[v] * mass[v];
    --a.size;
    b.m += mass[v];
    b.s = b.s + x[v] * mass[v];
    b.t = b.t + y[v] * mass[v];
    b.n = b.n + vertex_normal[v] * mass[v];
    ++b.size;
    loop_remove(v, label[v]);
    loop_add(v, to);
    label[v] = to;
  };
  int sweep = 0;
  bool converged = false;
  size_t moves = 0;
  // Only pairs of cells one of which changed since the pair was last looked
  // at can gain: a pair whose two cells did not change in the previous sweep
  // (nor yet in this one) gave no move then and gives none now.
  std::vector<char> active(clusters_now, 1), changed(clusters_now, 0);
  // The sweeps in parallel, with the same bits on any thread count. The
  // elements are cut into slabs along the longest axis (equal counts; how
  // many depends on the target, never on the threads). A sweep visits the
  // even slabs at once, then the odd ones, each slab in element order on one
  // thread, as the one-at-a-time sweep does. A slab only moves its own
  // elements, and only between cells it owns: a cell whose elements lie in
  // that slab and its two neighbours only (one owner per colour), so two
  // slabs running together never touch one cell or each other's elements.
  // What a slab may not do it leaves to a last pass on one thread, in
  // element order: moves that involve another slab's cell, elements on a
  // boundary loop (the loops' counts are shared) and elements with a
  // neighbour two slabs away (a long edge).
  // Which elements have a cell is all the schedule reads of the labels, and
  // no sweep changes it. With colour rounds on a device first, the schedule
  // is made on its own thread (from a copy of the labels) while they run:
  // the host would wait for them idle (igea at 10,000 on an H200: 18 ms of
  // schedule beside 38 ms of rounds).
  SlabSchedule schedule;
  std::future<SlabSchedule> schedule_beside;
  if (options.device_sweeps)
    schedule_beside = std::async(std::launch::async, [&x, &adj, &loop_of, count, labels = label] {
      return slab_schedule(x, adj, labels, loop_of, count);
    });
  else
    schedule = slab_schedule(x, adj, label, loop_of, count);
  const uint32_t slabs = slab_count(count);
  std::vector<uint32_t> owner;
  // in_slab[c * slabs + s]: cell c's elements in slab s, kept by the sweeps' moves.
  std::vector<uint32_t> in_slab;
  auto shift = [&](uint32_t v, uint32_t from, uint32_t to) {
    --in_slab[size_t(from) * slabs + schedule.slab_of[v]];
    ++in_slab[size_t(to) * slabs + schedule.slab_of[v]];
  };
  std::vector<std::vector<uint32_t>> deferred(slabs);
  std::vector<size_t> slab_moved(slabs);
  std::vector<uint32_t> last_pass;
  constexpr uint32_t kAnySlab = UINT32_MAX;
  // One element's turn: each neighbouring cell in turn, the move of v into it
  // when it lowers E and keeps both cells disks. False when a move was left
  // to the last pass.
  // v may move in `slab`'s turn: one of its elements, not left to the last pass.
  auto mine = [&](uint32_t v, uint32_t slab) {
    return slab == kAnySlab || (schedule.slab_of[v] == slab && !schedule.last[v]);
  };
  // One element's turn: for every edge from v to another cell, the better of
  // moving either end into the other's cell, when it lowers E and keeps both
  // cells disks. False when a move was left to the last pass.
  auto visit = [&](uint32_t v, uint32_t slab, size_t* moved) {
    bool done = true;
    for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w) {
      const uint32_t a = label[v], b = label[*w];
      if (a == b || a == UINT32_MAX || b == UINT32_MAX) continue;
      if (slab != kAnySlab && (owner[a] != slab || owner[b] != slab)) {
        done = false;
        continue;
      }
      if (!(active[a] | active[b] | changed[a] | changed[b])) continue;
      const double g_v = gain(v, a, b), g_w = mine(*w, slab) ? gain(*w, b, a) : 0.0;
      if (!(std::max(g_v, g_w) > 1e-18 * std::abs(energy.back()))) continue;
      if (g_v >= g_w && allowed(v, a, b)) {
        move(v, b);
        shift(v, a, b);
      } else if (g_w > g_v && allowed(*w, b, a)) {
        move(*w, a);
        shift(*w, b, a);
      } else {
        continue;
      }
      changed[a] = changed[b] = 1;
      ++*moved;
    }
    return done;
  };
  // The colour sweeps first when a twin is given (cvt_sweeps.h: the GPU's):
  // the bulk of the moves, the loops' elements only along their loops; the
  // sweeps below finish from there with every rule. The rounds go on to a
  // quarter of the tolerance, a few more of their cheap sweeps, so that the
  // sweeps here find little left: on igea, horse and fish one sweep instead
  // of 2-4 (bunny, with holes, 4 either way). They have a budget of their
  // own (max_sweeps a call), not counted against the sweeps here.
  size_t device_sweeps = 0;
  std::vector<char> loop_element;  // per element: on a boundary loop (the rounds' input)
  if (options.device_sweeps) {
    loop_element.resize(nv);
    for (uint32_t v = 0; v < nv; ++v) loop_element[v] = loop_of[v] != UINT32_MAX;
  }
  auto optimize = [&]() -> Status {
    if (options.device_sweeps) {
      CvtSweepInput in;
      in.edges = &adj;
      in.x = x.data();
      in.y = y.data();
      in.normal = vertex_normal.data();
      in.mass = mass.data();
      in.on_loop = loop_element.data();
      in.cells = clusters_now;
      in.constant = constant;
      in.tolerance = options.tolerance / 4;
      in.max_sweeps = options.max_sweeps;
      CvtSweepOutput out;
      VPR_RETURN_IF_ERROR(options.device_sweeps(in, &label, &out));
      marks.mark("rounds");
      device_sweeps += size_t(out.sweeps);
      moves += out.moves;
      energy.insert(energy.end(), out.energy.begin(), out.energy.end());
      rebuild();
    }
    marks.mark("sums");
    if (schedule_beside.valid()) schedule = schedule_beside.get();
    marks.mark("schedule_wait");
    converged = false;
    active.assign(clusters_now, 1);
    changed.assign(clusters_now, 0);
    owner.assign(clusters_now, kAnySlab);
    in_slab.assign(size_t(clusters_now) * slabs, 0);
    for (uint32_t v = 0; v < nv; ++v)
      if (label[v] != UINT32_MAX) ++in_slab[size_t(label[v]) * slabs + schedule.slab_of[v]];
    for (; sweep < options.max_sweeps; ++sweep) {
      size_t moved = 0;
      for (uint32_t colour = 0; colour < 2; ++colour) {
        // Owners: the slab of this colour among the ones a cell's elements lie in.
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, clusters_now, 1024), [&](const tbb::blocked_range<uint32_t>& r) {
          for (uint32_t c = r.begin(); c != r.end(); ++c) {
            const uint32_t* row = &in_slab[size_t(c) * slabs];
            uint32_t lo = 0, hi = slabs;
            while (lo < slabs && row[lo] == 0) ++lo;
            while (hi > lo && row[hi - 1] == 0) --hi;
            owner[c] = kAnySlab;
            if (lo == slabs || hi - lo > 3) continue;  // no element, or over more than three slabs
            const uint32_t last = hi - 1;
            if (lo % 2 == colour) {
              if (last - lo < 2) owner[c] = lo;  // else lo and last would both own it
            } else if (lo == last) {
              owner[c] = lo > 0 ? lo - 1 : (lo + 1 < slabs ? lo + 1 : kAnySlab);
            } else {
              owner[c] = lo + 1;
            }
          }
        });
        tbb::parallel_for(uint32_t(0), (slabs - colour + 1) / 2, [&](uint32_t i) {
          const uint32_t slab = 2 * i + colour;
          deferred[slab].clear();
          slab_moved[slab] = 0;
          for (uint32_t v : schedule.elements[slab])
            if (!visit(v, slab, &slab_moved[slab])) deferred[slab].push_back(v);
        });
        for (uint32_t slab = colour; slab < slabs; slab += 2) moved += slab_moved[slab];
      }
      last_pass = schedule.sequential;
      for (const auto& d : deferred) last_pass.insert(last_pass.end(), d.begin(), d.end());
      std::sort(last_pass.begin(), last_pass.end());
      for (uint32_t v : last_pass) visit(v, kAnySlab, &moved);
      moves += moved;
      active.swap(changed);
      std::fill(changed.begin(), changed.end(), 0);
      energy.push_back(total_energy(clusters, constant));
      const double previous = energy[energy.size() - 2], now = energy.back();
      if (moved == 0 || previous - now <= options.tolerance * std::abs(previous)) {
        converged = true;
        ++sweep;
        break;
      }
    }
    return Status::Ok();
  };

  // Topology: the dual is a manifold where every cell's link (the cells
  // around it, in the dual's triangles) is one path or cycle and no two
  // cells share an edge of more than two dual triangles. A cell that breaks
  // this (it wraps a thin part, or meets a neighbour twice) is cut in two
  // along its farthest pair of elements, as many cells elsewhere are merged
  // away, and the sweeps go on; up to max_split_fraction x count splits.
  size_t merged = 0;
  const uint32_t split_budget = uint32_t(std::ceil(options.max_split_fraction * count));
  size_t splits = 0;
  // Cells split, and their neighbours, are never merged away.
  std::vector<char> guarded(clusters_now, 0);
  // What both merges read of the cells: each one's part and normal sum
  // (sum m n), whether it meets a boundary loop, how many cells each part
  // has, and every pair of neighbouring cells, both ways, sorted.
  struct CellGraph {
    std::vector<Vec3d> normal_sum;
    std::vector<uint32_t> part_of, per_part;
    std::vector<char> on_a_loop;
    std::vector<uint64_t> pairs;  // a << 32 | b
  };
  auto cell_graph = [&]() {
    CellGraph g;
    g.normal_sum.assign(clusters_now, Vec3d{0, 0, 0});
    g.part_of.assign(clusters_now, UINT32_MAX);
    g.on_a_loop.assign(clusters_now, 0);
    for (uint32_t v = 0; v < nv; ++v) {
      const uint32_t a = label[v];
      if (a == UINT32_MAX) continue;
      g.normal_sum[a] = g.normal_sum[a] + vertex_normal[v] * mass[v];
      g.part_of[a] = part[v];
      g.on_a_loop[a] |= loop_of[v] != UINT32_MAX;
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w)
        if (label[*w] != a && label[*w] != UINT32_MAX) g.pairs.push_back(uint64_t(a) << 32 | label[*w]);
    }
    tbb::parallel_sort(g.pairs.begin(), g.pairs.end());
    g.pairs.erase(std::unique(g.pairs.begin(), g.pairs.end()), g.pairs.end());
    g.per_part.assign(parts, 0);
    for (uint32_t c = 0; c < clusters_now; ++c)
      if (g.part_of[c] != UINT32_MAX) ++g.per_part[g.part_of[c]];
    return g;
  };
  // Cells `gone` leave (their elements have joined other cells, or join
  // into[c] now when `into` is given); the ids close up in order, `guarded`
  // follows, and the cells' sums and loop counts are rebuilt.
  auto close_up = [&](const std::vector<char>& gone, const std::vector<uint32_t>& into) {
    std::vector<uint32_t> remap(clusters_now, UINT32_MAX);
    uint32_t next = 0;
    for (uint32_t c = 0; c < clusters_now; ++c)
      if (!gone[c]) {
        guarded[next] = guarded[c];
        remap[c] = next++;
      }
    if (!into.empty())
      for (uint32_t c = 0; c < clusters_now; ++c)
        if (gone[c]) remap[c] = remap[into[c]];
    clusters_now = next;
    guarded.resize(clusters_now);
    for (uint32_t& l : label)
      if (l != UINT32_MAX) l = remap[l];
    rebuild();
  };
  // Splits add cells; to keep the count, as many others are merged into their
  // neighbours: the flattest (their elements' normals agree best: far from
  // thin parts and creases, where a merge costs least), each away from any
  // split, from boundary loops and from each other, in parts with cells to
  // spare.
  auto merge = [&](uint32_t surplus) {
    CellGraph g = cell_graph();
    const std::vector<uint64_t>& pairs = g.pairs;
    const std::vector<uint32_t>& part_of = g.part_of;
    std::vector<uint32_t>& per_part = g.per_part;
    std::vector<char> blocked(guarded.begin(), guarded.end());
    for (uint64_t e : pairs)
      if (guarded[e >> 32]) blocked[uint32_t(e)] = 1;
    std::vector<uint32_t> order(clusters_now);
    std::iota(order.begin(), order.end(), 0u);
    auto spread = [&](uint32_t c) { return clusters[c].m > 0 ? 1.0 - norm(g.normal_sum[c]) / clusters[c].m : 1.0; };
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return spread(a) < spread(b); });
    std::vector<char> removed(clusters_now, 0);
    uint32_t taken = 0;
    for (uint32_t c : order) {
      if (taken == surplus) break;
      if (blocked[c] || g.on_a_loop[c] || part_of[c] == UINT32_MAX || per_part[part_of[c]] <= 2 * options.min_per_part)
        continue;
      removed[c] = 1;
      --per_part[part_of[c]];
      ++taken;
      auto first = std::lower_bound(pairs.begin(), pairs.end(), uint64_t(c) << 32);
      for (auto it = first; it != pairs.end() && (*it >> 32) == c; ++it) blocked[uint32_t(*it)] = 1;
    }
    if (taken == 0) return;
    // The removed cells' elements go to the nearest kept cell over the edges.
    using Item = std::pair<double, uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    std::vector<double> dist(nv, INFINITY);
    for (uint32_t v = 0; v < nv; ++v)
      if (label[v] != UINT32_MAX && removed[label[v]])
        for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w)
          if (label[*w] != UINT32_MAX && !removed[label[*w]]) {
            dist[*w] = 0;
            queue.push({0.0, *w});
          }
    while (!queue.empty()) {
      const auto [d, v] = queue.top();
      queue.pop();
      if (d > dist[v]) continue;
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w) {
        if (label[*w] == UINT32_MAX || !removed[label[*w]]) continue;
        const double nd = d + norm(x[*w] - x[v]);
        if (nd < dist[*w]) {
          dist[*w] = nd;
          label[*w] = label[v];  // v's label is final: it was taken before *w's
          queue.push({nd, *w});
        }
      }
    }
    close_up(removed, {});
    merged += taken;
  };
  // A warm start's surplus cells, merged away in rounds: each round takes
  // the pairs of neighbouring cells whose merge raises E least (Ward's
  // criterion: m_a m_b / (m_a + m_b) |c_a - c_b|^2, c the centroid in R^6),
  // cheapest first, no cell in two merges, none on a boundary loop and
  // none in a part left with 2 min_per_part cells or fewer; a pair merges
  // whole (b's elements join a). Ties go by the cells' ids: one result on
  // any thread count.
  size_t warm_merged = 0;
  auto merge_cheapest = [&](uint32_t surplus) {
    while (surplus > 0) {
      CellGraph g = cell_graph();
      const std::vector<uint32_t>& part_of = g.part_of;
      std::vector<uint32_t>& per_part = g.per_part;
      std::vector<uint64_t> pairs;  // a < b
      for (uint64_t e : g.pairs)
        if ((e >> 32) < uint32_t(e)) pairs.push_back(e);
      std::vector<std::pair<double, uint64_t>> cost(pairs.size());
      tbb::parallel_for(tbb::blocked_range<size_t>(0, pairs.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          const Cluster &a = clusters[pairs[i] >> 32], &b = clusters[uint32_t(pairs[i])];
          double c = INFINITY;
          if (a.m > 0 && b.m > 0) {
            const Vec3d ds = a.s * (1.0 / a.m) - b.s * (1.0 / b.m), dt = a.t * (1.0 / a.m) - b.t * (1.0 / b.m);
            c = a.m * b.m / (a.m + b.m) * (dot(ds, ds) + dot(dt, dt));
          }
          cost[i] = {c, pairs[i]};
        }
      });
      tbb::parallel_sort(cost.begin(), cost.end());
      std::vector<char> used(clusters_now, 0), gone(clusters_now, 0);
      std::vector<uint32_t> into(clusters_now, UINT32_MAX);  // b -> a
      uint32_t taken = 0;
      for (const auto& [c, pair] : cost) {
        if (taken == surplus) break;
        const uint32_t a = uint32_t(pair >> 32), b = uint32_t(pair);
        if (!std::isfinite(c) || used[a] || used[b] || g.on_a_loop[a] || g.on_a_loop[b] || part_of[a] != part_of[b] ||
            part_of[a] == UINT32_MAX || per_part[part_of[a]] <= 2 * options.min_per_part)
          continue;
        used[a] = used[b] = gone[b] = 1;
        into[b] = a;
        --per_part[part_of[a]];
        ++taken;
      }
      if (taken == 0) break;  // nothing may merge: more cells than count remain
      close_up(gone, into);
      surplus -= taken;
      warm_merged += taken;
    }
    energy.push_back(total_energy(clusters, constant));
  };
  // The elements of each of `cells` (distinct), in element order.
  auto elements_of = [&](const std::vector<uint32_t>& cells) {
    std::vector<std::vector<uint32_t>> out(cells.size());
    std::vector<uint32_t> slot(clusters_now, UINT32_MAX);
    for (size_t i = 0; i < cells.size(); ++i) slot[cells[i]] = uint32_t(i);
    for (uint32_t v = 0; v < nv; ++v)
      if (label[v] != UINT32_MAX && slot[label[v]] != UINT32_MAX) out[slot[label[v]]].push_back(v);
    return out;
  };
  // Cell c (its elements el, in element order, at least two) cut in two
  // along its farthest pair of elements: Dijkstra from both ends within the
  // cell, the second end's side a new cell. Both sides are connected.
  auto cut_in_two = [&](uint32_t c, const std::vector<uint32_t>& el) {
    const Vec3d centroid = clusters[c].s * (1.0 / clusters[c].m);
    auto farthest = [&](const Vec3d& from) {
      uint32_t best = el[0];
      double best_d = -1;
      for (uint32_t v : el)
        if (norm2(x[v] - from) > best_d) best_d = norm2(x[v] - from), best = v;
      return best;
    };
    const uint32_t p = farthest(centroid), q = farthest(x[p]);
    const uint32_t fresh = clusters_now++;
    clusters.emplace_back();
    loops_of_cluster.push_back(0);
    std::unordered_map<uint32_t, double> dist;
    std::unordered_map<uint32_t, uint32_t> side;
    for (uint32_t v : el) dist[v] = INFINITY;
    using Item = std::pair<double, uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    dist[p] = dist[q] = 0;
    side[p] = c;
    side[q] = fresh;
    queue.push({0.0, p});
    queue.push({0.0, q});
    while (!queue.empty()) {
      const auto [d, v] = queue.top();
      queue.pop();
      if (d > dist[v]) continue;
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w) {
        if (label[*w] != c) continue;
        const double nd = d + norm(x[*w] - x[v]);
        if (nd < dist[*w]) {
          dist[*w] = nd;
          side[*w] = side[v];
          queue.push({nd, *w});
        }
      }
    }
    for (uint32_t v : el)
      if (side.count(v) && side[v] == fresh) move(v, fresh);
  };
  // A warm start from fewer cells than count (a visual target's try above
  // one that failed): in rounds, the cells holding the most of E (their
  // inertia sum m |(x, a n) - centroid|^2, largest first, ties by id) are
  // cut in two, as the topology step cuts a cell, until the count is
  // reached; the sweeps then even the halves out. A cut lowers E most where
  // a cell's inertia is largest (for a cell cut through its centroid along
  // its long axis, by about half of it).
  size_t warm_split = 0;
  auto split_largest = [&](uint32_t missing) {
    while (missing > 0) {
      std::vector<double> moment(clusters_now, 0.0);  // sum m |(x, a n)|^2 per cell, in element order
      in_vertex_ranges(
          clusters_now,
          [&](uint32_t lo, uint32_t hi) {
            for (uint32_t v = 0; v < nv; ++v)
              if (label[v] >= lo && label[v] < hi) moment[label[v]] += mass[v] * (dot(x[v], x[v]) + dot(y[v], y[v]));
          },
          256);
      std::vector<std::pair<double, uint32_t>> order;  // (-inertia, cell): largest first
      for (uint32_t c = 0; c < clusters_now; ++c)
        if (clusters[c].size >= 2 && clusters[c].m > 0) order.push_back({-(moment[c] + clusters[c].energy()), c});
      std::sort(order.begin(), order.end());
      if (order.empty()) break;  // no cell can be cut: fewer cells than count remain
      order.resize(std::min<size_t>(order.size(), missing));
      std::vector<uint32_t> cut(order.size());
      for (size_t i = 0; i < order.size(); ++i) cut[i] = order[i].second;
      std::sort(cut.begin(), cut.end());
      const std::vector<std::vector<uint32_t>> members = elements_of(cut);
      for (size_t i = 0; i < cut.size(); ++i) cut_in_two(cut[i], members[i]);
      rebuild();
      missing -= uint32_t(cut.size());
      warm_split += cut.size();
    }
    guarded.resize(clusters_now, 0);
    energy.push_back(total_energy(clusters, constant));
  };
  marks.mark("setup");
  if (warm && clusters_now > count) merge_cheapest(clusters_now - count);
  if (warm && clusters_now < count) split_largest(count - clusters_now);
  VPR_RETURN_IF_ERROR(optimize());

  marks.mark("optimize");
  // The defective cells of the labels as they end, when the last round
  // counted them and changed nothing after (else counted again below).
  size_t defective_at_end = SIZE_MAX;
  for (int round = 0; round < options.topology_rounds; ++round) {
    std::vector<uint32_t> bad = defective_cells(mesh, adj, label, clusters_now);
    const size_t defective = bad.size();
    for (uint32_t c = 0; c < clusters_now; ++c)  // a cell on two loops would join them
      if (loops_of_cluster[c] > 1) bad.push_back(c);
    std::sort(bad.begin(), bad.end());
    bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
    if (bad.empty() || splits >= split_budget) {
      if (round == 0 || clusters_now == count) {
        defective_at_end = defective;
        break;
      }
      bad.clear();  // no split this round: the merges below bring the count back
    }
    if (bad.size() > split_budget - splits) {
      // The heaviest first: their defects span the most surface.
      std::stable_sort(bad.begin(), bad.end(), [&](uint32_t a, uint32_t b) { return clusters[a].m > clusters[b].m; });
      bad.resize(split_budget - splits);
      std::sort(bad.begin(), bad.end());
    }
    const std::vector<std::vector<uint32_t>> members = elements_of(bad);
    for (size_t i = 0; i < bad.size(); ++i) {
      const uint32_t c = bad[i];
      const std::vector<uint32_t>& el = members[i];
      if (el.size() < 2) continue;
      cut_in_two(c, el);
    }
    splits += bad.size();
    // Where a cell had to be split the surface needs finer cells than the
    // density asked for (a thin part, a narrow handle): its elements weigh
    // more from now on, so the sweeps keep the cells there small.
    for (const std::vector<uint32_t>& el : members)
      for (uint32_t v : el) mass[v] *= options.split_mass_factor;
    rebuild();
    for (uint32_t c : bad) guarded[c] = 1;
    guarded.resize(clusters_now, 1);
    if (clusters_now > count) merge(clusters_now - count);
    energy.push_back(total_energy(clusters, constant));
    VPR_RETURN_IF_ERROR(optimize());
  }

  marks.mark("topology");
  if (stats) {
    stats->sweeps = sweep + int(device_sweeps);
    stats->converged = converged;
    stats->energy = std::move(energy);
    stats->moves = moves;
    stats->clusters = clusters_now;
    stats->cells_split = splits;
    stats->cells_merged = merged;
    stats->warm_merged = warm_merged;
    stats->warm_split = warm_split;
    stats->device_sweeps = device_sweeps;
    stats->defective_cells = defective_at_end != SIZE_MAX ? defective_at_end
                                                          : defective_cells(mesh, adj, label, clusters_now).size();
  }
  marks.mark("stats");
  *label_out = std::move(label);
  return Status::Ok();
}

}  // namespace vpr
