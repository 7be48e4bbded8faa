// PNG contact sheets for `vpremesh compare`: meshes side by side, rendered
// from the same cameras, and the saliency field as a heat map on the input.
#pragma once

#include <string>
#include <vector>

#include "core/mesh.h"
#include "render/snapshot.h"
#include "core/status.h"
#include "render/views.h"

namespace vpr::cli {

struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // width * height * 3, row 0 at the top
};

// The snapshot's shading times the saliency color ramp (saliency_color) of the
// per-vertex importance at each pixel's surface point: the pixel is unprojected
// through its depth, and the importance is the inverse-distance average of the
// 4 nearest vertices (exact at a vertex; on a dense input, a per-pixel
// interpolation). importance: #V values. Background stays black.
StatusOr<RgbImage> heat_map(const Snapshot& snapshot, const View& view, const Mesh& mesh,
                            const std::vector<float>& importance);

RgbImage gray_to_rgb(const GrayImage& gray);

// Tiles laid out row by row (tiles[row][column], all the same size), with a
// 2-pixel dark gray gutter.
Status write_contact_sheet(const std::string& path, const std::vector<std::vector<RgbImage>>& tiles);

}  // namespace vpr::cli
