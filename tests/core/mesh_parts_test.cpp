// Connected parts and --drop-parts-smaller-than (issue 19, part 3).
#include "core/mesh_parts.h"

#include <gtest/gtest.h>

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
