// Stage 1 snapshots through EGL: a GPU's own driver (NVIDIA) or Mesa's
// software device, with no window system. Displays are tried in this order:
// the EGL device of the job's CUDA device when asked for and known, every
// other EGL device that is not a software rasterizer, the software devices,
// Mesa's surfaceless platform, the default display.
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

#include "render/gl_functions.h"
#include "render/snapshot.h"

namespace vpr::gl {
namespace {

std::string egl_error() {
  char buf[32];
  std::snprintf(buf, sizeof buf, "EGL error 0x%04X", unsigned(eglGetError()));
  return buf;
}

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const std::string all = std::string(" ") + list + " ";
  return all.find(std::string(" ") + name + " ") != std::string::npos;
}

// Displays stay initialized for the life of the process: eglInitialize of a
// GPU display costs tens of milliseconds and the pipeline creates a renderer
// per job, and eglTerminate would destroy the contexts of every other
// renderer on the same device (one device yields one EGLDisplay handle
// process-wide). Initializing an initialized display is a cheap no-op.
bool initialize_display(EGLDisplay display) {
  EGLint major = 0, minor = 0;
  return eglInitialize(display, &major, &minor) == EGL_TRUE;
}

class EglRenderer final : public Renderer {
 public:
  explicit EglRenderer(EGLDisplay display) : display_(display) {}
  ~EglRenderer() override {
    if (context_ != EGL_NO_CONTEXT) {
      if (make_current()) {
        destroy_framebuffer(gl_, &framebuffer_);
        release();
      }
      eglDestroyContext(display_, context_);
    }
    if (pbuffer_ != EGL_NO_SURFACE) eglDestroySurface(display_, pbuffer_);
  }

  // Creates the context and its render target; on failure the renderer is
  // unusable and the status says why.
  // cuda_device: the CUDA device the display is (EGL_NV_device_cuda), or -1;
  // the description names it.
  Status init(const std::string& label, int cuda_device) {
    if (!eglBindAPI(EGL_OPENGL_API))
      return unavailable(label + ": desktop OpenGL is not offered (" + egl_error() + ")");
    const char* display_extensions = eglQueryString(display_, EGL_EXTENSIONS);
    const bool surfaceless = has_extension(display_extensions, "EGL_KHR_surfaceless_context");

    // A pbuffer-capable RGBA8 + depth24 config; without pbuffers any OpenGL
    // config serves, as we then draw into a framebuffer object.
    for (EGLint surface_type : {EGLint(EGL_PBUFFER_BIT), EGLint(0)}) {
      // clang-format off
      const EGLint attribs[] = {EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24,
                                EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, surface_type, EGL_NONE};
      // clang-format on
      EGLint count = 0;
      if (eglChooseConfig(display_, attribs, &config_, 1, &count) && count > 0) {
        can_pbuffer_ = surface_type == EGL_PBUFFER_BIT;
        break;
      }
      config_ = nullptr;
    }
    if (!config_) return unavailable(label + ": no RGBA8 + depth24 OpenGL config");
    const EGLint context_attribs[] = {EGL_NONE};
    context_ = eglCreateContext(display_, config_, EGL_NO_CONTEXT, context_attribs);
    if (context_ == EGL_NO_CONTEXT) return unavailable(label + ": eglCreateContext failed (" + egl_error() + ")");

    std::string fbo_error;
    if (surfaceless && eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      Status s = load_functions(eglGetProcAddress, &gl_);
      if (s.ok()) s = ensure_framebuffer(gl_, 64, 64, &framebuffer_);
      if (s.ok()) {
        use_fbo_ = true;
      } else {
        fbo_error = s.message();
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      }
    } else {
      fbo_error =
          surfaceless ? "surfaceless eglMakeCurrent failed (" + egl_error() + ")" : "no EGL_KHR_surfaceless_context";
    }
    if (!use_fbo_) {
      if (!can_pbuffer_) return unavailable(label + ": " + fbo_error + ", and no pbuffer config");
      Status s = ensure_pbuffer(64, 64);
      if (s.ok()) s = load_functions(eglGetProcAddress, &gl_);
      if (!s.ok()) return unavailable(label + ": " + fbo_error + "; pbuffer: " + s.message());
    }
    description_ = "egl: " + renderer_string(gl_);
    if (cuda_device >= 0) description_ += ", CUDA device " + std::to_string(cuda_device);
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    return Status::Ok();
  }

