// Stage 1 (Section III): render a gray shaded image and a depth buffer per view
// with OpenGL, headless: EGL's device platform (NVIDIA GPUs and Mesa's software
// device alike) or OSMesa.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "core/status.h"
#include "render/drawn_geometry.h"
#include "render/views.h"

namespace vpr {

enum class RendererKind { kAuto, kEgl, kOsmesa };

StatusOr<RendererKind> parse_renderer_kind(const std::string& name);  // "auto", "egl", "osmesa"

struct Snapshot {
  GrayImage gray;    // shaded intensity, background 0; row 0 at the top
  FloatImage depth;  // window-space depth in [0, 1]; 1 where no surface was drawn
  Mask coverage;     // 1 where a surface was drawn
};

// Every view's pixels as GL left them, in two pixel-pack buffer objects of
// the renderer's context: glReadPixels into a buffer object copies on the GPU,
// so a GPU job's snapshots need not cross to the host (device_snapshots.h).
// View v's pixels start at pixel offset[v] of both buffers: width[v] x
// height[v], bottom row first.
struct PixelBuffers {
  unsigned rgba = 0;   // GL buffer name: RGBA8, 4 bytes a pixel
  unsigned depth = 0;  // GL buffer name: float window depth, 4 bytes a pixel
  std::vector<size_t> offset;
  std::vector<int> width, height;
  // Copies `bytes` from byte `from` of one of the two buffers to host memory
  // (glGetBufferSubData); empty where the GL library lacks it.
  std::function<void(unsigned buffer, size_t from, size_t bytes, void* to)> read;
};

// Where render() hands the views' pixels instead of reading them back to the
// host. Called with the renderer's context current on the calling thread.
class SnapshotSink {
 public:
  virtual ~SnapshotSink() = default;
  // Once, after every view is drawn. The buffers are deleted after the call:
  // copy what is needed before returning. An error fails the render with it.
  virtual Status take(const PixelBuffers& pixels) = 0;
};

// Holds one GL context. render() may be called from any thread; calls on one
// renderer are serialized (the context is current only during a call).
class Renderer {
 public:
  virtual ~Renderer() = default;
  // "<backend>: <GL_RENDERER> (<GL_VENDOR>)", what actually renders, and for
  // an EGL device that says which CUDA device it is, ", CUDA device N", e.g.
  // "egl: NVIDIA H100 80GB HBM3/PCIe/SSE2 (NVIDIA Corporation), CUDA device 0",
  // "osmesa: llvmpipe (LLVM 15.0.6, 256 bits) (Mesa/X.org)".
  virtual std::string description() const = 0;
  // Renders every view of the mesh; out receives one Snapshot per view.
  // Shading: smooth and two-sided (polygon soups need not be oriented), gray =
  // 255 * (0.15 + 0.85 |n . l|), n the corner's smooth normal (faces within
  // 60 degrees averaged, creases kept), l the view direction tilted 25
  // degrees toward the image's upper left. Degenerate faces draw nothing.
  // Out-of-range indices are kInvalidArgument. twin: the GPU twin of the
  // drawn geometry (drawn_geometry.h) on a GPU job, else empty (the host
  // builds it); the same images either way. sink: when given, each view's
  // pixels go to it (SnapshotSink) and *out is left empty; UNAVAILABLE where
  // the context has no buffer objects.
  virtual Status render(const Mesh& mesh, const std::vector<View>& views, std::vector<Snapshot>* out,
                        const DrawnGeometryTwin& twin = {}, SnapshotSink* sink = nullptr) = 0;
  // Where the last render() spent its time, for benchmarks:
  // "prep P ms, upload U ms, draw D ms, readback R ms, convert C ms, bind B ms"
  // (prep "(on the GPU)" when the twin built the geometry).
  virtual std::string last_breakdown() const { return ""; }
  // How the corners reach GL. kAuto: on a GPU, corners with the same
  // position and normal shared in an indexed draw (a smaller upload); on a
  // software rasterizer (llvmpipe), every corner unindexed (it draws those
  // faster). Both give the same images; tests force each.
  enum class DrawPath { kAuto, kCorners, kSharedCorners };
  virtual void set_draw_path(DrawPath path) { (void)path; }
};

// kAuto tries EGL first and falls back to OSMesa. The error names every
// backend tried and why it failed. cuda_device >= 0: EGL renders on that CUDA
// device's GPU where the driver says which EGL device it is
// (EGL_NV_device_cuda), so that on a host with several GPUs a job renders on
// its own GPU and its snapshots can stay there (device_snapshots.h); the
// first hardware device otherwise, and always when cuda_device < 0.
StatusOr<std::unique_ptr<Renderer>> create_renderer(RendererKind kind, int cuda_device = -1);

}  // namespace vpr
