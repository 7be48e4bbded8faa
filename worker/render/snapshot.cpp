// Stage 1 (Section III): snapshots. The paper renders each view with OpenGL and
// reads back the colour and depth buffers; image-space saliency (stage 2) works
// on the gray image, unprojection (stage 3) on the depth buffer.
//
// Shading is ours, chosen for polygon soups whose faces have no consistent
// orientation: two-sided, gray = 255 * (0.15 + 0.85 |n . l|), with l a
// headlight tilted 25 degrees up and to the left of the view direction so that
// creases facing the camera still differ in brightness. n is a smooth corner
// normal (see corner_normals): flat shading made every facet edge of a coarse
// mesh an inner feature (spot.obj: a grid of lines over the whole cow), which
// is tessellation, not shape.
#include "render/snapshot.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <string>

#include "core/vec3.h"
#include "render/drawn_geometry.h"
#include "render/gl_functions.h"
#include "render/gl_pixels.h"

namespace vpr {

StatusOr<RendererKind> parse_renderer_kind(const std::string& name) {
  if (name == "auto") return RendererKind::kAuto;
  if (name == "egl") return RendererKind::kEgl;
  if (name == "osmesa") return RendererKind::kOsmesa;
  return invalid_argument("unknown renderer '" + name + "'; expected one of: auto, egl, osmesa");
}

StatusOr<std::unique_ptr<Renderer>> create_renderer(RendererKind kind, int cuda_device) {
  if (kind == RendererKind::kEgl) return gl::create_egl_renderer(cuda_device);
  if (kind == RendererKind::kOsmesa) return gl::create_osmesa_renderer();
  auto egl = gl::create_egl_renderer(cuda_device);
  if (egl.ok()) return egl;
  auto osmesa = gl::create_osmesa_renderer();
  if (osmesa.ok()) return osmesa;
  return unavailable("no renderer could be created: egl: " + egl.status().message() +
                     "; osmesa: " + osmesa.status().message());
}

namespace gl {
namespace {

constexpr double kAmbient = 0.15;           // gray floor, so grazing faces stay distinct from background
constexpr double kLightTiltDegrees = 25.0;  // headlight tilt toward the view's upper left
constexpr GLenum kMultisample = 0x809D;     // GL_MULTISAMPLE (GL 1.3)
// Corners per draw call: keeps any one call well inside driver limits
// for meshes of tens of millions of faces.
constexpr GLsizei kDrawChunk = 3 * (1 << 20);

template <class F>
bool load_one(ProcLoader loader, const char* name, F* slot) {
  *slot = reinterpret_cast<F>(loader(name));
  return *slot != nullptr;
}

std::string hex(unsigned v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04X", v);
  return buf;
}

Vec3d unit(Vec3d v) {
  const double n = norm(v);
  return n > 0 ? v * (1.0 / n) : v;
}

// The light of one view, in model space (same frame as the face normals).
Vec3d view_light(const View& view) {
  // The view's right and up directions in model space, from its inverse
  // projection: the images of NDC +x and +y, relative to the NDC origin.
  const Vec3d o = transform_point(view.inv_view_proj, {0, 0, 0});
  const Vec3d right = unit(transform_point(view.inv_view_proj, {1, 0, 0}) - o);
  const Vec3d up = unit(transform_point(view.inv_view_proj, {0, 1, 0}) - o);
  const Vec3d toward{view.toward_camera.x, view.toward_camera.y, view.toward_camera.z};
  const double t = kLightTiltDegrees * M_PI / 180.0;
  return unit(std::cos(t) * unit(toward) + std::sin(t) * unit(up - right));
}

}  // namespace

#ifndef VPR_HAVE_EGL
StatusOr<std::unique_ptr<Renderer>> create_egl_renderer(int) {
  return unavailable("this build has no EGL support (VPR_EGL=OFF)");
}
#endif
#ifndef VPR_HAVE_OSMESA
StatusOr<std::unique_ptr<Renderer>> create_osmesa_renderer() {
  return unavailable("this build has no OSMesa support (VPR_OSMESA=OFF)");
}
#endif

bool Functions::has_framebuffer_objects() const {
  return GenFramebuffers && DeleteFramebuffers && BindFramebuffer && GenRenderbuffers && DeleteRenderbuffers &&
         BindRenderbuffer && RenderbufferStorage && FramebufferRenderbuffer && CheckFramebufferStatus;
}

Status load_functions(ProcLoader loader, Functions* gl) {
  std::string missing;
#define VPR_LOAD(field, name) \
  if (!load_one(loader, name, &gl->field)) missing += std::string(missing.empty() ? "" : ", ") + name
  VPR_LOAD(GetString, "glGetString");
  VPR_LOAD(GetError, "glGetError");
  VPR_LOAD(GetIntegerv, "glGetIntegerv");
  VPR_LOAD(Enable, "glEnable");
  VPR_LOAD(Disable, "glDisable");
  VPR_LOAD(Viewport, "glViewport");
  VPR_LOAD(ClearColor, "glClearColor");
  VPR_LOAD(ClearDepth, "glClearDepth");
  VPR_LOAD(Clear, "glClear");
  VPR_LOAD(DepthFunc, "glDepthFunc");
  VPR_LOAD(DepthMask, "glDepthMask");
  VPR_LOAD(DepthRange, "glDepthRange");
  VPR_LOAD(ShadeModel, "glShadeModel");
  VPR_LOAD(PolygonMode, "glPolygonMode");
  VPR_LOAD(MatrixMode, "glMatrixMode");
  VPR_LOAD(LoadMatrixd, "glLoadMatrixd");
  VPR_LOAD(LoadIdentity, "glLoadIdentity");
  VPR_LOAD(EnableClientState, "glEnableClientState");
  VPR_LOAD(DisableClientState, "glDisableClientState");
  VPR_LOAD(VertexPointer, "glVertexPointer");
  VPR_LOAD(ColorPointer, "glColorPointer");
  VPR_LOAD(DrawArrays, "glDrawArrays");
  VPR_LOAD(DrawElements, "glDrawElements");
  VPR_LOAD(PixelStorei, "glPixelStorei");
  VPR_LOAD(ReadBuffer, "glReadBuffer");
  VPR_LOAD(ReadPixels, "glReadPixels");
  VPR_LOAD(Finish, "glFinish");
#undef VPR_LOAD
  if (!missing.empty()) return unavailable("the GL library lacks " + missing);

  const bool buffers = load_one(loader, "glGenBuffers", &gl->GenBuffers) &
                       load_one(loader, "glDeleteBuffers", &gl->DeleteBuffers) &
                       load_one(loader, "glBindBuffer", &gl->BindBuffer) &
                       load_one(loader, "glBufferData", &gl->BufferData) &
                       load_one(loader, "glBufferSubData", &gl->BufferSubData);
  load_one(loader, "glGetBufferSubData", &gl->GetBufferSubData);
  if (!buffers) gl->GenBuffers = nullptr;

  // Framebuffer objects: core names first, then the EXT extension's.
  const char* suffixes[] = {"", "EXT"};
  for (const char* s : suffixes) {
    auto name = [s](const char* base) { return std::string(base) + s; };
    bool all = load_one(loader, name("glGenFramebuffers").c_str(), &gl->GenFramebuffers);
    all &= load_one(loader, name("glDeleteFramebuffers").c_str(), &gl->DeleteFramebuffers);
    all &= load_one(loader, name("glBindFramebuffer").c_str(), &gl->BindFramebuffer);
    all &= load_one(loader, name("glGenRenderbuffers").c_str(), &gl->GenRenderbuffers);
    all &= load_one(loader, name("glDeleteRenderbuffers").c_str(), &gl->DeleteRenderbuffers);
    all &= load_one(loader, name("glBindRenderbuffer").c_str(), &gl->BindRenderbuffer);
    all &= load_one(loader, name("glRenderbufferStorage").c_str(), &gl->RenderbufferStorage);
    all &= load_one(loader, name("glFramebufferRenderbuffer").c_str(), &gl->FramebufferRenderbuffer);
    all &= load_one(loader, name("glCheckFramebufferStatus").c_str(), &gl->CheckFramebufferStatus);
    if (all) break;
  }
  return Status::Ok();
}

std::string renderer_string(const Functions& gl) {
  auto str = [&](GLenum e) {
    const GLubyte* s = gl.GetString(e);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  return str(GL_RENDERER) + " (" + str(GL_VENDOR) + ")";
}

Status ensure_framebuffer(const Functions& gl, int width, int height, Framebuffer* fb) {
  if (!gl.has_framebuffer_objects()) return unavailable("framebuffer objects are not supported");
  if (fb->fbo != 0 && fb->width >= width && fb->height >= height) {
    gl.BindFramebuffer(GL_FRAMEBUFFER, fb->fbo);
    return Status::Ok();
  }
  const int w = std::max(width, fb->width), h = std::max(height, fb->height);
  destroy_framebuffer(gl, fb);
  GLint max_size = 0;
  gl.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  if (w > max_size || h > max_size)
    return resource_exhausted("snapshot of " + std::to_string(w) + "x" + std::to_string(h) +
                              " exceeds the GL renderbuffer limit of " + std::to_string(max_size));
  gl.GetError();  // clear stale errors so the check below is about this setup
  gl.GenFramebuffers(1, &fb->fbo);
  gl.BindFramebuffer(GL_FRAMEBUFFER, fb->fbo);
  gl.GenRenderbuffers(1, &fb->color);
  gl.BindRenderbuffer(GL_RENDERBUFFER, fb->color);
  gl.RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
  gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, fb->color);
  gl.GenRenderbuffers(1, &fb->depth);
  gl.BindRenderbuffer(GL_RENDERBUFFER, fb->depth);
  gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
  gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, fb->depth);
  const GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
  const GLenum error = gl.GetError();
  fb->width = w;
  fb->height = h;
  if (status != GL_FRAMEBUFFER_COMPLETE || error != GL_NO_ERROR) {
    destroy_framebuffer(gl, fb);
    return unavailable("framebuffer object incomplete (status " + hex(status) + ", GL error " + hex(error) + ")");
  }
  return Status::Ok();
}

void destroy_framebuffer(const Functions& gl, Framebuffer* fb) {
  if (fb->fbo) {
    gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
    gl.DeleteFramebuffers(1, &fb->fbo);
  }
  if (fb->color) gl.DeleteRenderbuffers(1, &fb->color);
  if (fb->depth) gl.DeleteRenderbuffers(1, &fb->depth);
  *fb = Framebuffer{};
}

void max_view_size(const std::vector<View>& views, int* width, int* height) {
  *width = 0;
  *height = 0;
  for (const View& v : views) {
    *width = std::max(*width, v.width);
    *height = std::max(*height, v.height);
  }
}

bool software_rasterizer(const Functions& gl) {
  const GLubyte* name = gl.GetString(GL_RENDERER);
  if (!name) return true;  // unknown: the path every renderer draws correctly and fast enough
  const std::string r(reinterpret_cast<const char*>(name));
  for (const char* soft : {"llvmpipe", "softpipe", "swrast", "Software Rasterizer", "SWR", "lavapipe"})
    if (r.find(soft) != std::string::npos) return true;
  return false;
}

std::string RenderBreakdown::to_string() const {
  char buf[192];
  std::snprintf(buf, sizeof buf,
                "prep %.1f ms%s, upload %.1f ms, draw %.1f ms, readback %.1f ms, convert %.1f ms, bind %.1f ms", prep,
                prep_on_gpu ? " (on the GPU)" : "", upload, draw, readback, convert, bind);
  return prep_note.empty() ? std::string(buf) : std::string(buf) + "; " + prep_note;
}

void snapshot_from_rows(const uint8_t* rgba, const float* depth, int width, int height, Snapshot* out) {
  out->gray = GrayImage(width, height, 0);
  out->depth = FloatImage(width, height, 1.0f);
  out->coverage = Mask(width, height, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < width; ++x)
        snapshot_pixel(rgba, depth, width, height, x, y, out->gray.pixels.data(), out->depth.pixels.data(),
                       out->coverage.pixels.data());
  });
}

