#include "core/mesh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "core/vec3.h"

namespace vpr {
namespace {

// The lowest i in [0, n) where bad(i), or n: blocks in parallel, each
// stopping at its first hit, a block skipped once a lower block has one.
template <class Bad>
size_t first_where(size_t n, Bad bad) {
  std::atomic<size_t> first{n};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 32768), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end() && i < first.load(std::memory_order_relaxed); ++i)
      if (bad(i)) {
        size_t seen = first.load(std::memory_order_relaxed);
        while (i < seen && !first.compare_exchange_weak(seen, i, std::memory_order_relaxed)) {
        }
        return;
      }
  });
  return first.load();
}

double face_area(const Mesh& mesh, size_t f) {
  const Vec3d a = load3d(mesh.positions.data(), mesh.indices[3 * f]);
  const Vec3d b = load3d(mesh.positions.data(), mesh.indices[3 * f + 1]);
  const Vec3d c = load3d(mesh.positions.data(), mesh.indices[3 * f + 2]);
  return 0.5 * norm(cross(b - a, c - a));
}

}  // namespace

float Aabb::diagonal() const {
  float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

Status validate_mesh(const Mesh& mesh, const MeshLimits& limits) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (mesh.positions.size() % 3 != 0 || mesh.indices.size() % 3 != 0)
    return invalid_argument("mesh arrays are not multiples of 3");
  if (nv == 0) return invalid_argument("empty mesh: no vertices");
  if (nf == 0)
    return invalid_argument("no faces: the input is a point cloud with " + std::to_string(nv) +
                            " points, a triangle mesh or polygon soup is required");
  if (nv > limits.max_vertices)
    return resource_exhausted("mesh has " + std::to_string(nv) + " vertices, the limit is " +
                              std::to_string(limits.max_vertices));
  if (nf > limits.max_faces)
    return resource_exhausted("mesh has " + std::to_string(nf) + " faces, the limit is " +
                              std::to_string(limits.max_faces));
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(mesh.origin[size_t(a)])) return invalid_argument("the mesh's origin is not finite");
  }
  if (!(mesh.scale > 0) || !std::isfinite(mesh.scale)) return invalid_argument("the mesh's scale is not positive");
  // Each test in parallel; the error names the first offender.
  const size_t bad_coordinate =
      first_where(mesh.positions.size(), [&](size_t i) { return !std::isfinite(mesh.positions[i]); });
  if (bad_coordinate < mesh.positions.size())
    return invalid_argument("vertex " + std::to_string(bad_coordinate / 3) +
                            " has a non-finite coordinate (NaN or infinity)");
  const size_t bad_index = first_where(mesh.indices.size(), [&](size_t i) { return mesh.indices[i] >= nv; });
  if (bad_index < mesh.indices.size())
    return invalid_argument("face " + std::to_string(bad_index / 3) + " references vertex " +
                            std::to_string(mesh.indices[bad_index]) + " but the mesh has " + std::to_string(nv) +
                            " vertices");
  // The areas are finite and never negative here: their sum is positive
  // exactly when one of them is.
  if (first_where(nf, [&](size_t f) { return face_area(mesh, f) > 0.0; }) == nf)
    return invalid_argument("degenerate mesh: every face has zero area");
  return validate_appearance(mesh);
}

Status validate_appearance(const Mesh& mesh) {
  const size_t nv = mesh.vertex_count();
  if (!mesh.colors.empty() && mesh.colors.size() != 3 * nv)
    return invalid_argument("the mesh has " + std::to_string(mesh.colors.size()) + " color bytes for " +
                            std::to_string(nv) + " vertices (3 per vertex are needed)");
  const MeshTextures& t = mesh.textures;
  if (t.empty()) {
    if (!t.uvs.empty() || !t.vertex_texture.empty())
      return invalid_argument("the mesh has texture coordinates but no textures");
    return Status::Ok();
  }
  if (t.uvs.size() != 2 * nv || t.vertex_texture.size() != nv)
    return invalid_argument("the mesh has " + std::to_string(t.uvs.size() / 2) + " texture coordinates and " +
                            std::to_string(t.vertex_texture.size()) + " texture indices for " + std::to_string(nv) +
                            " vertices");
  for (size_t v = 0; v < nv; ++v) {
    if (t.vertex_texture[v] != MeshTextures::kNone && t.vertex_texture[v] >= t.textures.size())
      return invalid_argument("vertex " + std::to_string(v) + " uses texture " + std::to_string(t.vertex_texture[v]) +
                              " but the mesh has " + std::to_string(t.textures.size()));
  }
  for (size_t i = 0; i < t.textures.size(); ++i) {
    const RgbImage* image = t.textures[i].image.get();
    if (!image || image->width <= 0 || image->height <= 0 ||
        image->pixels.size() != size_t(image->width) * size_t(image->height))
      return invalid_argument("texture " + std::to_string(i) + " has no image or an image of the wrong size");
  }
  return Status::Ok();
}

