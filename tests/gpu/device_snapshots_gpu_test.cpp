// A GPU job's snapshots handed from GL to CUDA (render/device_snapshots.h)
// against the host's read-back: the same images bit for bit, the same
// saliency points from stages 2-3 and the same visibility cue, on a scan
// (igea) and a torus soup far from the origin, 6 and 14 views; views of two
// sizes; a budget too small is refused before any image is written. Skipped
// where there is no CUDA device or no EGL.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "render/device_snapshots.h"
#include "render/snapshot.h"
#include "render/views.h"
#include "saliency/gpu_saliency.h"
#include "saliency/visibility.h"
#include "test_meshes.h"

namespace vpr {
namespace {

class DeviceSnapshotsGpu : public CudaTest {
 protected:
  void SetUp() override {
    CudaTest::SetUp();
    if (IsSkipped()) return;
    auto r = create_renderer(RendererKind::kEgl);
    if (!r.ok()) GTEST_SKIP() << "EGL unavailable: " << r.status().to_string();
    renderer_ = std::move(r).value();
  }
  std::unique_ptr<Renderer> renderer_;
};

// A torus as a soup of faces half of them turned over, 2e5 units from the
// origin, with an unused vertex further still.
Mesh far_soup() {
  Mesh m = testing::flipped_soup(testing::torus(3.0, 1.0, 96, 48));
  for (size_t i = 0; i < m.positions.size(); ++i) m.positions[i] += i % 3 == 1 ? 2e5f : 0.0f;
  m.positions.insert(m.positions.end(), {9e5f, 0.0f, 0.0f});
  return m;
}

// count views of resolution^2 pixels (make_views' defaults otherwise).
std::vector<View> views_of(const Mesh& mesh, int resolution, int count = 6) {
  ViewOptions options;
  options.count = count;
  options.resolution = resolution;
  auto views = make_views(mesh, options);
  EXPECT_TRUE(views.ok()) << views.status().to_string();
  return views.ok() ? *views : std::vector<View>{};
}

std::vector<Mesh> meshes() {
  std::vector<Mesh> out = {far_soup()};
  auto igea = read_mesh("../shared/models/igea.ply");
  if (igea.ok()) out.push_back(std::move(igea).value());
  return out;
}

TEST_F(DeviceSnapshotsGpu, TheSameImagesPointsAndVisibilityAsTheReadBack) {
  const std::vector<Mesh> all = meshes();
  ASSERT_EQ(all.size(), 2u) << "igea did not load";
  for (int count : {6, 14}) {
    size_t points = 0;  // over both meshes (a smooth torus may have no feature pixel)
    for (const Mesh& mesh : all) {
      SCOPED_TRACE(std::to_string(count) + " views, " + std::to_string(mesh.vertex_count()) + " vertices");
      const std::vector<View> views = views_of(mesh, 384, count);
      ASSERT_FALSE(views.empty());
      std::vector<Snapshot> read_back, left;
      ASSERT_TRUE(renderer_->render(mesh, views, &read_back).ok());
      cuda::DeviceSnapshots on_device(views, gpu_);
      const Status s = renderer_->render(mesh, views, &left, {}, &on_device);
      ASSERT_TRUE(s.ok()) << s.to_string();
      EXPECT_TRUE(left.empty());
      ASSERT_EQ(on_device.size(), views.size());
      ASSERT_NE(on_device.depths(), nullptr);

      std::vector<Snapshot> copied;
      ASSERT_TRUE(on_device.download(&copied).ok());
      ASSERT_EQ(copied.size(), read_back.size());
      for (size_t v = 0; v < copied.size(); ++v) {
        EXPECT_EQ(copied[v].gray.pixels, read_back[v].gray.pixels) << views[v].name;
        EXPECT_EQ(copied[v].depth.pixels, read_back[v].depth.pixels) << views[v].name;
        EXPECT_EQ(copied[v].coverage.pixels, read_back[v].coverage.pixels) << views[v].name;
      }
      for (size_t v = 0; v < views.size(); ++v) {
        std::vector<float> from_host, from_device;
        ASSERT_TRUE(cuda::view_saliency_points(read_back[v], views[v], {}, &from_host, nullptr, gpu_).ok());
        ASSERT_TRUE(cuda::view_saliency_points(on_device.snapshot(v), views[v], {}, &from_device, nullptr, gpu_).ok());
        EXPECT_EQ(from_device, from_host) << views[v].name;
        points += from_host.size();
      }
      std::vector<float> seen_host, seen_device;
      ASSERT_TRUE(
          cuda::view_visibility(mesh.positions.data(), mesh.vertex_count(), views, read_back, {}, &seen_host, gpu_)
              .ok());
      ASSERT_TRUE(cuda::view_visibility_on_device(mesh.positions.data(), mesh.vertex_count(), views, on_device.depths(),
                                                  {}, &seen_device, gpu_)
                      .ok());
      EXPECT_EQ(seen_device, seen_host);
    }
    EXPECT_GT(points, 0u) << count << " views";
  }
}

// The driver says which CUDA device its EGL device is (EGL_NV_device_cuda),
// which is how a job's renderer finds its own GPU (create_renderer).
TEST_F(DeviceSnapshotsGpu, TheRendererNamesTheCudaDeviceItDrawsOn) {
  auto on_zero = create_renderer(RendererKind::kEgl, 0);
  ASSERT_TRUE(on_zero.ok()) << on_zero.status().to_string();
  const std::string d = (*on_zero)->description();
  EXPECT_EQ(d.substr(d.size() - std::string(", CUDA device 0").size()), ", CUDA device 0") << d;
  EXPECT_NE(renderer_->description().find(", CUDA device "), std::string::npos) << renderer_->description();
}

TEST_F(DeviceSnapshotsGpu, ATinyBudgetIsRefusedAndTheRendererStaysUsable) {
  const Mesh sphere = testing::icosphere(3);
  const std::vector<View> views = views_of(sphere, 256);
  ASSERT_FALSE(views.empty());
  DeviceBudget tiny;
  tiny.limit = 4096;
  const ExecContext small{Device::kCuda, gpu_.stream, &tiny};
  cuda::DeviceSnapshots refused(views, small);
  std::vector<Snapshot> out;
  EXPECT_EQ(renderer_->render(sphere, views, &out, {}, &refused).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(refused.size(), 0u);
  EXPECT_EQ(refused.depths(), nullptr);
  EXPECT_EQ(refused.snapshot(0).gray, nullptr);
  EXPECT_EQ(tiny.used.load(), 0u);
  cuda::DeviceSnapshots fine(views, gpu_);
  ASSERT_TRUE(renderer_->render(sphere, views, &out, {}, &fine).ok());
  EXPECT_EQ(fine.size(), views.size());
  // Views of two sizes: each view's images, but no depths back to back.
  std::vector<View> mixed = views;
  mixed.push_back(views_of(sphere, 192)[0]);
  cuda::DeviceSnapshots two_sizes(mixed, gpu_);
  ASSERT_TRUE(renderer_->render(sphere, mixed, &out, {}, &two_sizes).ok());
  EXPECT_EQ(two_sizes.size(), mixed.size());
  EXPECT_EQ(two_sizes.depths(), nullptr);
  EXPECT_EQ(two_sizes.snapshot(mixed.size() - 1).width, 192);
  std::vector<Snapshot> copied, read_back;
  ASSERT_TRUE(two_sizes.download(&copied).ok());
  ASSERT_TRUE(renderer_->render(sphere, mixed, &read_back).ok());
  ASSERT_EQ(copied.size(), read_back.size());
  for (size_t v = 0; v < mixed.size(); ++v) EXPECT_EQ(copied[v].depth.pixels, read_back[v].depth.pixels) << v;
}

// On a host with several GPUs a job on the second renders there and hands its
// snapshots over; a renderer on the first GPU cannot, and says which devices
// are whose (the pipeline then reads back). Skipped with one GPU.
TEST_F(DeviceSnapshotsGpu, AJobOnTheSecondGpuRendersAndHandsOverThere) {
  std::string why;
  if (cuda_devices(&why).size() < 2) GTEST_SKIP() << "one GPU here";
  ASSERT_TRUE(init_cuda_device(1).ok());
  {
    auto stream = CudaStream::create(1);
    ASSERT_TRUE(stream.ok()) << stream.status().to_string();
    const ExecContext second{Device::kCuda, stream->get(), nullptr};
    const Mesh sphere = testing::icosphere(3);
    const std::vector<View> views = views_of(sphere, 128);
    ASSERT_FALSE(views.empty());
    auto on_second = create_renderer(RendererKind::kEgl, 1);
    ASSERT_TRUE(on_second.ok()) << on_second.status().to_string();
    cuda::DeviceSnapshots handed(views, second);
    std::vector<Snapshot> out, read_back;
    const Status s = (*on_second)->render(sphere, views, &out, {}, &handed);
    EXPECT_TRUE(s.ok()) << s.to_string();
    EXPECT_EQ(handed.size(), views.size());
    auto on_first = create_renderer(RendererKind::kEgl, 0);
    ASSERT_TRUE(on_first.ok()) << on_first.status().to_string();
    cuda::DeviceSnapshots refused(views, second);
    const Status wrong = (*on_first)->render(sphere, views, &out, {}, &refused);
    EXPECT_EQ(wrong.code(), StatusCode::kUnavailable) << wrong.to_string();
    EXPECT_NE(wrong.message().find("renders on CUDA device 0, the job runs on device 1"), std::string::npos)
        << wrong.to_string();
    ASSERT_TRUE((*on_first)->render(sphere, views, &read_back).ok());
    std::vector<Snapshot> copied;
    ASSERT_TRUE(handed.download(&copied).ok());
    ASSERT_EQ(copied.size(), read_back.size());
    for (size_t v = 0; v < copied.size(); ++v) EXPECT_EQ(copied[v].depth.pixels, read_back[v].depth.pixels) << v;
  }  // the second GPU's buffers and stream go while it is current
  ASSERT_TRUE(init_cuda_device(0).ok());
}

}  // namespace
}  // namespace vpr