  std::string description() const override { return description_; }
  std::string last_breakdown() const override { return breakdown_.to_string(); }
  void set_draw_path(DrawPath path) override {
    std::lock_guard<std::mutex> lock(mutex_);
    draw_path_ = path;
  }

  // One render at a time per renderer: the context is made current on the
  // calling thread for the duration of the call and released afterwards.
  Status render(const Mesh& mesh, const std::vector<View>& views, std::vector<Snapshot>* out,
                const DrawnGeometryTwin& twin = {}, SnapshotSink* sink = nullptr) override {
    std::lock_guard<std::mutex> lock(mutex_);
    using Clock = std::chrono::steady_clock;
    auto ms_since = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
    const auto start = Clock::now();
    int width = 0, height = 0;
    max_view_size(views, &width, &height);
    Status s;
    if (use_fbo_) {
      if (!make_current()) return unavailable("egl: eglMakeCurrent failed (" + egl_error() + ")");
      s = ensure_framebuffer(gl_, width, height, &framebuffer_);
    } else {
      s = ensure_pbuffer(width, height);
    }
    const double bind = ms_since(start);
    if (s.ok()) s = render_views(gl_, mesh, views, out, &breakdown_, draw_path_, twin, sink);
    const auto released = Clock::now();
    release();
    breakdown_.bind = bind + ms_since(released);
    return s;
  }

 private:
  // The bound client API is per thread, and eglMakeCurrent acts on the
  // calling thread's: render() may run on a thread that never bound OpenGL.
  bool make_current() {
    return eglBindAPI(EGL_OPENGL_API) && eglMakeCurrent(display_, pbuffer_, pbuffer_, context_) == EGL_TRUE;
  }
  void release() {
    eglBindAPI(EGL_OPENGL_API);
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }

  // Makes the pbuffer at least width x height and the context current on it.
  Status ensure_pbuffer(int width, int height) {
    if (pbuffer_ == EGL_NO_SURFACE || pbuffer_width_ < width || pbuffer_height_ < height) {
      release();
      if (pbuffer_ != EGL_NO_SURFACE) eglDestroySurface(display_, pbuffer_);
      pbuffer_width_ = std::max(width, pbuffer_width_);
      pbuffer_height_ = std::max(height, pbuffer_height_);
      const EGLint attribs[] = {EGL_WIDTH, pbuffer_width_, EGL_HEIGHT, pbuffer_height_, EGL_NONE};
      pbuffer_ = eglCreatePbufferSurface(display_, config_, attribs);
      if (pbuffer_ == EGL_NO_SURFACE)
        return unavailable("eglCreatePbufferSurface " + std::to_string(pbuffer_width_) + "x" +
                           std::to_string(pbuffer_height_) + " failed (" + egl_error() + ")");
    }
    if (!make_current()) return unavailable("eglMakeCurrent on the pbuffer failed (" + egl_error() + ")");
    return Status::Ok();
  }

