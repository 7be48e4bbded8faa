// What a person wants to look at when a result surprises them: per view, the
// snapshot, the inner and silhouette feature images and the skeleton as PNG,
// and the saliency points as PLY.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "render/snapshot.h"
#include "render/views.h"
#include "saliency/image_saliency.h"

namespace vpr {

Status write_view_debug(const std::string& dir, const View& view, const Snapshot& snapshot,
                        const FeatureImages& features, const std::vector<float>& view_points);

// One picture for the README: the snapshot with inner features in red, thin
// silhouette features in yellow and the skeleton in cyan.
Status write_feature_overlay(const std::string& path, const Snapshot& snapshot, const FeatureImages& features);

}  // namespace vpr
