// Synthetic shapes for tests (the shared models are real scans; these are
// shapes whose answers we know).
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <map>
#include <tuple>
#include <utility>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace vpr::testing {

// Every interior angle of every face, in degrees (three per face, in corner order).
inline std::vector<double> triangle_angles_deg(const Mesh& m) {
  std::vector<double> angles;
  angles.reserve(3 * m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Vec3d o = load3d(m.positions.data(), m.indices[3 * f + c]);
      const Vec3d u = load3d(m.positions.data(), m.indices[3 * f + (c + 1) % 3]) - o;
      const Vec3d w = load3d(m.positions.data(), m.indices[3 * f + (c + 2) % 3]) - o;
      angles.push_back(std::atan2(norm(cross(u, w)), dot(u, w)) * 180 / 3.14159265358979323846);
    }
  return angles;
}

// Icosphere of the given radius: 12 vertices subdivided `levels` times.
inline Mesh icosphere(int levels, float radius = 1.0f) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  Mesh m;
  m.positions = {-1, t,  0,  1, t, 0,  -1, -t, 0,  1, -t, 0, 0,  -1, t,  0,  1, t,
                 0,  -1, -t, 0, 1, -t, t,  0,  -1, t, 0,  1, -t, 0,  -1, -t, 0, 1};
  m.indices = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4,  11, 10, 2,  10, 7, 6, 7, 1, 8,
               3, 9,  4, 3, 4, 2, 3, 2, 6, 3, 6, 8,  3, 8,  9,  4, 9, 5, 2, 4,  11, 6,  2,  10, 8,  6, 7, 9, 8, 1};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      const uint32_t id = uint32_t(m.vertex_count());
      for (int k = 0; k < 3; ++k) m.positions.push_back(0.5f * (m.positions[3 * a + k] + m.positions[3 * b + k]));
      mid[key] = id;
      return id;
    };
    std::vector<uint32_t> next;
    for (size_t f = 0; f < m.face_count(); ++f) {
      const uint32_t a = m.indices[3 * f], b = m.indices[3 * f + 1], c = m.indices[3 * f + 2];
      const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    m.indices = std::move(next);
  }
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const float n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    for (int k = 0; k < 3; ++k) p[k] *= radius / n;
  }
  return m;
}

// The same surface as a polygon soup: every face its own three vertices, and
// every other face wound the other way. No connectivity survives.
inline Mesh flipped_soup(const Mesh& mesh) {
  Mesh soup;
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    uint32_t corner[3] = {mesh.indices[3 * f], mesh.indices[3 * f + 1], mesh.indices[3 * f + 2]};
    if (f % 2) std::swap(corner[1], corner[2]);
    for (uint32_t c : corner) {
      soup.indices.push_back(uint32_t(soup.vertex_count()));
      soup.positions.insert(soup.positions.end(), &mesh.positions[3 * c], &mesh.positions[3 * c + 3]);
    }
  }
  return soup;
}

// A bumpy sphere (features for the saliency stages) on a 2^-20 grid, as OBJ
// text moved by `shift` and scaled by `scale` about zero; `strays` unused
// vertices in a cube beside it, half before and half after the used ones.
inline std::string bumpy_sphere_obj(double scale, double shift, int strays) {
  Mesh sphere = icosphere(4);
  std::string text;
  char line[160];
  auto vertex = [&](const double p[3]) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p[0] * scale + shift, p[1] * scale + shift,
                  p[2] * scale + shift);
    text += line;
  };
  for (int i = 0; i < strays / 2; ++i) {
    const double p[3] = {2.0 + 0.01 * i, 0.5, -0.5};
    vertex(p);
  }
  for (size_t v = 0; v < sphere.vertex_count(); ++v) {
    const float* q = &sphere.positions[3 * v];
    const double bump = 1 + 0.15 * std::sin(3 * std::atan2(q[1], q[0])) * std::cos(2 * std::acos(q[2]));
    double p[3];
    for (int a = 0; a < 3; ++a) p[a] = std::round(q[a] * bump * 1048576.0) / 1048576.0;
    vertex(p);
  }
  for (int i = strays / 2; i < strays; ++i) {
    const double p[3] = {-2.0, 0.01 * i, 1.5};
    vertex(p);
  }
  for (size_t f = 0; f < sphere.face_count(); ++f) {
    std::snprintf(line, sizeof line, "f %u %u %u\n", sphere.indices[3 * f] + 1 + strays / 2,
                  sphere.indices[3 * f + 1] + 1 + strays / 2, sphere.indices[3 * f + 2] + 1 + strays / 2);
    text += line;
  }
  return text;
}

// A torus about the z axis: ring radius R, tube radius r, seg x rings grid.
inline Mesh torus(double R, double r, int seg, int rings) {
  constexpr double kPi = 3.14159265358979323846;
  Mesh m;
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < seg; ++i) {
      const double u = 2 * kPi * j / rings, v = 2 * kPi * i / seg;
      m.positions.insert(m.positions.end(), {float((R + r * std::cos(v)) * std::cos(u)),
                                             float((R + r * std::cos(v)) * std::sin(u)), float(r * std::sin(v))});
    }
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < seg; ++i) {
      const uint32_t a = j * seg + i, b = j * seg + (i + 1) % seg, c = ((j + 1) % rings) * seg + i,
                     d = ((j + 1) % rings) * seg + (i + 1) % seg;
      m.indices.insert(m.indices.end(), {a, c, d, a, d, b});
    }
  return m;
}

}  // namespace vpr::testing
