// The CVT's sweeps (surface_cvt.h) in colour rounds, the form that runs on a
// GPU: the elements are coloured so that no two neighbours share a colour
// (Jones and Plassmann 1993), and a round moves the elements of one colour at
// once, each to the neighbouring cell whose move lowers E most and keeps both
// cells disks (cvt_sweep_kernels.h). Elements of one colour are never
// neighbours, so each one's disk tests read labels no other move of the round
// changes; their gains read the cells' sums as the round began. A sweep is
// one round per colour, and the sweeps stop as surface_cvt's do: when one
// lowers E by less than `tolerance` (relative) or moves nothing.
//
// surface_cvt runs these before its own sweeps when CvtOptions::device_sweeps
// is set (the pipeline sets it to the GPU twin): they do the bulk of the
// moves, and surface_cvt's sweeps finish from there with its every rule
// (the boundary loops' among them, of which the rounds keep a stricter
// form). The CPU
// reference here gives the GPU twin's labels bit for bit, on any thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "core/vec3.h"
#include "surface/mesh_edges.h"

namespace vpr {

struct CvtSweepInput {
  const MeshEdges* edges = nullptr;
  // Per element: position, the normal half of its position in R^6 (zero:
  // isotropic), unit normal, mass, and whether it lies on a boundary loop
  // (an edge with one face): such elements move only along their loop
  // (cvt_sweep_kernels.h, cvt_best_move).
  const Vec3d* x = nullptr;
  const Vec3d* y = nullptr;
  const Vec3d* normal = nullptr;
  const double* mass = nullptr;
  const char* on_loop = nullptr;
  uint32_t cells = 0;
  double constant = 0;  // sum m |(x, a n)|^2: E's part no move changes
  double tolerance = 1e-4;
  int max_sweeps = 300;
  // When set, called once the inputs are on the device: the host's threads,
  // which the staged upload copies with, are free for other work from then
  // on (the pipeline starts the dual's facts there). Changes no result.
  std::function<void()> uploaded;
};

struct CvtSweepOutput {
  int sweeps = 0;
  bool converged = false;
  size_t moves = 0;
  uint32_t colours = 0;
  std::vector<double> energy;  // E after each sweep
};

// label: per element, its cell in [0, cells) or kNoCell (no mass, no cell);
// updated in place.
using CvtDeviceSweeps = std::function<Status(const CvtSweepInput&, std::vector<uint32_t>* label, CvtSweepOutput*)>;

namespace cpu {
// The elements' colours (no two neighbours share one; 64: every colour taken
// around it, never moved by the colour rounds) and how many there are below 64.
StatusOr<std::vector<uint8_t>> cvt_colouring(const MeshEdges& edges, uint32_t* colours);
Status cvt_colour_sweeps(const CvtSweepInput& input, std::vector<uint32_t>* label, CvtSweepOutput* output);
}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (cvt_sweeps.cu): the same labels.
namespace cuda {
Status cvt_colour_sweeps(const CvtSweepInput& input, std::vector<uint32_t>* label, CvtSweepOutput* output,
                         const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
