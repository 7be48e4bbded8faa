#include "surface/pinch_split.h"

#include <algorithm>
#include <numeric>

namespace vpr {

std::vector<std::pair<uint32_t, uint32_t>> split_pinched_vertices(std::vector<uint32_t>* indices_io,
                                                                   size_t* vertex_count) {
  std::vector<uint32_t>& indices = *indices_io;
  const size_t nv = *vertex_count;
  // Corners by vertex (counting sort: the faces of each vertex ascending).
  std::vector<uint32_t> offset(nv + 1, 0);
  for (uint32_t v : indices) ++offset[v + 1];
  std::partial_sum(offset.begin(), offset.end(), offset.begin());
  std::vector<uint32_t> corner(indices.size()), fill(offset.begin(), offset.end() - 1);
  for (size_t c = 0; c < indices.size(); ++c) corner[fill[indices[c]]++] = uint32_t(c);

  std::vector<std::pair<uint32_t, uint32_t>> copies;
  std::vector<std::pair<uint32_t, uint32_t>> spokes;  // (other end, corner's slot) of v's edges
  std::vector<uint32_t> fan, name;  // per slot of v: its fan's root; per root: its vertex
  for (uint32_t v = 0; v < nv; ++v) {
    const uint32_t begin = offset[v], n = offset[v + 1] - begin;
    if (n < 2) continue;
    // Two of v's faces are in one fan when they share an edge at v: union
    // the slots of every spoke's faces.
    fan.resize(n);
    std::iota(fan.begin(), fan.end(), 0u);
    auto find = [&](uint32_t a) {
      while (fan[a] != a) a = fan[a] = fan[fan[a]];
      return a;
    };
    spokes.clear();
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t c = corner[begin + i], f = c / 3;
      const uint32_t a = indices[3 * f + (c + 1) % 3], b = indices[3 * f + (c + 2) % 3];
      if (a == v || b == v || a == b) continue;  // a degenerate face joins nothing
      spokes.push_back({a, i});
      spokes.push_back({b, i});
    }
    std::sort(spokes.begin(), spokes.end());
    for (size_t k = 1; k < spokes.size(); ++k)
      if (spokes[k].first == spokes[k - 1].first) {
        const uint32_t ra = find(spokes[k].second), rb = find(spokes[k - 1].second);
        if (ra != rb) fan[std::max(ra, rb)] = std::min(ra, rb);  // the root is the fan's first face
      }
    // The first fan (that of v's first face) keeps v; each other fan, in the
    // order of its first face, gets a copy.
    name.assign(n, UINT32_MAX);
    bool kept = false;
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t c = corner[begin + i], f = c / 3;
      const uint32_t a = indices[3 * f + (c + 1) % 3], b = indices[3 * f + (c + 2) % 3];
      if (a == v || b == v || a == b) continue;
      const uint32_t r = find(i);
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
  }
  return copies;
}

}  // namespace vpr
