// Peer: meshoptimizer's simplifier (meshopt_simplify: edge collapses ordered by
// a quadric error metric, topology-preserving), the fast choice of game engines.
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "peers.h"
#include "peers_internal.h"

namespace vpr::peers {
namespace {

size_t referenced_vertices(const std::vector<unsigned>& indices, size_t count, size_t vertex_count) {
  std::vector<uint8_t> used(vertex_count, 0);
  size_t n = 0;
  for (size_t i = 0; i < count; ++i) n += !used[indices[i]]++;
  return n;
}

}  // namespace

StatusOr<PeerResult> meshopt_simplify(const Mesh& input, uint32_t target_vertices) {
  if (Status s = check_input(input, target_vertices, "meshoptimizer"); !s.ok()) return s;
  const auto start = Clock::now();
  // Weld corners at exactly the same position: a soup (or an OBJ split at its
  // texture seams) would otherwise have borders everywhere, and meshoptimizer
  // only collapses a border vertex along its border.
  const size_t index_count = input.indices.size();
  std::vector<unsigned> remap(input.vertex_count());
  const size_t welded = meshopt_generateVertexRemap(remap.data(), input.indices.data(), index_count,
                                                    input.positions.data(), input.vertex_count(), 3 * sizeof(float));
  std::vector<float> positions(3 * welded);
  meshopt_remapVertexBuffer(positions.data(), input.positions.data(), input.vertex_count(), 3 * sizeof(float),
                            remap.data());
  std::vector<unsigned> indices(index_count);
  meshopt_remapIndexBuffer(indices.data(), input.indices.data(), index_count, remap.data());
  // Degenerate (repeated-index) faces after welding carry no surface.
  size_t kept = 0;
  for (size_t f = 0; f < index_count / 3; ++f) {
    const unsigned a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
    if (a == b || b == c || a == c) continue;
    indices[kept++] = a;
    indices[kept++] = b;
    indices[kept++] = c;
  }
  indices.resize(kept);
  const size_t have = referenced_vertices(indices, indices.size(), welded);
  if (have == 0) return invalid_argument("meshoptimizer: every face is degenerate once equal positions are welded");

  PeerResult result;
  std::vector<unsigned> out(indices.size()), best;
  size_t best_vertices = 0;
  double target_indices = double(indices.size()) * std::min(1.0, double(target_vertices) / double(have));
  int runs = 0;
  size_t previous = SIZE_MAX;
  const auto core_start = Clock::now();
  for (; runs < 4; ++runs) {
    const size_t ti = std::max<size_t>(3, size_t(std::llround(target_indices / 3)) * 3);
    const size_t n = ::meshopt_simplify(out.data(), indices.data(), indices.size(), positions.data(), welded,
                                        3 * sizeof(float), ti, 1.0f, 0, nullptr);
    const size_t got = referenced_vertices(out, n, welded);
    const auto miss = [&](size_t v) { return std::abs(double(v) - double(target_vertices)); };
    if (best.empty() || miss(got) < miss(best_vertices)) {
      best.assign(out.begin(), out.begin() + ptrdiff_t(n));
      best_vertices = got;
    }
    if (miss(got) <= 0.01 * target_vertices || got == previous || target_vertices >= have) break;
    previous = got;
    target_indices *= double(target_vertices) / double(got);
    target_indices = std::min(target_indices, double(indices.size()));
  }
  result.core_ms = ms_since(core_start);
  result.mesh = compact(positions, std::vector<uint32_t>(best.begin(), best.end()));
  result.mesh.origin = input.origin;  // positions stay in the input's frame
  result.mesh.scale = input.scale;
  result.ms = ms_since(start);
  char note[160];
  std::snprintf(note, sizeof note, "landed on %zu vertices (target %u, %+.2f%%) after %d run%s", best_vertices,
                target_vertices, 100.0 * (double(best_vertices) / target_vertices - 1), std::min(runs + 1, 4),
                runs == 0 ? "" : "s");
  result.note = note;
  return result;
}

}  // namespace vpr::peers