Status render_views(const Functions& gl, const Mesh& mesh, const std::vector<View>& views, std::vector<Snapshot>* out,
                    RenderBreakdown* breakdown, Renderer::DrawPath path, const DrawnGeometryTwin& twin,
                    SnapshotSink* sink) {
  assert(out != nullptr);
  RenderBreakdown local;
  RenderBreakdown& bd = breakdown ? *breakdown : local;
  bd = RenderBreakdown{};
  using Clock = std::chrono::steady_clock;
  auto lap = [last = Clock::now()](double* into) mutable {
    const auto now = Clock::now();
    *into += std::chrono::duration<double, std::milli>(now - last).count();
    last = now;
  };
  double unused = 0;
  lap(&unused);
  out->clear();
  for (const View& v : views)
    if (v.width <= 0 || v.height <= 0) return invalid_argument("view " + v.name + " has an empty image");
  if (sink && !gl.has_vertex_buffers())
    return unavailable("the GL context has no buffer objects, which pixels handed over on the GPU need");
  // The drawable faces' corners, with smooth normals, shared on a GPU's
  // renderer (drawn_geometry.h); on a GPU job the twin builds them there.
  const bool indexed = path == Renderer::DrawPath::kAuto ? !software_rasterizer(gl)
                                                        : path == Renderer::DrawPath::kSharedCorners;
  DrawnGeometry geometry;
  VPR_RETURN_IF_ERROR(drawn_geometry(mesh, indexed, twin, &geometry, &bd.prep_on_gpu, &bd.prep_note));
  const Vec3d centre = geometry.centre;
  const std::vector<float>& positions = geometry.positions;
  const std::vector<Vec3>& normals = geometry.normals;
  const std::vector<uint32_t>& indices = geometry.indices;
  const size_t drawn = normals.size();
  const GLsizei vertex_count = GLsizei(geometry.corners);  // corners drawn (indices, or array vertices)
  std::vector<uint8_t> colors(4 * drawn, 255);

  lap(&bd.prep);
  gl.GetError();
  gl.Disable(GL_DITHER);
  gl.Disable(kMultisample);
  gl.Disable(GL_LIGHTING);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_BLEND);
  gl.Disable(GL_TEXTURE_2D);
  gl.Disable(GL_POLYGON_SMOOTH);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.DepthMask(GL_TRUE);
  gl.DepthRange(0.0, 1.0);
  gl.ShadeModel(GL_SMOOTH);
  gl.PolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  gl.ClearColor(0.f, 0.f, 0.f, 1.f);
  gl.ClearDepth(1.0);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadIdentity();
  gl.EnableClientState(GL_VERTEX_ARRAY);
  gl.EnableClientState(GL_COLOR_ARRAY);
  // With buffer objects the positions and indices cross to the GPU once, and
  // only the colours (a quarter of the vertex bytes) once per view.
  GLuint buffers[3] = {0, 0, 0};
  const bool use_buffers = gl.has_vertex_buffers();
  const GLsizeiptr position_bytes = GLsizeiptr(positions.size() * sizeof(float));
  const GLsizeiptr color_bytes = GLsizeiptr(colors.size());
  const GLsizeiptr index_bytes = GLsizeiptr(indices.size() * sizeof(uint32_t));
  if (use_buffers) {
    gl.GenBuffers(3, buffers);
    gl.BindBuffer(GL_ARRAY_BUFFER, buffers[0]);
    gl.BufferData(GL_ARRAY_BUFFER, position_bytes, positions.data(), GL_STATIC_DRAW);
    gl.VertexPointer(3, GL_FLOAT, 0, nullptr);
    if (indexed) {
      gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, buffers[2]);
      gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, index_bytes, indices.data(), GL_STATIC_DRAW);
    }
    gl.BindBuffer(GL_ARRAY_BUFFER, buffers[1]);
    gl.BufferData(GL_ARRAY_BUFFER, color_bytes, nullptr, GL_STREAM_DRAW);
    gl.ColorPointer(4, GL_UNSIGNED_BYTE, 0, nullptr);
  } else {
    gl.VertexPointer(3, GL_FLOAT, 0, positions.data());
    gl.ColorPointer(4, GL_UNSIGNED_BYTE, 0, colors.data());
  }
  lap(&bd.upload);
  auto release = [&] {
    gl.DisableClientState(GL_VERTEX_ARRAY);
    gl.DisableClientState(GL_COLOR_ARRAY);
    if (use_buffers) {
      gl.BindBuffer(GL_ARRAY_BUFFER, 0);
      gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
      gl.DeleteBuffers(3, buffers);
    }
  };
  // With a sink, every view's pixels are read into two pixel-pack buffers
  // (a copy on the GPU), each view at its own offset, and handed over once.
  GLuint pixel_buffers[2] = {0, 0};
  PixelBuffers handed;
  if (sink) {
    size_t pixels = 0;
    for (const View& v : views) {
      handed.offset.push_back(pixels);
      handed.width.push_back(v.width);
      handed.height.push_back(v.height);
      pixels += size_t(v.width) * size_t(v.height);
    }
    gl.GenBuffers(2, pixel_buffers);
    for (GLuint b : pixel_buffers) {
      gl.BindBuffer(GL_PIXEL_PACK_BUFFER, b);
      gl.BufferData(GL_PIXEL_PACK_BUFFER, GLsizeiptr(4 * pixels), nullptr, GL_STREAM_READ);
    }
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    handed.rgba = pixel_buffers[0];
    handed.depth = pixel_buffers[1];
    if (gl.GetBufferSubData)
      handed.read = [&gl](unsigned buffer, size_t from, size_t bytes, void* to) {
        gl.BindBuffer(GL_PIXEL_PACK_BUFFER, buffer);
        gl.GetBufferSubData(GL_PIXEL_PACK_BUFFER, GLintptr(from), GLsizeiptr(bytes), to);
        gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
      };
  }
  auto release_all = [&] {
    if (pixel_buffers[0]) gl.DeleteBuffers(2, pixel_buffers);
    release();
  };

  std::vector<uint8_t> rgba;
  std::vector<float> depth;
  out->reserve(sink ? 0 : views.size());
  for (const View& view : views) {
    const Vec3d l = view_light(view);
    const Vec3 light{float(l.x), float(l.y), float(l.z)};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, drawn, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t c = r.begin(); c < r.end(); ++c) {
        const float shade =
            std::clamp(float(kAmbient) + float(1.0 - kAmbient) * std::abs(dot(normals[c], light)), 0.f, 1.f);
        const uint8_t g = uint8_t(255.f * shade + 0.5f);
        colors[4 * c] = colors[4 * c + 1] = colors[4 * c + 2] = g;
      }
    });
    lap(&bd.prep);
    if (use_buffers) gl.BufferSubData(GL_ARRAY_BUFFER, 0, color_bytes, colors.data());
    lap(&bd.upload);

    // view_proj * translate(centre): the positions above are centre-relative.
    Mat4 m = view.view_proj;
    for (int r = 0; r < 4; ++r) m[12 + r] += m[0 + r] * centre.x + m[4 + r] * centre.y + m[8 + r] * centre.z;
    gl.MatrixMode(GL_PROJECTION);
    gl.LoadMatrixd(m.data());
    gl.Viewport(0, 0, view.width, view.height);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    for (GLsizei first = 0; first < vertex_count; first += kDrawChunk) {
      const GLsizei count = std::min(kDrawChunk, vertex_count - first);
      if (!indexed)
        gl.DrawArrays(GL_TRIANGLES, first, count);
      else if (use_buffers)
        gl.DrawElements(GL_TRIANGLES, count, GL_UNSIGNED_INT,
                        reinterpret_cast<const void*>(size_t(first) * sizeof(uint32_t)));
      else
        gl.DrawElements(GL_TRIANGLES, count, GL_UNSIGNED_INT, indices.data() + first);
    }

    const int w = view.width, h = view.height;
    // The draw's own time, apart from the readback's. A sink's copies wait for
    // the draws on the GPU instead: its hand-over's time holds theirs.
    if (!sink) gl.Finish();
    lap(&bd.draw);
    if (sink) {
      const size_t at = 4 * handed.offset[size_t(&view - views.data())];  // bytes
      gl.BindBuffer(GL_PIXEL_PACK_BUFFER, pixel_buffers[0]);
      gl.ReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, reinterpret_cast<void*>(at));
      gl.BindBuffer(GL_PIXEL_PACK_BUFFER, pixel_buffers[1]);
      gl.ReadPixels(0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, reinterpret_cast<void*>(at));
      gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    } else {
      rgba.resize(size_t(w) * h * 4);
      depth.resize(size_t(w) * h);
      gl.ReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
      gl.ReadPixels(0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
    }
    const GLenum error = gl.GetError();
    if (error != GL_NO_ERROR) {
      release_all();
      out->clear();
      return internal_error("GL error " + hex(error) + " while rendering view " + view.name);
    }
    if (sink) {
      lap(&bd.readback);
      continue;
    }
    lap(&bd.readback);
    Snapshot s;
    snapshot_from_rows(rgba.data(), depth.data(), w, h, &s);
    out->push_back(std::move(s));
    lap(&bd.convert);
  }
  if (sink) {
    const Status taken = sink->take(handed);
    lap(&bd.readback);
    release_all();
    return taken;
  }
  release_all();
  return Status::Ok();
}

}  // namespace gl
}  // namespace vpr
