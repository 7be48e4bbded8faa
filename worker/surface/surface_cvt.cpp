#include "surface/surface_cvt.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <queue>
#include <string>

#include "core/rng.h"
#include "core/vec3.h"

namespace vpr {
namespace {

// Vertex adjacency in compressed rows, neighbours sorted.
struct Adjacency {
  std::vector<uint32_t> offset, neighbor;
  size_t degree(uint32_t v) const { return offset[v + 1] - offset[v]; }
  const uint32_t* begin(uint32_t v) const { return neighbor.data() + offset[v]; }
  const uint32_t* end(uint32_t v) const { return neighbor.data() + offset[v + 1]; }
  bool adjacent(uint32_t a, uint32_t b) const { return std::binary_search(begin(a), end(a), b); }
};

Adjacency adjacency(const Mesh& mesh) {
  const size_t nv = mesh.vertex_count();
  std::vector<uint64_t> edges;
  edges.reserve(6 * mesh.face_count());
  for (size_t f = 0; f < mesh.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint64_t a = mesh.indices[3 * f + c], b = mesh.indices[3 * f + (c + 1) % 3];
      edges.push_back(a << 32 | b);
      edges.push_back(b << 32 | a);
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  Adjacency adj;
  adj.offset.assign(nv + 1, 0);
  adj.neighbor.resize(edges.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    ++adj.offset[(edges[i] >> 32) + 1];
    adj.neighbor[i] = uint32_t(edges[i]);
  }
  for (size_t v = 0; v < nv; ++v) adj.offset[v + 1] += adj.offset[v];
  return adj;
}

struct Cluster {
  double m = 0;
  Vec3d s{0, 0, 0};
  size_t size = 0;
  // -|s|^2 / m: the cluster's energy less sum m |x|^2, which no move changes.
  double energy() const { return m > 0 ? -dot(s, s) / m : 0.0; }
};

double total_energy(const std::vector<Cluster>& clusters, double constant) {
  double e = constant;
  for (const Cluster& c : clusters) e += c.energy();
  return e;
}

// Whether v's neighbours in cluster `c` stay connected to each other without
// v (through edges among v's neighbours): if not, taking v out of c could cut
// c in two. A local test, conservative on a manifold.
bool removable(const Adjacency& adj, const std::vector<uint32_t>& label, uint32_t v, uint32_t c) {
  uint32_t ring[64];
  size_t n = 0;
  for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w)
    if (label[*w] == c) {
      if (n == 64) return false;
      ring[n++] = *w;
    }
  if (n <= 1) return n == 1;  // a lone element of c beside v keeps c whole; none: v is c's last element
  uint32_t parent[64];
  std::iota(parent, parent + n, 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  size_t groups = n;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      if (adj.adjacent(ring[i], ring[j])) {
        const uint32_t a = find(uint32_t(i)), b = find(uint32_t(j));
        if (a != b) {
          parent[a] = b;
          --groups;
        }
      }
  return groups == 1;
}

}  // namespace

std::vector<double> vertex_areas(const Mesh& mesh) {
  std::vector<double> area(mesh.vertex_count(), 0.0);
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const uint32_t* t = &mesh.indices[3 * f];
    const Vec3d a = load3d(mesh.positions.data(), t[0]), b = load3d(mesh.positions.data(), t[1]),
                c = load3d(mesh.positions.data(), t[2]);
    const double third = norm(cross(b - a, c - a)) / 6.0;
    for (int k = 0; k < 3; ++k) area[t[k]] += third;
  }
  return area;
}

Status surface_cvt(const Mesh& mesh, const std::vector<double>& mass, uint32_t count, const CvtOptions& options,
                   std::vector<uint32_t>* label_out, CvtStats* stats) {
  const size_t nv = mesh.vertex_count();
  if (mass.size() != nv) return invalid_argument("surface CVT: one mass per vertex expected");
  if (count < 1) return invalid_argument("surface CVT: at least one cluster");
  const Adjacency adj = adjacency(mesh);
  std::vector<Vec3d> x(nv);
  for (size_t v = 0; v < nv; ++v) x[v] = load3d(mesh.positions.data(), v);

  // Connected parts (elements with mass only; isolated vertices have none).
  std::vector<uint32_t> part(nv, UINT32_MAX);
  std::vector<double> part_mass;
  std::vector<std::vector<uint32_t>> part_elements;
  for (uint32_t s = 0; s < nv; ++s) {
    if (part[s] != UINT32_MAX || adj.degree(s) == 0) continue;
    const uint32_t id = uint32_t(part_mass.size());
    part_mass.push_back(0);
    part_elements.emplace_back();
    std::vector<uint32_t> stack = {s};
    part[s] = id;
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      part_mass[id] += mass[v];
      part_elements[id].push_back(v);
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w)
        if (part[*w] == UINT32_MAX) {
          part[*w] = id;
          stack.push_back(*w);
        }
    }
  }
  const size_t parts = part_mass.size();
  size_t elements = 0;
  for (const auto& e : part_elements) elements += e.size();
  if (elements < count)
    return invalid_argument("surface CVT: " + std::to_string(count) + " clusters need at least as many elements, got " +
                            std::to_string(elements));

  // Clusters per part: in proportion to its mass, at least min_per_part (or
  // all its elements) where the target allows; largest remainders first.
  const double total_mass = std::accumulate(part_mass.begin(), part_mass.end(), 0.0);
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
      const double share = total_mass > 0 ? double(count) * part_mass[p] / total_mass : 0.0;
      quota[p] = std::min<uint32_t>(uint32_t(share), uint32_t(part_elements[p].size()));
      if (minimum_fits) quota[p] = std::max(quota[p], floor_of[p]);
      assigned += quota[p];
      remainder.push_back({share - std::floor(share), p});
    }
    std::sort(remainder.begin(), remainder.end(), [](auto a, auto b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
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

  // Seeds: per part, elements drawn in proportion to mass (Philox keyed by
  // the seed: the same on every machine and thread count).
  std::vector<uint32_t> label(nv, UINT32_MAX);
  std::vector<uint32_t> seeds;
  for (size_t p = 0; p < parts; ++p) {
    const auto& el = part_elements[p];
    std::vector<double> cumulative(el.size());
    double acc = 0;
    for (size_t i = 0; i < el.size(); ++i) cumulative[i] = acc += std::max(mass[el[i]], 1e-300);
    uint64_t draw = 0;
    for (uint32_t k = 0; k < quota[p]; ++draw) {
      const Philox4 r = random4(options.seed, p, draw);
      const double u = (double(r.v[0]) + double(r.v[1]) / 4294967296.0) / 4294967296.0 * acc;
      size_t i = size_t(std::upper_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin());
      i = std::min(i, el.size() - 1);
      // A taken element: the next free one in the part's order (always exists: quota <= size).
      while (label[el[i]] != UINT32_MAX) i = (i + 1) % el.size();
      label[el[i]] = uint32_t(seeds.size());
      seeds.push_back(el[i]);
      ++k;
    }
  }

  // Grow the cells from the seeds over the edges, nearest first (Dijkstra on
  // edge lengths), so every cell starts connected.
  {
    using Item = std::pair<double, uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    std::vector<double> dist(nv, INFINITY);
    for (uint32_t s : seeds) {
      dist[s] = 0;
      queue.push({0.0, s});
    }
    while (!queue.empty()) {
      const auto [d, v] = queue.top();
      queue.pop();
      if (d > dist[v]) continue;
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w) {
        const double nd = d + norm(x[*w] - x[v]);
        if (nd < dist[*w]) {
          dist[*w] = nd;
          label[*w] = label[v];
          queue.push({nd, *w});
        }
      }
    }
  }

  std::vector<Cluster> clusters(count);
  double constant = 0;  // sum m |x|^2
  for (uint32_t v = 0; v < nv; ++v) {
    if (label[v] == UINT32_MAX) continue;
    Cluster& c = clusters[label[v]];
    c.m += mass[v];
    c.s = c.s + x[v] * mass[v];
    ++c.size;
    constant += mass[v] * dot(x[v], x[v]);
  }
  std::vector<double> energy = {total_energy(clusters, constant)};

  // Sweeps: for every edge between two cells, the better of moving either
  // end into the other cell, when it lowers E.
  auto gain = [&](uint32_t v, uint32_t from, uint32_t to) {
    const Cluster& a = clusters[from];
    const Cluster& b = clusters[to];
    const double m = mass[v];
    if (a.size <= 1 || !(a.m - m > 0)) return 0.0;
    const Vec3d sa = a.s - x[v] * m, sb = b.s + x[v] * m;
    const double after = -dot(sa, sa) / (a.m - m) - dot(sb, sb) / (b.m + m);
    return a.energy() + b.energy() - after;  // > 0: E falls
  };
  auto move = [&](uint32_t v, uint32_t to) {
    Cluster& a = clusters[label[v]];
    Cluster& b = clusters[to];
    a.m -= mass[v];
    a.s = a.s - x[v] * mass[v];
    --a.size;
    b.m += mass[v];
    b.s = b.s + x[v] * mass[v];
    ++b.size;
    label[v] = to;
  };
  int sweep = 0;
  bool converged = false;
  size_t moves = 0;
  for (; sweep < options.max_sweeps; ++sweep) {
    size_t moved = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      if (label[v] == UINT32_MAX) continue;
      for (const uint32_t* w = adj.begin(v); w != adj.end(v); ++w) {
        const uint32_t a = label[v], b = label[*w];
        if (a == b) continue;
        const double g_v = gain(v, a, b), g_w = gain(*w, b, a);
        const double best = std::max(g_v, g_w);
        if (!(best > 1e-18 * std::abs(energy.back()))) continue;
        if (g_v >= g_w && removable(adj, label, v, a)) {
          move(v, b);
          ++moved;
        } else if (g_w > g_v && removable(adj, label, *w, b)) {
          move(*w, a);
          ++moved;
        }
      }
    }
    moves += moved;
    energy.push_back(total_energy(clusters, constant));
    const double previous = energy[energy.size() - 2], now = energy.back();
    if (moved == 0 || previous - now <= options.tolerance * std::abs(previous)) {
      converged = true;
      ++sweep;
      break;
    }
  }
  if (stats) {
    stats->sweeps = sweep;
    stats->converged = converged;
    stats->energy = std::move(energy);
    stats->moves = moves;
  }
  *label_out = std::move(label);
  return Status::Ok();
}

}  // namespace vpr
