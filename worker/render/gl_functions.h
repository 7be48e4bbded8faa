// Internal to the snapshot renderers (snapshot*.cpp); not a stage contract.
//
// libOSMesa exports the gl* entry points itself, so linking it together with
// libGL/libOpenGL, or calling gl* directly, would bind each call to whichever
// library the dynamic linker saw first. Every GL call therefore goes through
// this table, filled by the backend's own loader (eglGetProcAddress or
// OSMesaGetProcAddress), and no gl* symbol is referenced at link time.
#pragma once

#include <GL/gl.h>
#include <GL/glext.h>

#include <memory>
#include <string>
#include <vector>

#include "render/snapshot.h"
#include "core/status.h"

namespace vpr::gl {

using Proc = void (*)();
using ProcLoader = Proc (*)(const char* name);

// decltype of a declared gl* prototype names the pointer type without
// referencing the symbol.
struct Functions {
  decltype(&::glGetString) GetString = nullptr;
  decltype(&::glGetError) GetError = nullptr;
  decltype(&::glGetIntegerv) GetIntegerv = nullptr;
  decltype(&::glEnable) Enable = nullptr;
  decltype(&::glDisable) Disable = nullptr;
  decltype(&::glViewport) Viewport = nullptr;
  decltype(&::glClearColor) ClearColor = nullptr;
  decltype(&::glClearDepth) ClearDepth = nullptr;
  decltype(&::glClear) Clear = nullptr;
  decltype(&::glDepthFunc) DepthFunc = nullptr;
  decltype(&::glDepthMask) DepthMask = nullptr;
  decltype(&::glDepthRange) DepthRange = nullptr;
  decltype(&::glShadeModel) ShadeModel = nullptr;
  decltype(&::glPolygonMode) PolygonMode = nullptr;
  decltype(&::glMatrixMode) MatrixMode = nullptr;
  decltype(&::glLoadMatrixd) LoadMatrixd = nullptr;
  decltype(&::glLoadIdentity) LoadIdentity = nullptr;
  decltype(&::glEnableClientState) EnableClientState = nullptr;
  decltype(&::glDisableClientState) DisableClientState = nullptr;
  decltype(&::glVertexPointer) VertexPointer = nullptr;
  decltype(&::glColorPointer) ColorPointer = nullptr;
  decltype(&::glDrawArrays) DrawArrays = nullptr;
  decltype(&::glDrawElements) DrawElements = nullptr;
  decltype(&::glPixelStorei) PixelStorei = nullptr;
  decltype(&::glReadBuffer) ReadBuffer = nullptr;
  decltype(&::glReadPixels) ReadPixels = nullptr;
  decltype(&::glFinish) Finish = nullptr;
  // Framebuffer objects (GL 3.0 or ARB/EXT_framebuffer_object); only the EGL
  // backend needs them, so they may stay null.
  PFNGLGENFRAMEBUFFERSPROC GenFramebuffers = nullptr;
  PFNGLDELETEFRAMEBUFFERSPROC DeleteFramebuffers = nullptr;
  PFNGLBINDFRAMEBUFFERPROC BindFramebuffer = nullptr;
  PFNGLGENRENDERBUFFERSPROC GenRenderbuffers = nullptr;
  PFNGLDELETERENDERBUFFERSPROC DeleteRenderbuffers = nullptr;
  PFNGLBINDRENDERBUFFERPROC BindRenderbuffer = nullptr;
  PFNGLRENDERBUFFERSTORAGEPROC RenderbufferStorage = nullptr;
  PFNGLFRAMEBUFFERRENDERBUFFERPROC FramebufferRenderbuffer = nullptr;
  PFNGLCHECKFRAMEBUFFERSTATUSPROC CheckFramebufferStatus = nullptr;

  // Vertex buffer objects (GL 1.5): the mesh goes to the GPU once per job
  // instead of once per view. Optional; client arrays otherwise.
  PFNGLGENBUFFERSPROC GenBuffers = nullptr;
  PFNGLDELETEBUFFERSPROC DeleteBuffers = nullptr;
  PFNGLBINDBUFFERPROC BindBuffer = nullptr;
  PFNGLBUFFERDATAPROC BufferData = nullptr;
  PFNGLBUFFERSUBDATAPROC BufferSubData = nullptr;
  // Reads a buffer back (GL 1.5): a pixel buffer's bytes for a host sink
  // (PixelBuffers::read). Optional.
  PFNGLGETBUFFERSUBDATAPROC GetBufferSubData = nullptr;

  bool has_framebuffer_objects() const;
  bool has_vertex_buffers() const { return GenBuffers && DeleteBuffers && BindBuffer && BufferData && BufferSubData; }
};

// Fills every entry. Must be called with a context current (some loaders only
// answer then). Fails, naming the missing function, if a required one is absent.
Status load_functions(ProcLoader loader, Functions* gl);

// "<GL_RENDERER> (<GL_VENDOR>)" of the current context.
std::string renderer_string(const Functions& gl);

// An off-screen colour (RGBA8) + depth (24 bit) framebuffer object.
struct Framebuffer {
  GLuint fbo = 0, color = 0, depth = 0;
  int width = 0, height = 0;
};
// Makes *fb at least width x height and binds it. Needs a current context.
Status ensure_framebuffer(const Functions& gl, int width, int height, Framebuffer* fb);
void destroy_framebuffer(const Functions& gl, Framebuffer* fb);

// The shared part of every backend: with a context current whose bound draw
// framebuffer holds at least each view's width x height, shades the mesh
// (smooth corner normals, two-sided headlight, see snapshot.cpp) from each view and reads back
// gray, depth and coverage with row 0 at the top.
// Wall times of one render_views call, milliseconds.
struct RenderBreakdown {
  double prep = 0, upload = 0, draw = 0, readback = 0, convert = 0;
  double bind = 0;  // making the context current and releasing it (the EGL renderer's)
  bool prep_on_gpu = false;  // the drawn geometry came from the GPU twin (drawn_geometry.h)
  std::string prep_note;     // why the twin's result was not used, if it was asked for
  std::string to_string() const;
};

// path: Renderer::DrawPath (kAuto: by software_rasterizer). twin: the drawn
// geometry's GPU twin (Renderer::render), or empty for the host's.
Status render_views(const Functions& gl, const Mesh& mesh, const std::vector<View>& views, std::vector<Snapshot>* out,
                    RenderBreakdown* breakdown = nullptr, Renderer::DrawPath path = Renderer::DrawPath::kAuto,
                    const DrawnGeometryTwin& twin = {}, SnapshotSink* sink = nullptr);

// The host's read-back of one view: glReadPixels' rows (bottom first) into a
// snapshot (row 0 at the top), gl_pixels.h's rule per pixel.
void snapshot_from_rows(const uint8_t* rgba, const float* depth, int width, int height, Snapshot* out);

// Whether the current context rasterizes on the CPU (Mesa's llvmpipe,
// softpipe, swrast): render_views then draws every corner unindexed, which
// those draw faster, instead of sharing corners for a smaller upload.
bool software_rasterizer(const Functions& gl);

// Largest width and height over the views.
void max_view_size(const std::vector<View>& views, int* width, int* height);

// Backend factories. Each returns kUnavailable with the reason when its
// platform cannot give a working context on this machine.
// cuda_device: create_renderer's.
StatusOr<std::unique_ptr<Renderer>> create_egl_renderer(int cuda_device = -1);
StatusOr<std::unique_ptr<Renderer>> create_osmesa_renderer();

}  // namespace vpr::gl
