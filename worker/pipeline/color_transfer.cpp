#include "pipeline/color_transfer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cassert>
#include <cmath>

#include "core/color.h"
#include "surface/closest_point.h"

namespace vpr {

namespace {

// A coordinate brought into one period of its wrap mode, so that scaling it by
// the texture's size cannot overflow: [0, 1) for REPEAT, [0, 2) for MIRRORED_REPEAT, [0, 1] for CLAMP_TO_EDGE.
double wrap_coordinate(double u, TextureWrap wrap) {
  if (!std::isfinite(u)) return 0;
  switch (wrap) {
    case TextureWrap::kRepeat:
      return u - std::floor(u);
    case TextureWrap::kMirroredRepeat:
      return u - 2 * std::floor(u / 2);
    case TextureWrap::kClampToEdge:
      return std::clamp(u, 0.0, 1.0);
  }
  return 0;
}

// Texel column (or row) i of a texture `size` texels wide, wrapped.
int64_t texel_index(int64_t i, int64_t size, TextureWrap wrap) {
  switch (wrap) {
    case TextureWrap::kRepeat:
      return ((i % size) + size) % size;
    case TextureWrap::kMirroredRepeat: {
      const int64_t m = ((i % (2 * size)) + 2 * size) % (2 * size);
      return m < size ? m : 2 * size - 1 - m;
    }
    case TextureWrap::kClampToEdge:
      return std::clamp<int64_t>(i, 0, size - 1);
  }
  return 0;
}

}  // namespace

std::array<float, 3> sample_texture(const BaseColorTexture& texture, double u, double v) {
  const RgbImage& image = *texture.image;
  const double x = wrap_coordinate(u, texture.wrap_u) * image.width - 0.5;
  const double y = wrap_coordinate(v, texture.wrap_v) * image.height - 0.5;
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double fx = x - x0, fy = y - y0;
  int64_t columns[2], rows[2];
  for (int k = 0; k < 2; ++k) {
    columns[k] = texel_index(int64_t(x0) + k, image.width, texture.wrap_u);
    rows[k] = texel_index(int64_t(y0) + k, image.height, texture.wrap_v);
  }
  std::array<float, 3> out{0, 0, 0};
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const double w = (i ? fx : 1 - fx) * (j ? fy : 1 - fy);
      const auto& texel = image.at(int(columns[i]), int(rows[j]));
      for (size_t c = 0; c < 3; ++c) out[c] += float(w * srgb_to_linear(texel[c]));
    }
  return out;
}

std::array<float, 3> surface_color(const Mesh& mesh, uint32_t face, const std::array<double, 3>& b) {
  const uint32_t* corner = &mesh.indices[3 * size_t(face)];
  std::array<float, 3> rgb{1, 1, 1};
  if (!mesh.colors.empty()) {
    for (size_t c = 0; c < 3; ++c) {
      double sum = 0;
      for (size_t k = 0; k < 3; ++k) sum += b[k] * srgb_to_linear(mesh.colors[3 * size_t(corner[k]) + c]);
      rgb[c] = float(sum);
    }
  }
  const MeshTextures& t = mesh.textures;
  if (!t.empty() && t.vertex_texture[corner[0]] != MeshTextures::kNone) {
    double uv[2] = {0, 0};
    for (size_t k = 0; k < 3; ++k)
      for (size_t a = 0; a < 2; ++a) uv[a] += b[k] * double(t.uvs[2 * size_t(corner[k]) + a]);
    const std::array<float, 3> texel = sample_texture(t.textures[t.vertex_texture[corner[0]]], uv[0], uv[1]);
    for (size_t c = 0; c < 3; ++c) rgb[c] *= texel[c];
  }
  return rgb;
}

Status transfer_colors(const Mesh& input, const Mesh& output, std::vector<uint8_t>* colors) {
  assert(has_appearance(input));
  const ClosestPointTree tree(input);
  if (tree.empty()) return invalid_argument("colors: every face of the input is degenerate (collinear corners)");
  const size_t nv = output.vertex_count();
  colors->assign(3 * nv, 0);
  // The output's vertices in the input's frame (mesh.h), in double.
  const bool same_frame = output.origin == input.origin && output.scale == input.scale;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      Vec3d p = load3d(output.positions.data(), v);
      if (!same_frame) {
        double x[3];
        for (int a = 0; a < 3; ++a) x[a] = (output.absolute(v, a) - input.origin[size_t(a)]) / input.scale;
        p = {x[0], x[1], x[2]};
      }
      const ClosestPointTree::Hit hit = tree.closest(p);
      const std::array<float, 3> rgb = surface_color(input, hit.face, hit.barycentric);
      for (size_t c = 0; c < 3; ++c) (*colors)[3 * v + c] = srgb_from_linear(rgb[c]);
    }
  });
  return Status::Ok();
}

}  // namespace vpr
