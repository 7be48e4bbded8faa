#include "surface/pinch_split.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/vec3.h"
#include "surface/mesh_edges.h"

namespace vpr {
namespace {

constexpr double kTwoPi = 6.283185307179586;

// One vertex's faces grouped into fans, with the scratch it reuses from
// vertex to vertex (one per thread).
struct FanFinder {
  const std::vector<uint32_t>& indices;
  const std::vector<uint32_t>& offset;  // the corners of vertex v: corner[offset[v] .. offset[v + 1])
  const std::vector<uint32_t>& corner;
  const std::vector<double>& positions;
  const std::vector<std::pair<uint32_t, uint32_t>>& copies;
  const size_t nv;
  std::vector<std::pair<uint32_t, uint32_t>> spokes;  // (other end, corner's slot) of v's edges
  std::vector<uint32_t> fan;                          // per slot of v: its fan's root (find)
  std::vector<uint32_t> run_faces;
  std::vector<int> run_forward;
  // When set: each edge from v to a higher vertex that v's faces use once or
  // more than twice (an open edge: pinch_split.h), as group(v) meets it.
  std::vector<std::pair<uint32_t, uint32_t>>* open = nullptr;

  Vec3d position(uint32_t i) const {  // a copy sits where its original does
    const size_t o = i < nv ? i : copies[i - nv].second;
    return Vec3d{positions[3 * o], positions[3 * o + 1], positions[3 * o + 2]};
  }
  uint32_t find(uint32_t a) {
    while (fan[a] != a) a = fan[a] = fan[fan[a]];
    return a;
  }
  void join(uint32_t a, uint32_t b) {
    const uint32_t ra = find(a), rb = find(b);
    if (ra != rb) fan[std::max(ra, rb)] = std::min(ra, rb);  // the root is the fan's first face
  }
  // Slot i of v's corners: false for a degenerate face (it joins nothing).
  bool joins(uint32_t v, uint32_t i) const {
    const uint32_t c = corner[offset[v] + i], f = c / 3;
    const uint32_t a = indices[3 * f + (c + 1) % 3], b = indices[3 * f + (c + 2) % 3];
    return !(a == v || b == v || a == b);
  }

  // The faces round an edge used by more than two, paired into sheets: going
  // round the edge (from its lower-numbered end a to b), a face's normal
  // points towards increasing angle when it runs a -> b and towards
  // decreasing angle when it runs b -> a; the sector between a face whose
  // normal points away from it on each side is inside a solid, and those two
  // faces are one sheet there (two boxes that share an edge stay two closed
  // boxes; a fin on a face is left alone, its own sheet). partner[i]: the
  // slot of run_faces paired with slot i, or itself.
  std::vector<std::pair<double, uint32_t>> round;
  std::vector<uint32_t> partner;
  bool coincident = false;

  void pair_round_edge(uint32_t a, uint32_t b) {
    const std::vector<uint32_t>& faces = run_faces;
    const std::vector<int>& forward = run_forward;
    const size_t k = faces.size();
    partner.resize(k);
    std::iota(partner.begin(), partner.end(), 0u);
    coincident = false;
    const Vec3d pa = position(a), d = position(b) - pa;
    const double len2 = dot(d, d);
    if (!(len2 > 0)) {
      coincident = true;  // no direction to go round: joined as it was
      return;
    }
    Vec3d e1{0, 0, 0}, e2{0, 0, 0};
    round.clear();
    for (size_t i = 0; i < k; ++i) {
      const uint32_t* t = &indices[3 * size_t(faces[i])];
      uint32_t o = t[0];
      for (int c = 0; c < 3; ++c)
        if (t[c] != a && t[c] != b) o = t[c];
      Vec3d r = position(o) - pa;
      r = r - d * (dot(r, d) / len2);  // across the edge
      if (i == 0) {
        e1 = r;
        e2 = cross(d, r);
      }
      round.push_back({std::atan2(dot(r, e2), dot(r, e1) * std::sqrt(len2)), uint32_t(i)});  // |e2| = |d| |e1|
    }
    std::sort(round.begin(), round.end());  // by angle, ties by slot: one order
    // Two faces on top of each other (a double-sided sheet: the same
    // triangles both ways round) leave a sector of no width between them,
    // which no solid's inside can be: the one whose normal points into it
    // from below (towards increasing angle) goes first, so that both
    // normals face that sector and it counts as outside. A double-sided
    // wall inside a box then bounds the solid on each side with one of its
    // two sheets (two closed boxes, as a modeller meant), and a double-sided
    // fin comes off the face it stands on. Any other tie (more than two
    // faces, or two the same way round) stays joined as it was (all the
    // edge's faces one fan).
    for (size_t j = 0; j < k;) {
      size_t e = j + 1;
      while (e < k && !(round[e].first - round[e - 1].first > 1e-9)) ++e;
      if (e - j > 2 || (e - j == 2 && forward[round[j].second] == forward[round[j + 1].second])) {
        coincident = true;
        return;
      }
      if (e - j == 2 && !forward[round[j].second]) std::swap(round[j], round[j + 1]);
      j = e;
    }
    if (!(round[0].first + kTwoPi - round[k - 1].first > 1e-9)) {  // a tie across the cut at pi
      coincident = true;
      return;
    }
    for (size_t j = 0; j < k; ++j) {
      const uint32_t s = round[j].second, t = round[(j + 1) % k].second;
      // s's normal points back (b -> a), t's forward (a -> b): inside between them.
      if (!forward[s] && forward[t] && partner[s] == s && partner[t] == t && s != t) partner[s] = t, partner[t] = s;
    }
  }

