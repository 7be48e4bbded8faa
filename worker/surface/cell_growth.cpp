#include "surface/cell_growth.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

namespace vpr {

Status check_cell_growth_input(const CellGrowthInput& in, const std::vector<uint32_t>& label) {
  if (!in.edges || !in.x || !in.normal || !in.seeds) return invalid_argument("cell growth: missing element arrays");
  const size_t nv = in.edges->vertex_count();
  if (label.size() != nv)
    return invalid_argument("cell growth: " + std::to_string(label.size()) + " labels for " + std::to_string(nv) +
                            " elements");
  for (size_t c = 0; c < in.seeds->size(); ++c)
    if ((*in.seeds)[c] >= nv || label[(*in.seeds)[c]] != c)
      return invalid_argument("cell growth: seed " + std::to_string(c) + " is not an element labelled with its cell");
  return Status::Ok();
}

namespace cpu {

// At the end each element's cell is that of a neighbour nearer the same
// seed: the cells are connected.
Status grow_cells(const CellGrowthInput& in, std::vector<uint32_t>* label_io) {
  VPR_RETURN_IF_ERROR(check_cell_growth_input(in, *label_io));
  const MeshEdges& adj = *in.edges;
  const size_t nv = adj.vertex_count();
  const std::vector<uint32_t>& seeds = *in.seeds;
  std::vector<uint32_t>& label = *label_io;
  std::vector<double> dist(nv, INFINITY);
  for (uint32_t s : seeds) dist[s] = 0;
  // The rounds' sets are the same on any thread count; the order in which
  // threads list them is not, and nothing depends on it.
  std::unique_ptr<std::atomic<uint32_t>[]> listed(new std::atomic<uint32_t>[nv]);
  for (size_t v = 0; v < nv; ++v) listed[v].store(0, std::memory_order_relaxed);
  std::vector<uint32_t> front = seeds, candidates;
  std::vector<std::pair<double, uint32_t>> better;
  tbb::enumerable_thread_specific<std::vector<uint32_t>> local;
  auto gather = [&](std::vector<uint32_t>* out) {
    out->clear();
    for (auto& l : local) out->insert(out->end(), l.begin(), l.end()), l.clear();
  };
  std::vector<char> settled(nv, 0);
  uint32_t round = 1;
  auto grow = [&](bool facing) {
    for (; !front.empty(); ++round) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, front.size(), 512), [&](const tbb::blocked_range<size_t>& r) {
        auto& out = local.local();
        for (size_t i = r.begin(); i != r.end(); ++i)
          for (const uint32_t* w = adj.begin(front[i]); w != adj.end(front[i]); ++w)
            if (!settled[*w] && listed[*w].exchange(round, std::memory_order_relaxed) != round) out.push_back(*w);
      });
      gather(&candidates);
      better.resize(candidates.size());
      tbb::parallel_for(
          tbb::blocked_range<size_t>(0, candidates.size(), 512), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t i = r.begin(); i != r.end(); ++i)
              cell_growth_best(adj.offset.data(), adj.neighbor.data(), in.x, in.normal, seeds.data(), dist.data(),
                               label.data(), facing, candidates[i], &better[i].first, &better[i].second);
          });
      tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates.size(), 512),
                        [&](const tbb::blocked_range<size_t>& r) {
                          auto& out = local.local();
                          for (size_t i = r.begin(); i != r.end(); ++i)
                            if (better[i].second != kNoCell) {
                              dist[candidates[i]] = better[i].first;
                              label[candidates[i]] = better[i].second;
                              out.push_back(candidates[i]);
                            }
                        });
      gather(&front);
    }
  };
  grow(true);
  front.clear();
  for (uint32_t v = 0; v < nv; ++v) {
    settled[v] = label[v] != kNoCell;
    if (settled[v] && std::any_of(adj.begin(v), adj.end(v), [&](uint32_t w) { return label[w] == kNoCell; }))
      front.push_back(v);
  }
  grow(false);
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