Aabb bounding_box(const float* p, size_t n) {
  Aabb box;
  if (n == 0) return box;
  box.lo = {p[0], p[1], p[2]};
  box.hi = box.lo;
  for (size_t i = 1; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], p[3 * i + a]);
      box.hi[a] = std::max(box.hi[a], p[3 * i + a]);
    }
  }
  return box;
}

Mesh mesh_from_absolute(const std::vector<double>& positions, std::vector<uint32_t> indices) {
  Mesh mesh;
  mesh.indices = std::move(indices);
  const size_t nv = positions.size() / 3;
  // Only coordinates a float can hold count; the others are reported.
  auto usable = [](double x) { return std::abs(x) <= double(FLT_MAX); };
  // The box of the vertices faces use (of all of them when no face is whole):
  // a min and max, the same whatever order the threads take them in.
  const size_t ni = mesh.indices.size();
  const bool any_face = first_where(ni, [&](size_t k) { return mesh.indices[k] < nv; }) < ni;
  const size_t count = any_face ? ni : nv;
  auto vertex = [&](size_t k) { return any_face ? size_t(mesh.indices[k]) : k; };
  struct Box {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  };
  const Box box = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, count, 32768), Box{},
      [&](const tbb::blocked_range<size_t>& r, Box b) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
          const size_t v = vertex(k);
          if (v >= nv) continue;
          for (int a = 0; a < 3; ++a) {
            const double x = positions[3 * v + size_t(a)];
            if (!usable(x)) continue;
            b.lo[a] = std::min(b.lo[a], x);
            b.hi[a] = std::max(b.hi[a], x);
          }
        }
        return b;
      },
      [](Box x, const Box& y) {
        for (int a = 0; a < 3; ++a) {
          x.lo[a] = std::min(x.lo[a], y.lo[a]);
          x.hi[a] = std::max(x.hi[a], y.hi[a]);
        }
        return x;
      });
  // -0.0 and +0.0 compare equal, so which one a bound holds would depend on
  // the schedule: a bound of zero is +0.0.
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = box.lo[a] == 0 ? 0.0 : box.lo[a];
    hi[a] = box.hi[a] == 0 ? 0.0 : box.hi[a];
  }
  double diag2 = 0;
  for (int a = 0; a < 3; ++a) {
    if (!(lo[a] <= hi[a])) continue;
    // Halves first: lo + hi may overflow where each alone does not.
    mesh.origin[size_t(a)] = 0.5 * lo[a] + 0.5 * hi[a];
    diag2 += (0.5 * hi[a] - 0.5 * lo[a]) * (0.5 * hi[a] - 0.5 * lo[a]);
  }
  const double diagonal = 2 * std::sqrt(diag2);
  if (diagonal > 0 && std::isfinite(diagonal)) mesh.scale = diagonal;
  mesh.positions.resize(3 * nv);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, 3 * nv, 32768), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const double x = positions[i];
      mesh.positions[i] = usable(x) ? float((x - mesh.origin[i % 3]) / mesh.scale) : x > 0 ? HUGE_VALF
                                                                                    : x < 0 ? -HUGE_VALF
                                                                                            : NAN;
    }
  });
  return mesh;
}

Mesh rebased(const Mesh& mesh, const std::array<double, 3>& origin, double scale) {
  Mesh out;
  out.indices = mesh.indices;
  out.colors = mesh.colors;
  out.textures = mesh.textures;
  out.origin = origin;
  out.scale = scale;
  out.positions.resize(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    out.positions[i] = float((mesh.origin[i % 3] - origin[i % 3] + mesh.scale * double(mesh.positions[i])) / scale);
  return out;
}

double writable_absolute(const Mesh& mesh, size_t v, int a) {
  const double d = mesh.absolute(v, a);
  if (std::abs(d) <= double(FLT_MAX)) return d;
  const double rounding = mesh.scale * 0x1p-23;  // a float's spacing in the frame, over [-1, 1]
  if (std::abs(d) <= double(FLT_MAX) + rounding) return std::copysign(double(FLT_MAX), d);
  return d > 0 ? HUGE_VAL : d < 0 ? -HUGE_VAL : d;  // NaN stays NaN
}

std::vector<float> absolute_positions(const Mesh& mesh) {
  std::vector<float> out(mesh.positions.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = float(writable_absolute(mesh, i / 3, int(i % 3)));
  return out;
}

bool absolute_fits_float(const Mesh& mesh) {
  // A float's spacing near x is at most x * 2^-23: within 8 diagonals of zero
  // that is below 1e-6 of the diagonal. Only the vertices faces use count (a
  // stray vertex far away does not make floats precise enough for the rest).
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (uint32_t i : mesh.indices)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], mesh.absolute(i, a));
      hi[a] = std::max(hi[a], mesh.absolute(i, a));
    }
  double diag2 = 0, far = 0;
  for (int a = 0; a < 3; ++a) {
    if (!(lo[a] <= hi[a])) return true;
    diag2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    far = std::max({far, std::abs(lo[a]), std::abs(hi[a])});
  }
  // Floats also need the model inside their normal range (a model 1e-40
  // across would underflow to zeros).
  const double diagonal = std::sqrt(diag2);
  return far <= 8.0 * diagonal && diagonal >= 1e-30 && far <= 1e37;
}