  // Groups v's corners into fans (fan, find); returns how many fans its
  // faces that join anything form.
  size_t group(uint32_t v) {
    const uint32_t begin = offset[v], n = offset[v + 1] - begin;
    // Two of v's faces are in one fan when they share an edge at v (and, on
    // an edge of more than two faces, are one sheet there).
    fan.resize(n);
    std::iota(fan.begin(), fan.end(), 0u);
    spokes.clear();
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t c = corner[begin + i], f = c / 3;
      const uint32_t a = indices[3 * f + (c + 1) % 3], b = indices[3 * f + (c + 2) % 3];
      if (a == v || b == v || a == b) continue;  // a degenerate face joins nothing
      spokes.push_back({a, i});
      spokes.push_back({b, i});
    }
    std::sort(spokes.begin(), spokes.end());
    for (size_t lo = 0; lo < spokes.size();) {
      size_t hi = lo + 1;
      while (hi < spokes.size() && spokes[hi].first == spokes[lo].first) ++hi;
      if (open && hi - lo != 2 && spokes[lo].first > v) open->push_back({v, spokes[lo].first});
      if (hi - lo == 2) {
        join(spokes[lo].second, spokes[lo + 1].second);
      } else if (hi - lo > 2) {
        const uint32_t w = spokes[lo].first, a = std::min(v, w), b = std::max(v, w);
        run_faces.clear();
        run_forward.clear();
        for (size_t s = lo; s < hi; ++s) {
          const uint32_t c = corner[begin + spokes[s].second], f = c / 3;
          run_faces.push_back(f);
          // a -> b in this face: the corner after a is b.
          const uint32_t* t = &indices[3 * size_t(f)];
          int forward = 0;
          for (int q = 0; q < 3; ++q) forward |= t[q] == a && t[(q + 1) % 3] == b;
          run_forward.push_back(forward);
        }
        pair_round_edge(a, b);
        for (size_t s = 0; s < hi - lo; ++s)
          if (coincident) join(spokes[lo].second, spokes[lo + s].second);
          else if (partner[s] != s) join(spokes[lo + s].second, spokes[lo + partner[s]].second);
      }
      lo = hi;
    }
    size_t fans = 0;
    for (uint32_t i = 0; i < n; ++i) fans += joins(v, i) && find(i) == i;
    return fans;
  }
};

}  // namespace

std::vector<std::pair<uint32_t, uint32_t>> split_pinched_vertices(std::vector<uint32_t>* indices_io,
                                                                   size_t* vertex_count,
                                                                   const std::vector<double>& positions,
                                                                   std::vector<std::pair<uint32_t, uint32_t>>* open_edges) {
  std::vector<uint32_t>& indices = *indices_io;
  const size_t nv = *vertex_count;
  // Corners by vertex (the faces of each vertex ascending: mesh_edges.h).
  const VertexCorners by_vertex = vertex_corners(indices, nv);
  const std::vector<uint32_t>&offset = by_vertex.offset, &corner = by_vertex.corner;

  std::vector<std::pair<uint32_t, uint32_t>> copies;
  // The vertices whose faces form more than one fan as the mesh comes, found
  // in parallel: nearly every vertex has one fan, and walking them was most
  // of the cost.
  std::vector<char> pinched(nv, 0);
  tbb::enumerable_thread_specific<FanFinder> finders(
      [&] { return FanFinder{indices, offset, corner, positions, copies, nv}; });
  tbb::enumerable_thread_specific<std::vector<std::pair<uint32_t, uint32_t>>> open;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    FanFinder& finder = finders.local();
    finder.open = open_edges ? &open.local() : nullptr;
    for (size_t v = r.begin(); v != r.end(); ++v) pinched[v] = finder.group(uint32_t(v)) > 1;
  });
  if (open_edges) {
    open_edges->clear();
    for (const auto& list : open) open_edges->insert(open_edges->end(), list.begin(), list.end());
    std::sort(open_edges->begin(), open_edges->end());  // one order on any thread count
  }
  // Then in vertex order, as the serial walk of every vertex went: a vertex
  // given copies renames its corners in its neighbours' faces, which can
  // change their fans, so a vertex is walked again when it was pinched or a
  // neighbour before it got copies; every other vertex keeps its one fan and
  // its name, as the walk would have left it.
  std::vector<char> touched(nv, 0);
  FanFinder finder{indices, offset, corner, positions, copies, nv};
  std::vector<uint32_t> name;  // per root: its vertex
  for (uint32_t v = 0; v < nv; ++v) {
    if (!pinched[v] && !touched[v]) continue;
    const uint32_t begin = offset[v], n = offset[v + 1] - begin;
    finder.group(v);
    const size_t copies_before = copies.size();
    // The first fan (that of v's first face) keeps v; each other fan, in the
    // order of its first face, gets a copy.
    name.assign(n, UINT32_MAX);
    bool kept = false;
    for (uint32_t i = 0; i < n; ++i) {
      if (!finder.joins(v, i)) continue;
      const uint32_t c = corner[begin + i];
      const uint32_t r = finder.find(i);
      if (name[r] == UINT32_MAX) {
        if (!kept) {
          name[r] = v;
          kept = true;
        } else {
          name[r] = uint32_t(*vertex_count);
          copies.push_back({uint32_t((*vertex_count)++), v});
        }
      }
      indices[c] = name[r];
    }
    if (copies.size() > copies_before)
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t f = corner[begin + i] / 3;
        for (int q = 0; q < 3; ++q)
          if (indices[3 * f + q] < nv) touched[indices[3 * f + q]] = 1;
      }
  }
  return copies;
}

}  // namespace vpr
