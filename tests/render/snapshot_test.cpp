// Stage 1 snapshots: what each backend draws, checked against the cameras'
// own matrices and the shading formula; EGL against OSMesa where both exist.
#include "render/snapshot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "render/gl_pixels.h"
#include "render/views.h"
#include "test_meshes.h"

namespace vpr {
namespace {

void append_box(Vec3d lo, Vec3d hi, Mesh* m) {
  const uint32_t base = uint32_t(m->vertex_count());
  for (int i = 0; i < 8; ++i) {
    m->positions.push_back(float(i & 1 ? hi.x : lo.x));
    m->positions.push_back(float(i & 2 ? hi.y : lo.y));
    m->positions.push_back(float(i & 4 ? hi.z : lo.z));
  }
  for (uint32_t i :
       {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5})
    m->indices.push_back(base + i);
}

Mesh box(Vec3d lo, Vec3d hi) {
  Mesh m;
  append_box(lo, hi, &m);
  return m;
}

std::vector<View> views_of(const Mesh& mesh, int resolution, int count = 6) {
  ViewOptions options;
  options.count = count;
  options.resolution = resolution;
  options.pca_align = false;  // the model frame is the camera frame
  auto views = make_views(mesh, options);
  EXPECT_TRUE(views.ok()) << views.status().to_string();
  return views.ok() ? *views : std::vector<View>{};
}

struct Pixel {
  int x, y;  // row 0 at the top
  double depth;
};
Pixel pixel_of(const View& v, Vec3d p) {
  const Vec3d n = transform_point(v.view_proj, p);
  const double wx = (n.x + 1) * 0.5 * v.width, wy = (n.y + 1) * 0.5 * v.height;
  return {int(std::floor(wx)), int(std::floor(v.height - wy)), (n.z + 1) * 0.5};
}

size_t covered(const Snapshot& s) {
  size_t n = 0;
  for (uint8_t c : s.coverage.pixels) n += c;
  return n;
}

// The shading of snapshot.cpp written out independently for one face normal:
// headlight tilted 25 degrees toward the view's upper left.
int expected_gray(Vec3d n, Vec3d toward, Vec3d up, Vec3d right) {
  const double t = 25.0 * M_PI / 180.0;
  Vec3d ul = up - right;
  ul = ul * (1.0 / norm(ul));
  const Vec3d l = std::cos(t) * toward + std::sin(t) * ul;
  n = n * (1.0 / norm(n));
  return int(std::lround(255.0 * (0.15 + 0.85 * std::abs(dot(n, l)))));
}

// Every backend that can start here. OSMesa, when built in, must: it needs
// no device and no display.
std::vector<std::unique_ptr<Renderer>> renderers() {
  std::vector<std::unique_ptr<Renderer>> out;
  std::string reasons;
  for (RendererKind kind : {RendererKind::kOsmesa, RendererKind::kEgl}) {
    auto r = create_renderer(kind);
    if (r.ok()) {
      out.push_back(std::move(r).value());
    } else {
      reasons += r.status().to_string() + "\n";
#ifdef VPR_HAVE_OSMESA
      EXPECT_NE(kind, RendererKind::kOsmesa) << r.status().to_string();
#endif
    }
  }
  if (out.empty()) std::printf("no renderer can start here:\n%s", reasons.c_str());
  return out;
}

// Runs the test body once per backend; skips (saying why) only where none starts.
class Backends : public ::testing::Test {
 protected:
  void SetUp() override {
    backends_ = renderers();
    if (backends_.empty()) GTEST_SKIP() << "no renderer backend can start on this machine";
  }
  std::vector<std::unique_ptr<Renderer>> backends_;
};

TEST_F(Backends, ParseKindsAndDescribeThemselves) {
  EXPECT_EQ(*parse_renderer_kind("auto"), RendererKind::kAuto);
  EXPECT_EQ(*parse_renderer_kind("egl"), RendererKind::kEgl);
  EXPECT_EQ(*parse_renderer_kind("osmesa"), RendererKind::kOsmesa);
  EXPECT_EQ(parse_renderer_kind("vulkan").status().code(), StatusCode::kInvalidArgument);
  for (auto& r : backends_) {
    const std::string d = r->description();
    EXPECT_TRUE(d.rfind("osmesa: ", 0) == 0 || d.rfind("egl: ", 0) == 0) << d;
    std::printf("backend: %s\n", d.c_str());
  }
  // Auto takes EGL when it starts, else OSMesa (the last backend listed).
  auto any = create_renderer(RendererKind::kAuto);
  ASSERT_TRUE(any.ok()) << any.status().to_string();
  EXPECT_EQ((*any)->description(), backends_.back()->description());
  // A CUDA device that no EGL device is (none here, or a ninth GPU) leaves
  // the usual order: the same renderer, the same pictures.
  auto for_gpu = create_renderer(RendererKind::kAuto, 8);
  ASSERT_TRUE(for_gpu.ok()) << for_gpu.status().to_string();
  EXPECT_EQ((*for_gpu)->description(), (*any)->description());
  const Mesh cube = box({-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  std::vector<Snapshot> a, b;
  ASSERT_TRUE((*any)->render(cube, views_of(cube, 64), &a).ok());
  ASSERT_TRUE((*for_gpu)->render(cube, views_of(cube, 64), &b).ok());
  EXPECT_EQ(a[4].depth.pixels, b[4].depth.pixels);
}

TEST_F(Backends, CubeFromPlusZCoversTheProjectedSquareAtTheExpectedDepth) {
  const Mesh cube = box({-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const std::vector<View> views = views_of(cube, 256);
  const View& pz = views[4];
  ASSERT_EQ(pz.name, "+z");
  // The face fills 90% of the image width (5% margin each side).
  const double side = 0.9 * 256;
  const Pixel centre = pixel_of(pz, {0, 0, 0.5});
  const int gray = expected_gray({0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {1, 0, 0});
  ASSERT_EQ(gray, 235);
  for (auto& r : backends_) {
    SCOPED_TRACE(r->description());
    std::vector<Snapshot> shots;
    ASSERT_TRUE(r->render(cube, views, &shots).ok());
    ASSERT_EQ(shots.size(), 6u);
    for (size_t v = 0; v < 6; ++v) {
      const Snapshot& s = shots[v];
      ASSERT_EQ(s.gray.width, 256);
      ASSERT_EQ(s.depth.height, 256);
      EXPECT_NEAR(double(covered(s)), side * side, 0.01 * side * side) << views[v].name;
      // Only the face toward the camera is visible (the others are edge-on),
      // and every one of its pixels has the same flat shade; the background
      // is black with depth 1.
      for (size_t i = 0; i < s.gray.pixels.size(); ++i) {
        if (s.coverage.pixels[i]) {
          ASSERT_EQ(int(s.gray.pixels[i]), gray) << views[v].name << " pixel " << i;
          ASSERT_LT(s.depth.pixels[i], 1.0f);
        } else {
          ASSERT_EQ(s.gray.pixels[i], 0);
          ASSERT_EQ(s.depth.pixels[i], 1.0f);
        }
      }
    }
    EXPECT_NEAR(shots[4].depth.at(centre.x, centre.y), centre.depth, 1e-3);
    std::printf("%s: cube +z coverage %zu px (square %.1f), centre depth %.7f (expected %.7f)\n",
                r->description().c_str(), covered(shots[4]), side * side, shots[4].depth.at(centre.x, centre.y),
                centre.depth);
  }
}

// Covered pixels in row y (or column x when `column`).
int run_length(const Mask& m, int i, bool column) {
  int n = 0;
  for (int j = 0; j < (column ? m.height : m.width); ++j) n += column ? m.at(i, j) : m.at(j, i);
  return n;
}

TEST_F(Backends, RowZeroIsTheTopAndColumnZeroTheLeft) {
  // A cube with a thin post on top (+z) and a thin arm to the right (+x).
  Mesh mesh = box({-1, -1, -1}, {1, 1, 1});
  append_box({-0.2, -0.2, 1}, {0.2, 0.2, 1.6}, &mesh);
  append_box({1, -0.1, -0.1}, {1.5, 0.1, 0.1}, &mesh);
  const std::vector<View> views = views_of(mesh, 200);
  const View& px = views[0];  // up is +z
  const View& pz = views[4];  // up is +y, right is +x
  for (auto& r : backends_) {
    SCOPED_TRACE(r->description());
    std::vector<Snapshot> shots;
    ASSERT_TRUE(r->render(mesh, views, &shots).ok());
    // From +x the post is the top of the picture: the first covered row is
    // the post's width (0.4 of 2.6 model units over 180 px), the last the cube's.
    const Mask& side = shots[0].coverage;
    int top = 0, bottom = side.height - 1;
    while (top < side.height && run_length(side, top, false) == 0) ++top;
    while (bottom > 0 && run_length(side, bottom, false) == 0) --bottom;
    EXPECT_NEAR(run_length(side, top, false), 0.4 / 2.6 * 180, 2);
    EXPECT_NEAR(run_length(side, bottom, false), 2.0 / 2.6 * 180, 2);
    const Pixel post = pixel_of(px, {0.2, 0, 1.3});
    EXPECT_EQ(side.at(post.x, post.y), 1);
    EXPECT_NEAR(shots[0].depth.at(post.x, post.y), post.depth, 1e-4);
    // From +z the arm is on the right: the last covered column is the arm's
    // height (0.2 of 2.5 units), the first the cube's.
    const Mask& top_view = shots[4].coverage;
    int left = 0, right = top_view.width - 1;
    while (left < top_view.width && run_length(top_view, left, true) == 0) ++left;
    while (right > 0 && run_length(top_view, right, true) == 0) --right;
    EXPECT_NEAR(run_length(top_view, right, true), 0.2 / 2.5 * 180, 2);
    EXPECT_NEAR(run_length(top_view, left, true), 2.0 / 2.5 * 180, 2);
    const Pixel arm = pixel_of(pz, {1.25, 0, 0.1});
    EXPECT_EQ(top_view.at(arm.x, arm.y), 1);
    EXPECT_NEAR(shots[4].depth.at(arm.x, arm.y), arm.depth, 1e-4);
  }
}

TEST_F(Backends, ShadesEachFaceByItsAngleToTheTiltedHeadlight) {
  // Three small quads seen from +z with different normals.
  const Vec3d normals[3] = {{0.5, 0, 1}, {0, -0.8, 1}, {-1, 1, 1}};
  Mesh mesh;
  for (int q = 0; q < 3; ++q) {
    const Vec3d n = normals[q];
    const double cx = -2.0 + 2.0 * q;
    // Quad over [cx-0.6, cx+0.6] x [-0.6, 0.6] on the plane n . p = 0 around (cx, 0).
    const uint32_t base = uint32_t(mesh.vertex_count());
    for (Vec3d c : {Vec3d{-0.6, -0.6, 0}, Vec3d{0.6, -0.6, 0}, Vec3d{0.6, 0.6, 0}, Vec3d{-0.6, 0.6, 0}}) {
      const double z = -(n.x * c.x + n.y * c.y) / n.z;
      for (double v : {cx + c.x, c.y, z}) mesh.positions.push_back(float(v));
    }
    for (uint32_t i : {0, 1, 2, 0, 2, 3}) mesh.indices.push_back(base + i);
  }
  const std::vector<View> views = views_of(mesh, 240);
  const View& pz = views[4];
  for (auto& r : backends_) {
    SCOPED_TRACE(r->description());
    std::vector<Snapshot> shots;
    ASSERT_TRUE(r->render(mesh, views, &shots).ok());
    for (int q = 0; q < 3; ++q) {
      const Pixel p = pixel_of(pz, {-2.0 + 2.0 * q, 0, 0});
      EXPECT_EQ(int(shots[4].gray.at(p.x, p.y)), expected_gray(normals[q], {0, 0, 1}, {0, 1, 0}, {1, 0, 0}))
          << "quad " << q;
    }
  }
}

TEST_F(Backends, FlippedSoupLooksLikeTheOrientedMesh) {
  const Mesh sphere = testing::icosphere(3);
  // The same surface as a soup: every face its own vertices, every other face
  // wound the other way, plus a degenerate face that must draw nothing.
  Mesh soup = testing::flipped_soup(sphere);
  soup.indices.insert(soup.indices.end(), {0, 0, 1});
  const std::vector<View> views = views_of(sphere, 256);
  for (auto& r : backends_) {
    SCOPED_TRACE(r->description());
    std::vector<Snapshot> a, b;
    ASSERT_TRUE(r->render(sphere, views, &a).ok());
    ASSERT_TRUE(r->render(soup, views, &b).ok());
    size_t differing = 0, pixels = 0;
    for (size_t v = 0; v < views.size(); ++v) {
      pixels += a[v].gray.pixels.size();
      for (size_t i = 0; i < a[v].gray.pixels.size(); ++i)
        // Gouraud interpolation may round differently with the corners in
        // another order: one gray level is allowed, nothing more.
        differing += std::abs(int(a[v].gray.pixels[i]) - int(b[v].gray.pixels[i])) > 1 ||
                     a[v].coverage.pixels[i] != b[v].coverage.pixels[i];
    }
    EXPECT_EQ(differing, 0u) << "of " << pixels;
  }
}

// Shared corners in an indexed draw (a GPU's path) and every corner drawn
// unindexed (a software rasterizer's) draw the same triangles with the same
// corner values: the same pictures, bit for bit, on a smooth sphere, a box
// (creases: corners at one position with different normals stay apart), two
// boxes sharing a face, and a flipped soup (opposite normals share a vertex).
TEST_F(Backends, SharedAndUnsharedCornersDrawTheSamePictures) {
  Mesh boxes = box({-1, -1, -1}, {0, 1, 1});
  append_box({0, -1, -1}, {1, 0.5, 0.5}, &boxes);
  Mesh soup = testing::flipped_soup(testing::icosphere(3));
  soup.indices.insert(soup.indices.end(), {0, 0, 1});  // degenerate: draws nothing either way
  for (const Mesh& mesh : {testing::icosphere(4), box({-1, -2, -0.5}, {1, 2, 0.5}), boxes, soup}) {
    const std::vector<View> views = views_of(mesh, 200);
    for (auto& r : backends_) {
      SCOPED_TRACE(r->description());
      std::vector<Snapshot> shared, corners;
      r->set_draw_path(Renderer::DrawPath::kSharedCorners);
      ASSERT_TRUE(r->render(mesh, views, &shared).ok());
      r->set_draw_path(Renderer::DrawPath::kCorners);
      ASSERT_TRUE(r->render(mesh, views, &corners).ok());
      r->set_draw_path(Renderer::DrawPath::kAuto);
      for (size_t v = 0; v < views.size(); ++v) {
        EXPECT_GT(covered(shared[v]), 1000u);
        EXPECT_EQ(shared[v].gray.pixels, corners[v].gray.pixels) << views[v].name;
        EXPECT_EQ(shared[v].depth.pixels, corners[v].depth.pixels) << views[v].name;
        EXPECT_EQ(shared[v].coverage.pixels, corners[v].coverage.pixels) << views[v].name;
      }
    }
  }
}

TEST(BackendsCompared, EglAndOsmesaAgree) {
  auto osmesa = create_renderer(RendererKind::kOsmesa);
  if (!osmesa.ok()) GTEST_SKIP() << "OSMesa unavailable: " << osmesa.status().to_string();
  auto egl = create_renderer(RendererKind::kEgl);
  if (!egl.ok()) GTEST_SKIP() << "EGL unavailable: " << egl.status().to_string();
  const Mesh sphere = testing::icosphere(4);
  const std::vector<View> views = views_of(sphere, 320, 14);
  std::vector<Snapshot> a, b;
  ASSERT_TRUE((*osmesa)->render(sphere, views, &a).ok());
  ASSERT_TRUE((*egl)->render(sphere, views, &b).ok());
  for (size_t v = 0; v < views.size(); ++v) {
    const double total = double(a[v].coverage.pixels.size());
    EXPECT_NEAR(double(covered(a[v])), double(covered(b[v])), 0.005 * total) << views[v].name;
    size_t gray_off = 0;
    double depth_off = 0;
    for (size_t i = 0; i < a[v].gray.pixels.size(); ++i) {
      if (!a[v].coverage.pixels[i] || !b[v].coverage.pixels[i]) continue;
      gray_off += std::abs(int(a[v].gray.pixels[i]) - int(b[v].gray.pixels[i])) > 1;
      depth_off = std::max(depth_off, double(std::abs(a[v].depth.pixels[i] - b[v].depth.pixels[i])));
    }
    EXPECT_LT(double(gray_off), 0.005 * total) << views[v].name;
    EXPECT_LT(depth_off, 1e-3) << views[v].name;
  }
  std::printf("%s vs %s: +x coverage %zu vs %zu px\n", (*osmesa)->description().c_str(), (*egl)->description().c_str(),
              covered(a[0]), covered(b[0]));
}

// A sink on the host: copies the pixel buffers back (PixelBuffers::read) and
// builds each view's snapshot by gl_pixels.h's rule, as the GPU's sink does on
// the device. fail: take() refuses.
class HostSink final : public SnapshotSink {
 public:
  explicit HostSink(bool fail = false) : fail_(fail) {}
  Status take(const PixelBuffers& p) override {
    ++calls;
    if (fail_) return unavailable("this sink refuses " + std::to_string(p.width.size()) + " views");
    if (!p.read) return unavailable("the GL library cannot read buffers back");
    for (size_t v = 0; v < p.width.size(); ++v) {
      const int w = p.width[v], h = p.height[v];
      const size_t n = size_t(w) * size_t(h);
      std::vector<uint8_t> rgba(4 * n);
      std::vector<float> depth(n);
      p.read(p.rgba, 4 * p.offset[v], rgba.size(), rgba.data());
      p.read(p.depth, 4 * p.offset[v], depth.size() * sizeof(float), depth.data());
      Snapshot s;
      s.gray = GrayImage(w, h, 7);  // not the rule's values, so each pixel must be written
      s.depth = FloatImage(w, h, 7.0f);
      s.coverage = Mask(w, h, 7);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          gl::snapshot_pixel(rgba.data(), depth.data(), w, h, x, y, s.gray.pixels.data(), s.depth.pixels.data(),
                             s.coverage.pixels.data());
      taken.push_back(std::move(s));
    }
    return Status::Ok();
  }

  std::vector<Snapshot> taken;
  int calls = 0;

 private:
  bool fail_;
};

// The GPU job's path (render/device_snapshots.h) reads every view into pixel
// buffers instead of host memory: the same pictures, on every backend here,
// with views of two sizes in one render.
TEST_F(Backends, PixelBuffersHandOverTheSamePicturesAsTheReadBack) {
  Mesh far = testing::flipped_soup(testing::icosphere(3));
  for (size_t i = 0; i < far.positions.size(); ++i) far.positions[i] += i % 3 == 0 ? 1e5f : 0.0f;
  Mesh boxes = box({-1, -1, -1}, {0, 1, 1});
  append_box({0, -1, -1}, {1, 0.5, 0.5}, &boxes);
  for (const Mesh& mesh : {testing::icosphere(4), boxes, far}) {
    std::vector<View> views = views_of(mesh, 160);
    const std::vector<View> large = views_of(mesh, 224);
    views.insert(views.end(), large.begin(), large.begin() + 2);
    for (auto& r : backends_) {
      SCOPED_TRACE(r->description());
      std::vector<Snapshot> read_back, left = {Snapshot{}};
      ASSERT_TRUE(r->render(mesh, views, &read_back).ok());
      HostSink sink;
      const Status s = r->render(mesh, views, &left, {}, &sink);
      ASSERT_TRUE(s.ok()) << s.to_string();
      EXPECT_TRUE(left.empty());  // the views went to the sink
      EXPECT_EQ(sink.calls, 1);
      ASSERT_EQ(sink.taken.size(), views.size());
      for (size_t v = 0; v < views.size(); ++v) {
        EXPECT_EQ(sink.taken[v].gray.width, views[v].width);
        EXPECT_GT(covered(sink.taken[v]), 1000u) << views[v].name;
        EXPECT_EQ(sink.taken[v].gray.pixels, read_back[v].gray.pixels) << views[v].name;
        EXPECT_EQ(sink.taken[v].depth.pixels, read_back[v].depth.pixels) << views[v].name;
        EXPECT_EQ(sink.taken[v].coverage.pixels, read_back[v].coverage.pixels) << views[v].name;
      }
    }
  }
}

TEST_F(Backends, ASinkThatFailsFailsTheRenderWithItsError) {
  const Mesh sphere = testing::icosphere(2);
  const std::vector<View> views = views_of(sphere, 100);
  for (auto& r : backends_) {
    SCOPED_TRACE(r->description());
    HostSink sink(/*fail=*/true);
    std::vector<Snapshot> out;
    const Status s = r->render(sphere, views, &out, {}, &sink);
    EXPECT_EQ(s.code(), StatusCode::kUnavailable);
    EXPECT_NE(s.message().find("refuses 6 views"), std::string::npos) << s.to_string();
    EXPECT_EQ(sink.calls, 1);
    EXPECT_TRUE(out.empty());
    // The renderer is still good for the next job.
    std::vector<Snapshot> again;
    ASSERT_TRUE(r->render(sphere, views, &again).ok());
    EXPECT_GT(covered(again[0]), 500u);
    // Bad indices are refused before anything reaches the sink.
    Mesh broken = sphere;
    broken.indices[4] = uint32_t(broken.vertex_count()) + 3;
    HostSink unused;
    EXPECT_EQ(r->render(broken, views, &out, {}, &unused).code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(unused.calls, 0);
  }
}

TEST_F(Backends, RendersRepeatablyAtAnySizeAndRejectsBadIndices) {
  const Mesh sphere = testing::icosphere(2);
  for (auto& r : backends_) {
    SCOPED_TRACE(r->description());
    std::vector<Snapshot> small, large, again;
    ASSERT_TRUE(r->render(sphere, views_of(sphere, 100), &small).ok());
    ASSERT_TRUE(r->render(sphere, views_of(sphere, 300), &large).ok());
    ASSERT_TRUE(r->render(sphere, views_of(sphere, 100), &again).ok());
    EXPECT_EQ(large[0].gray.width, 300);
    // Nine times the pixels, nine times the disc (to the rasterization of its rim).
    EXPECT_NEAR(double(covered(large[0])) / double(covered(small[0])), 9.0, 0.15);
    EXPECT_EQ(small[2].gray.pixels, again[2].gray.pixels);
    EXPECT_EQ(small[2].depth.pixels, again[2].depth.pixels);
    // A worker thread other than the creating one gets the same pictures.
    std::vector<Snapshot> threaded;
    Status threaded_status;
    std::thread([&] { threaded_status = r->render(sphere, views_of(sphere, 100), &threaded); }).join();
    ASSERT_TRUE(threaded_status.ok()) << threaded_status.to_string();
    EXPECT_EQ(small[2].gray.pixels, threaded[2].gray.pixels);

    Mesh broken = sphere;
    broken.indices[7] = uint32_t(broken.vertex_count());
    std::vector<Snapshot> none;
    EXPECT_EQ(r->render(broken, views_of(sphere, 100), &none).code(), StatusCode::kInvalidArgument);
  }
}

}  // namespace
}  // namespace vpr
