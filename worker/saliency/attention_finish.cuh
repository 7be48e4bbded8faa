// The attention field's host part (finish_attention_field: the cue maps over
// their medians, the raw cue and its rank normalization) on the device, for
// the GPU twin: the same double arithmetic in the same order (compiled
// without FMA contraction), the same medians and a stable sort with the same
// tie rule, so the field has the CPU twin's bits. On the host this work
// competes for cores with what runs beside the front half (the refinement
// made ahead); on the device it is a few launches.
#pragma once

#include <cstdint>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "saliency/attention_field.h"

namespace vpr::cuda {

// sorted, order: the vertex grid's entries on the device (VertexGrid::sorted,
// ::order). coarse: #V grid means in vertex order; density: #V weighted feature
// counts in vertex order, or null without the image cue (both on the device).
// fine, visibility: host arrays in vertex order (visibility may be null).
// importance: #V values, as finish_attention_field makes them.
Status finish_attention_on_device(const float* sorted, const uint32_t* order, const float* coarse,
                                  const float* density, const std::vector<double>& fine, const float* visibility,
                                  size_t vertex_count, const AttentionFieldOptions& options,
                                  std::vector<float>* importance, const ExecContext& ctx);

}  // namespace vpr::cuda
