// Connected parts of a mesh (faces joined by shared vertices), and dropping
// the small ones on request (`--drop-parts-smaller-than`; issue 19: never by
// default, every part of the input is in the output unless the user says so).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh.h"

namespace vpr {

// Part id of each face (#F, ids 0..parts-1 in order of first face); `parts`
// gets the count. Faces with an out-of-range index belong to no part (UINT32_MAX).
std::vector<uint32_t> face_parts(const Mesh& mesh, size_t* parts);

// Removes the faces of every part whose bounding-box diagonal is below
// `min_fraction` of the whole mesh's; vertices stay (unreferenced ones are
// dropped where the pipeline prepares its input). Returns the parts removed.
// min_fraction <= 0 keeps everything; the largest part always stays.
size_t drop_small_parts(Mesh* mesh, double min_fraction);

}  // namespace vpr
