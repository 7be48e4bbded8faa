// Helpers shared by the peer implementations (not part of the peers API).
#pragma once

#include <chrono>
#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr::peers {

using Clock = std::chrono::steady_clock;
inline double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// The faces `indices` (#F x 3 into positions, #V x 3) with only the vertices
// they reference, renumbered in order of first use.
Mesh compact(const std::vector<float>& positions, const std::vector<uint32_t>& indices);

// validate_mesh and a positive target, with the method's name in the message.
Status check_input(const Mesh& input, uint32_t target_vertices, const char* method);

}  // namespace vpr::peers
