#include "contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <flann/flann.hpp>

#include "io/mesh_io.h"
#include "io/png_io.h"
#include "core/vec3.h"

namespace vpr::cli {

RgbImage gray_to_rgb(const GrayImage& gray) {
  RgbImage out{gray.width, gray.height, std::vector<uint8_t>(3 * gray.pixels.size())};
  for (size_t i = 0; i < gray.pixels.size(); ++i)
    out.rgb[3 * i] = out.rgb[3 * i + 1] = out.rgb[3 * i + 2] = gray.pixels[i];
  return out;
}

StatusOr<RgbImage> heat_map(const Snapshot& snapshot, const View& view, const Mesh& mesh,
                            const std::vector<float>& importance) {
  if (importance.size() != mesh.vertex_count())
    return invalid_argument("heat map: " + std::to_string(importance.size()) + " importance values for " +
                            std::to_string(mesh.vertex_count()) + " vertices");
  const int w = snapshot.gray.width, h = snapshot.gray.height;
  constexpr int kNeighbours = 4;
  const int k = int(std::min<size_t>(kNeighbours, mesh.vertex_count()));
  // Surface points of the covered pixels (unproject.cpp's pixel-centre convention).
  std::vector<float> points;
  std::vector<size_t> pixel;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!snapshot.coverage.at(x, y)) continue;
      const double ndc_x = 2.0 * (x + 0.5) / w - 1.0, ndc_y = 2.0 * (double(h - y) - 0.5) / h - 1.0;
      const Vec3d p = transform_point(view.inv_view_proj, {ndc_x, ndc_y, 2.0 * double(snapshot.depth.at(x, y)) - 1.0});
      points.insert(points.end(), {float(p.x), float(p.y), float(p.z)});
      pixel.push_back(size_t(y) * w + size_t(x));
    }
  RgbImage out{w, h, std::vector<uint8_t>(size_t(3) * w * h, 0)};
  if (pixel.empty()) return out;
  const flann::Matrix<float> data(const_cast<float*>(mesh.positions.data()), mesh.vertex_count(), 3);
  flann::KDTreeSingleIndex<flann::L2_Simple<float>> tree(data, flann::KDTreeSingleIndexParams(16));
  tree.buildIndex();
  const flann::Matrix<float> queries(points.data(), pixel.size(), 3);
  std::vector<int> idx(pixel.size() * size_t(k));
  std::vector<float> dist(pixel.size() * size_t(k));
  flann::Matrix<int> indices(idx.data(), pixel.size(), size_t(k));
  flann::Matrix<float> dists(dist.data(), pixel.size(), size_t(k));
  flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
  params.cores = 0;
  tree.knnSearch(queries, indices, dists, size_t(k), params);
  for (size_t i = 0; i < pixel.size(); ++i) {
    double sum = 0, weight = 0;
    for (int j = 0; j < k; ++j) {
      const double d2 = dist[i * size_t(k) + size_t(j)];
      const float value = importance[size_t(idx[i * size_t(k) + size_t(j)])];
      if (d2 <= 0) {  // on a vertex
        sum = value;
        weight = 1;
        break;
      }
      sum += value / d2;  // squared distances: a smooth, local blend
      weight += 1 / d2;
    }
    uint8_t rgb[3];
    saliency_color(float(sum / weight), rgb);
    const float shade = snapshot.gray.pixels[pixel[i]] / 255.f;
    for (int c = 0; c < 3; ++c) out.rgb[3 * pixel[i] + size_t(c)] = uint8_t(std::lround(rgb[c] * shade));
  }
  return out;
}

Status write_contact_sheet(const std::string& path, const std::vector<std::vector<RgbImage>>& tiles) {
  constexpr int kGutter = 2;
  constexpr uint8_t kGutterGray = 64;
  if (tiles.empty() || tiles[0].empty()) return invalid_argument("contact sheet without tiles");
  const int tw = tiles[0][0].width, th = tiles[0][0].height;
  size_t columns = 0;
  for (const auto& row : tiles) {
    columns = std::max(columns, row.size());
    for (const RgbImage& t : row)
      if (t.width != tw || t.height != th) return invalid_argument("contact sheet tiles differ in size");
  }
  const int w = int(columns) * (tw + kGutter) + kGutter, h = int(tiles.size()) * (th + kGutter) + kGutter;
  std::vector<uint8_t> rgb(size_t(3) * w * h, kGutterGray);
  for (size_t r = 0; r < tiles.size(); ++r)
    for (size_t c = 0; c < tiles[r].size(); ++c) {
      const int x0 = kGutter + int(c) * (tw + kGutter), y0 = kGutter + int(r) * (th + kGutter);
      for (int y = 0; y < th; ++y)
        std::copy_n(&tiles[r][c].rgb[size_t(3) * y * tw], size_t(3) * tw, &rgb[3 * (size_t(y0 + y) * w + x0)]);
    }
  return write_rgb_png(path, w, h, rgb.data());
}

}  // namespace vpr::cli
