// Stage 1 snapshots through OSMesa: Mesa's software rasterizer (llvmpipe)
// drawing into a host buffer. Needs no device and no display, so it is the
// fallback that works everywhere.
#include <GL/osmesa.h>

#include <mutex>
#include <string>

#include "render/gl_functions.h"
#include "render/snapshot.h"

namespace vpr::gl {
namespace {

class OsmesaRenderer final : public Renderer {
 public:
  ~OsmesaRenderer() override {
    if (context_) OSMesaDestroyContext(context_);
  }

  Status init() {
    // Compatibility profile: we draw with client arrays and the fixed pipeline.
    // clang-format off
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_STENCIL_BITS, 0,
                           OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_COMPAT_PROFILE, 0};
    // clang-format on
    context_ = OSMesaCreateContextAttribs(attribs, nullptr);
    if (!context_) context_ = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
    if (!context_) return unavailable("OSMesa could not create an RGBA context with a 24-bit depth buffer");
    VPR_RETURN_IF_ERROR(make_current(64, 64));
    Status s = load_functions(reinterpret_cast<ProcLoader>(OSMesaGetProcAddress), &gl_);
    if (s.ok()) description_ = "osmesa: " + renderer_string(gl_);
    release();
    return s;
  }

  std::string description() const override { return description_; }
  std::string last_breakdown() const override { return breakdown_.to_string(); }
  void set_draw_path(DrawPath path) override {
    std::lock_guard<std::mutex> lock(mutex_);
    draw_path_ = path;
  }

  // One render at a time per renderer; the context is current on the calling
  // thread only for the duration of the call.
  Status render(const Mesh& mesh, const std::vector<View>& views, std::vector<Snapshot>* out,
                const DrawnGeometryTwin& twin = {}, SnapshotSink* sink = nullptr) override {
    std::lock_guard<std::mutex> lock(mutex_);
    int width = 0, height = 0;
    max_view_size(views, &width, &height);
    Status s = make_current(width, height);
    if (s.ok()) s = render_views(gl_, mesh, views, out, &breakdown_, draw_path_, twin, sink);
    release();
    return s;
  }

 private:
  Status make_current(int width, int height) {
    GLint max_width = 0, max_height = 0;
    if (width > 0 && height > 0) {
      // OSMesa answers limits only for a current context; the first call has none.
      if (OSMesaGetCurrentContext() == context_) {
        OSMesaGetIntegerv(OSMESA_MAX_WIDTH, &max_width);
        OSMesaGetIntegerv(OSMESA_MAX_HEIGHT, &max_height);
      }
      if ((max_width > 0 && width > max_width) || (max_height > 0 && height > max_height))
        return resource_exhausted("snapshot of " + std::to_string(width) + "x" + std::to_string(height) +
                                  " exceeds OSMesa's limit of " + std::to_string(max_width) + "x" +
                                  std::to_string(max_height));
    }
    width = std::max(width, 1);
    height = std::max(height, 1);
    // The colour buffer stays the size of the last render; only a larger view reallocates.
    if (size_t(width) * height * 4 > buffer_.size()) buffer_.resize(size_t(width) * height * 4);
    if (!OSMesaMakeCurrent(context_, buffer_.data(), GL_UNSIGNED_BYTE, width, height))
      return unavailable("OSMesaMakeCurrent " + std::to_string(width) + "x" + std::to_string(height) + " failed");
    return Status::Ok();
  }

  void release() { OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0); }

  OSMesaContext context_ = nullptr;
  std::vector<uint8_t> buffer_;  // RGBA8 colour, bottom row first
  Functions gl_;
  RenderBreakdown breakdown_;
  DrawPath draw_path_ = DrawPath::kAuto;
  std::string description_;
  std::mutex mutex_;
};

}  // namespace

StatusOr<std::unique_ptr<Renderer>> create_osmesa_renderer() {
  auto renderer = std::make_unique<OsmesaRenderer>();
  VPR_RETURN_IF_ERROR(renderer->init());
  return std::unique_ptr<Renderer>(std::move(renderer));
}

}  // namespace vpr::gl