size_t unreferenced_vertex_count(const Mesh& mesh) {
  std::vector<bool> referenced(mesh.vertex_count(), false);
  for (uint32_t i : mesh.indices) referenced[i] = true;
  return size_t(std::count(referenced.begin(), referenced.end(), false));
}

size_t remove_unreferenced_vertices(Mesh* mesh, std::vector<uint32_t>* used) {
  constexpr uint32_t kUnused = UINT32_MAX;
  const size_t nv = mesh->vertex_count();
  std::vector<uint32_t> remap(nv, kUnused);
  for (uint32_t i : mesh->indices) remap[i] = 0;
  uint32_t kept = 0;
  for (size_t v = 0; v < nv; ++v)
    if (remap[v] != kUnused) remap[v] = kept++;
  if (used) used->clear();
  if (kept == nv) return 0;
  if (used) used->resize(kept);
  const bool colors = !mesh->colors.empty();
  MeshTextures& t = mesh->textures;
  const bool textures = !t.empty();
  for (size_t v = 0; v < nv; ++v) {
    if (remap[v] == kUnused) continue;
    const size_t to = remap[v];
    for (size_t a = 0; a < 3; ++a) mesh->positions[3 * to + a] = mesh->positions[3 * v + a];
    if (colors)
      for (size_t c = 0; c < 3; ++c) mesh->colors[3 * to + c] = mesh->colors[3 * v + c];
    if (textures) {
      t.uvs[2 * to] = t.uvs[2 * v];
      t.uvs[2 * to + 1] = t.uvs[2 * v + 1];
      t.vertex_texture[to] = t.vertex_texture[v];
    }
    if (used) (*used)[to] = uint32_t(v);
  }
  mesh->positions.resize(3 * size_t(kept));
  if (colors) mesh->colors.resize(3 * size_t(kept));
  if (textures) {
    t.uvs.resize(2 * size_t(kept));
    t.vertex_texture.resize(kept);
  }
  for (uint32_t& i : mesh->indices) i = remap[i];
  return nv - kept;
}

std::vector<double> face_areas(const Mesh& mesh) {
  const size_t nf = mesh.face_count();
  std::vector<double> areas(nf);
  for (size_t f = 0; f < nf; ++f) areas[f] = face_area(mesh, f);
  return areas;
}

double total_area(const Mesh& mesh) {
  double sum = 0.0;
  for (double a : face_areas(mesh)) sum += a;
  return sum;
}

double mean_edge_length(const Mesh& mesh) {
  const size_t nf = mesh.face_count();
  if (nf == 0) return 0.0;
  double sum = 0.0;
  for (size_t f = 0; f < nf; ++f) {
    for (int e = 0; e < 3; ++e) {
      const Vec3d a = load3d(mesh.positions.data(), mesh.indices[3 * f + e]);
      const Vec3d b = load3d(mesh.positions.data(), mesh.indices[3 * f + (e + 1) % 3]);
      sum += norm(b - a);
    }
  }
  return sum / (3.0 * nf);
}

Mesh weld_exact(const Mesh& mesh) {
  struct Key {
    uint32_t x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return (size_t(k.x) * 73856093u) ^ (size_t(k.y) * 19349663u) ^ (size_t(k.z) * 83492791u);
    }
  };
  std::unordered_map<Key, uint32_t, KeyHash> ids;
  ids.reserve(mesh.vertex_count());
  std::vector<uint32_t> id(mesh.vertex_count());
  Mesh out;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    // -0 and +0 are one position (an exporter writes both): + 0.0f makes -0 +0.
    const float canonical[3] = {mesh.positions[3 * v] + 0.0f, mesh.positions[3 * v + 1] + 0.0f,
                                mesh.positions[3 * v + 2] + 0.0f};
    Key k;
    std::memcpy(&k, canonical, sizeof k);
    auto [it, added] = ids.emplace(k, uint32_t(ids.size()));
    if (added) out.positions.insert(out.positions.end(), &mesh.positions[3 * v], &mesh.positions[3 * v] + 3);
    id[v] = it->second;
  }
  out.indices.reserve(mesh.indices.size());
  for (uint32_t i : mesh.indices) out.indices.push_back(i < id.size() ? id[i] : UINT32_MAX);  // out of range stays so
  out.origin = mesh.origin;
  out.scale = mesh.scale;
  return out;
}

}  // namespace vpr
