// Connected parts and --drop-parts-smaller-than (issue 19, part 3).
#include "core/mesh_parts.h"

#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <random>

#include "test_meshes.h"

namespace vpr {
namespace {

// Three spheres of radii 1, 0.3 and 0.01 side by side.
Mesh three_spheres() {
  Mesh kit;
  const float radius[3] = {1.0f, 0.3f, 0.01f};
  for (int i = 0; i < 3; ++i) {
    const Mesh s = testing::icosphere(1, radius[i]);
    const uint32_t base = uint32_t(kit.vertex_count());
    for (size_t v = 0; v < s.vertex_count(); ++v)
      for (int a = 0; a < 3; ++a) kit.positions.push_back(s.positions[3 * v + a] + (a == 0 ? 3.0f * i : 0.0f));
    for (uint32_t idx : s.indices) kit.indices.push_back(base + idx);
  }
  return kit;
}

TEST(MeshParts, FacesJoinedBySharedVerticesFormOnePart) {
  const Mesh kit = three_spheres();
  size_t parts = 0;
  const std::vector<uint32_t> part = face_parts(kit, &parts);
  ASSERT_EQ(parts, 3u);
  const size_t per = kit.face_count() / 3;
  for (size_t f = 0; f < kit.face_count(); ++f) EXPECT_EQ(part[f], f / per) << "face " << f;
}

// The serial walk face_parts replaced: a union-find in face order, then the
// parts numbered by their first face.
std::vector<uint32_t> serial_face_parts(const Mesh& mesh, size_t* parts) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<uint32_t> up(nv);
  std::iota(up.begin(), up.end(), 0u);
  auto find = [&](uint32_t v) {
    while (up[v] != v) v = up[v] = up[up[v]];
    return v;
  };
  auto valid = [&](size_t f) {
    return mesh.indices[3 * f] < nv && mesh.indices[3 * f + 1] < nv && mesh.indices[3 * f + 2] < nv;
  };
  for (size_t f = 0; f < nf; ++f)
    if (valid(f))
      for (int k = 1; k < 3; ++k) {
        const uint32_t a = find(mesh.indices[3 * f]), b = find(mesh.indices[3 * f + k]);
        if (a != b) up[std::max(a, b)] = std::min(a, b);
      }
  std::vector<uint32_t> id(nv, UINT32_MAX), part(nf, UINT32_MAX);
  uint32_t count = 0;
  for (size_t f = 0; f < nf; ++f) {
    if (!valid(f)) continue;
    const uint32_t r = find(mesh.indices[3 * f]);
    if (id[r] == UINT32_MAX) id[r] = count++;
    part[f] = id[r];
  }
  *parts = count;
  return part;
}

// Thousands of strips whose faces are shuffled among each other and whose
// vertices are numbered at random (so a part's lowest vertex and its first
// face disagree on the order), some joined later through one shared vertex,
// and faces with an index out of range: the serial walk's numbering on any
// thread count.
TEST(MeshParts, InParallelTheSerialWalksNumbering) {
  std::mt19937 rng(7);
  const uint32_t strips = 3000, per = 12;  // a strip of 12 faces over 14 vertices
  Mesh m;
  m.positions.assign(3 * size_t(strips) * (per + 2), 0.0f);
  std::vector<uint32_t> name(strips * (per + 2));
  std::iota(name.begin(), name.end(), 0u);
  std::shuffle(name.begin(), name.end(), rng);
  std::vector<std::array<uint32_t, 3>> faces;
  for (uint32_t s = 0; s < strips; ++s)
    for (uint32_t k = 0; k < per; ++k) {
      const uint32_t b = s * (per + 2) + k;
      faces.push_back({name[b], name[b + 1], name[b + 2]});
    }
  for (uint32_t s = 0; s + 7 < strips; s += 7)  // every seventh strip touches the next one at a vertex
    faces.push_back({name[s * (per + 2)], name[(s + 1) * (per + 2) + 3], name[(s + 1) * (per + 2) + 4]});
  for (int i = 0; i < 50; ++i) faces.push_back({name[size_t(i) * 5], uint32_t(name.size()) + 9, name[3]});
  std::shuffle(faces.begin(), faces.end(), rng);
  for (const auto& f : faces) m.indices.insert(m.indices.end(), f.begin(), f.end());

  size_t expected_parts = 0;
  const std::vector<uint32_t> expected = serial_face_parts(m, &expected_parts);
  EXPECT_LT(expected_parts, strips);
  EXPECT_GT(expected_parts, strips / 2);
  EXPECT_EQ(std::count(expected.begin(), expected.end(), UINT32_MAX), 50);
  for (int threads : {1, 2, 4, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    size_t parts = 0;
    EXPECT_EQ(face_parts(m, &parts), expected) << threads << " threads";
    EXPECT_EQ(parts, expected_parts);
  }
}

TEST(MeshParts, DropsOnlyPartsBelowTheAskedShareOfTheDiagonal) {
  const Mesh kit = three_spheres();
  const size_t per = kit.face_count() / 3;
  // The whole kit's diagonal is about 8.2; the smallest sphere's 0.035 (0.4%), the middle one's 1.0 (12%).
  Mesh m = kit;
  EXPECT_EQ(drop_small_parts(&m, 0.0), 0u);
  EXPECT_EQ(m.face_count(), kit.face_count());
  EXPECT_EQ(drop_small_parts(&m, 0.01), 1u);
  EXPECT_EQ(m.face_count(), 2 * per);
  m = kit;
  EXPECT_EQ(drop_small_parts(&m, 0.5), 2u);
  EXPECT_EQ(m.face_count(), per);
  // The largest part stays whatever is asked.
  m = kit;
  EXPECT_EQ(drop_small_parts(&m, 2.0), 2u);
  EXPECT_EQ(m.face_count(), per);
}

}  // namespace
}  // namespace vpr
