// The render's drawn geometry on the GPU against the host's (drawn_geometry.h):
// the same positions, normals and shared corners bit for bit, on a scan, on a
// soup far from the origin with degenerate faces and unused vertices, and on
// boxes (creases); a budget too small is refused, and the renderer then draws
// the host's. Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "render/drawn_geometry.h"
#include "render/snapshot.h"
#include "render/views.h"
#include "test_meshes.h"

namespace vpr {
namespace {

class DrawnGeometryGpu : public CudaTest {};

Mesh load_model(const std::string& name) {
  auto mesh = read_mesh("../shared/models/" + name);
  return mesh.ok() ? std::move(mesh).value() : Mesh{};
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void expect_same(const Mesh& mesh, bool indexed, const ExecContext& gpu, const std::string& what) {
  SCOPED_TRACE(what + (indexed ? ", shared corners" : ", every corner"));
  const DrawnGeometry host = drawn_geometry(mesh, indexed);
  DrawnGeometry device;
  const Status s = cuda::drawn_geometry(mesh, indexed, &device, gpu);
  ASSERT_TRUE(s.ok()) << s.to_string();
  EXPECT_EQ(device.corners, host.corners);
  EXPECT_EQ(device.indexed, indexed);
  EXPECT_EQ(device.centre.x, host.centre.x);
  EXPECT_EQ(device.centre.z, host.centre.z);
  EXPECT_TRUE(same_bits(device.positions, host.positions)) << device.positions.size() << " vs " << host.positions.size();
  EXPECT_TRUE(same_bits(device.normals, host.normals)) << device.normals.size() << " vs " << host.normals.size();
  EXPECT_EQ(device.indices, host.indices);
}

// Two boxes sharing a face, with an unused vertex between them: creases keep
// corners apart at one position, and the shared face's corners weld.
Mesh two_boxes() {
  Mesh m;
  auto box = [&m](float x0, float x1) {
    const uint32_t b = uint32_t(m.vertex_count());
    for (int i = 0; i < 8; ++i) m.positions.insert(m.positions.end(), {i & 1 ? x1 : x0, float(i >> 1 & 1), float(i >> 2 & 1)});
    const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : q) m.indices.insert(m.indices.end(), {b + f[0], b + f[1], b + f[2], b + f[0], b + f[2], b + f[3]});
    m.positions.insert(m.positions.end(), {0.5f * (x0 + x1), 0.5f, 0.5f});  // unused
  };
  box(0, 1);
  box(1, 2.5f);
  return m;
}

TEST_F(DrawnGeometryGpu, MatchesTheHostBitForBit) {
  const Mesh bunny = load_model("bunny.obj");
  ASSERT_GT(bunny.face_count(), 0u);
  // The soup: every face its own corners, every other one flipped, 10^5 from
  // the origin, with a repeated-index face, a zero-area face and a NaN vertex.
  Mesh soup = testing::flipped_soup(testing::icosphere(4));
  for (size_t i = 0; i < soup.positions.size(); ++i) soup.positions[i] += i % 3 == 1 ? 1e5f : 0.f;
  soup.indices.insert(soup.indices.end(), {0, 0, 1, 3, 4, 3});
  const uint32_t nan_vertex = uint32_t(soup.vertex_count());
  soup.positions.insert(soup.positions.end(), {NAN, 0.f, 0.f});
  soup.indices.insert(soup.indices.end(), {5, 6, nan_vertex});
  for (bool indexed : {true, false}) {
    expect_same(bunny, indexed, gpu_, "bunny");
    expect_same(soup, indexed, gpu_, "soup far from the origin");
    expect_same(two_boxes(), indexed, gpu_, "two boxes");
    expect_same(Mesh{}, indexed, gpu_, "empty");
  }
  const Mesh igea = load_model("igea.ply");
  if (igea.face_count() > 0) expect_same(igea, true, gpu_, "igea");
}

TEST_F(DrawnGeometryGpu, RefusesATinyBudgetAndTheRendererDrawsTheHostsGeometry) {
  const Mesh sphere = testing::icosphere(4);
  DeviceBudget tiny;
  tiny.limit = 4096;
  const ExecContext small{Device::kCuda, gpu_.stream, &tiny};
  DrawnGeometry out;
  EXPECT_EQ(cuda::drawn_geometry(sphere, true, &out, small).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(tiny.used.load(), 0u);

  auto renderer = create_renderer(RendererKind::kEgl);
  if (!renderer.ok()) GTEST_SKIP() << "EGL unavailable: " << renderer.status().to_string();
  Renderer& r = **renderer;
  ViewOptions view_options;
  view_options.resolution = 256;
  auto views = make_views(sphere, view_options);
  ASSERT_TRUE(views.ok()) << views.status().to_string();
  const ExecContext gpu = gpu_;
  auto twin_in = [](const ExecContext& ctx) {
    return DrawnGeometryTwin([ctx](const Mesh& m, bool indexed, DrawnGeometry* g) {
      return cuda::drawn_geometry(m, indexed, g, ctx);
    });
  };
  std::vector<Snapshot> host, device, refused;
  ASSERT_TRUE(r.render(sphere, *views, &host).ok());
  ASSERT_TRUE(r.render(sphere, *views, &device, twin_in(gpu)).ok());
  EXPECT_NE(r.last_breakdown().find("(on the GPU)"), std::string::npos) << r.last_breakdown();
  ASSERT_TRUE(r.render(sphere, *views, &refused, twin_in(small)).ok());
  EXPECT_NE(r.last_breakdown().find("prepared on the host"), std::string::npos) << r.last_breakdown();
  ASSERT_EQ(device.size(), host.size());
  for (size_t v = 0; v < host.size(); ++v) {
    EXPECT_GT(std::count(host[v].coverage.pixels.begin(), host[v].coverage.pixels.end(), 1), 1000);
    EXPECT_EQ(device[v].gray.pixels, host[v].gray.pixels) << v;
    EXPECT_EQ(device[v].depth.pixels, host[v].depth.pixels) << v;
    EXPECT_EQ(refused[v].gray.pixels, host[v].gray.pixels) << v;
  }
}

}  // namespace
}  // namespace vpr