  EGLDisplay display_;
  EGLConfig config_ = nullptr;
  EGLContext context_ = EGL_NO_CONTEXT;
  EGLSurface pbuffer_ = EGL_NO_SURFACE;
  int pbuffer_width_ = 0, pbuffer_height_ = 0;
  bool can_pbuffer_ = false;
  bool use_fbo_ = false;
  Framebuffer framebuffer_;
  Functions gl_;
  RenderBreakdown breakdown_;
  DrawPath draw_path_ = DrawPath::kAuto;
  std::string description_;
  std::mutex mutex_;
};

// `display` is initialized by the caller.
StatusOr<std::unique_ptr<Renderer>> try_display(EGLDisplay display, const std::string& label, int cuda_device) {
  auto renderer = std::make_unique<EglRenderer>(display);
  Status s = renderer->init(label, cuda_device);
  if (!s.ok()) return s;
  return std::unique_ptr<Renderer>(std::move(renderer));
}

}  // namespace

StatusOr<std::unique_ptr<Renderer>> create_egl_renderer(int cuda_device) {
  std::string errors;
  auto note = [&](const std::string& e) { errors += (errors.empty() ? "" : "; ") + e; };
  auto attempt = [&](EGLDisplay display, const std::string& label, int cuda = -1) -> std::unique_ptr<Renderer> {
    if (display == EGL_NO_DISPLAY) {
      note(label + ": no display (" + egl_error() + ")");
      return nullptr;
    }
    if (!initialize_display(display)) {
      note(label + ": eglInitialize failed (" + egl_error() + ")");
      return nullptr;
    }
    auto r = try_display(display, label, cuda);
    if (r.ok()) return std::move(r).value();
    note(r.status().message());
    return nullptr;
  };

  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto query_device_string =
      reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
  auto query_device_attrib =
      reinterpret_cast<PFNEGLQUERYDEVICEATTRIBEXTPROC>(eglGetProcAddress("eglQueryDeviceAttribEXT"));
  // The CUDA device an EGL device is (EGL_NV_device_cuda), or -1.
  auto cuda_device_of = [&](EGLDeviceEXT device) -> int {
    EGLAttrib id = -1;
    if (!query_device_attrib || !has_extension(query_device_string(device, EGL_EXTENSIONS), "EGL_NV_device_cuda") ||
        !query_device_attrib(device, EGL_CUDA_DEVICE_NV, &id))
      return -1;
    return int(id);
  };

  if (has_extension(client_extensions, "EGL_EXT_platform_device") && get_platform_display && query_devices &&
      query_device_string) {
    EGLDeviceEXT devices[16];
    EGLint count = 0;
    if (!query_devices(16, devices, &count)) count = 0;
    // The job's GPU first, then hardware devices; Mesa marks its software
    // rasterizer device.
    std::vector<std::tuple<bool, bool, int>> order;  // (not the job's GPU, is software, index)
    for (EGLint i = 0; i < count; ++i)
      order.push_back({cuda_device < 0 || cuda_device_of(devices[i]) != cuda_device,
                       has_extension(query_device_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software"), i});
    std::stable_sort(order.begin(), order.end());
    for (const auto& [other, software, i] : order) {
      std::string label = "device " + std::to_string(i);
      if (const int cuda = cuda_device_of(devices[i]); cuda >= 0)
        label += " (CUDA device " + std::to_string(cuda) + ")";
      if (has_extension(query_device_string(devices[i], EGL_EXTENSIONS), "EGL_EXT_device_drm")) {
        const char* file = query_device_string(devices[i], EGL_DRM_DEVICE_FILE_EXT);
        if (file) label += std::string(" (") + file + ")";
      }
      if (software) label += " (software)";
      if (auto r = attempt(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr), label,
                           cuda_device_of(devices[i])))
        return r;
    }
    if (count == 0) note("EGL lists no devices");
  } else {
    note("EGL_EXT_platform_device is not available");
  }
  if (has_extension(client_extensions, "EGL_MESA_platform_surfaceless") && get_platform_display) {
    if (auto r = attempt(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
                         "surfaceless platform"))
      return r;
  }
  if (auto r = attempt(eglGetDisplay(EGL_DEFAULT_DISPLAY), "default display")) return r;
  return unavailable(errors);
}

}  // namespace vpr::gl
