// Elements in the order of a space-filling curve through their positions
// (the Z-order, or Morton, curve: each position's cell of a 2^21 grid over the
// box, its coordinates' bits interleaved). Consecutive runs of the order are
// compact pieces of space, so points taken at even steps of a quantity
// accumulated along it (stratified sampling) spread over the surface like
// blue noise rather than clumping as independent draws do: the CVT's seeds
// (surface_cvt.cpp).
#pragma once

#include <cstdint>
#include <vector>

#include "core/vec3.h"

namespace vpr {

// `elements` (indices into x) sorted by the Morton code of their position in
// the box [lo, lo + extent]^3; ties (one grid cell) by index, so the order is
// the same on any thread count.
std::vector<uint32_t> morton_order(const std::vector<Vec3d>& x, const std::vector<uint32_t>& elements, Vec3d lo,
                                   double extent);

}  // namespace vpr
