// CPU reference of the CVT's colour sweeps (cvt_sweeps.h): the GPU twin's
// steps one for one, with the arithmetic of cvt_sweep_kernels.h.
#include "surface/cvt_sweeps.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "surface/cvt_sweep_kernels.h"
#include "surface/cvt_sweeps_setup.h"

namespace vpr::cpu {

StatusOr<std::vector<uint8_t>> cvt_colouring(const MeshEdges& adj, uint32_t* colours) {
  const uint32_t nv = uint32_t(adj.vertex_count());
  const uint32_t* offset = adj.offset.data();
  const uint32_t* neighbor = adj.neighbor.data();
  // Jones-Plassmann rounds, each reading only the rounds before.
  std::vector<uint8_t> colour(nv, kUncoloured), next(nv);
  std::vector<uint32_t> round_of(nv, UINT32_MAX);
  uint32_t left = nv;
  *colours = 0;
  for (uint32_t round = 0; left > 0; ++round) {
    if (round >= kCvtMaxColourRounds) return internal_error("CVT colour sweeps: colouring did not finish");
    tbb::parallel_for(uint32_t(0), nv, [&](uint32_t v) {
      next[v] = round_of[v] == UINT32_MAX
                    ? cvt_colour_in_round(offset, neighbor, colour.data(), round_of.data(), round, v)
                    : kUncoloured;
    });
    for (uint32_t v = 0; v < nv; ++v)
      if (next[v] != kUncoloured) {
        colour[v] = next[v];
        round_of[v] = round;
        --left;
        if (next[v] < 64) *colours = std::max(*colours, uint32_t(next[v]) + 1);
      }
  }
  return colour;
}

Status cvt_colour_sweeps(const CvtSweepInput& in, std::vector<uint32_t>* label_io, CvtSweepOutput* out) {
  VPR_RETURN_IF_ERROR(check_cvt_sweep_input(in, *label_io));
  *out = CvtSweepOutput{};
  const MeshEdges& adj = *in.edges;
  const uint32_t nv = uint32_t(adj.vertex_count());
  const uint32_t* offset = adj.offset.data();
  const uint32_t* neighbor = adj.neighbor.data();
  const uint32_t* faces = adj.faces.data();
  std::vector<uint32_t>& label = *label_io;
  if (nv == 0 || in.cells == 0) return Status::Ok();
  const CvtFixedScale scale = cvt_fixed_scale(in, label);

  uint32_t colours = 0;
  VPR_ASSIGN_OR_RETURN(const std::vector<uint8_t> colour, cvt_colouring(adj, &colours));
  out->colours = colours;

  std::vector<long long> sums(size_t(in.cells) * kCvtSums, 0);
  std::vector<uint32_t> size(in.cells, 0);
  std::vector<long long> contribution(size_t(nv) * kCvtSums);
  for (uint32_t v = 0; v < nv; ++v) {
    long long* c = &contribution[size_t(v) * kCvtSums];
    cvt_contribution(in.mass[v], in.x[v], in.y[v], in.normal[v], scale, c);
    if (label[v] == kNoCell) continue;
    for (int k = 0; k < kCvtSums; ++k) sums[size_t(label[v]) * kCvtSums + k] += c[k];
    ++size[label[v]];
  }
  auto energy = [&]() {
    double lane[kCvtEnergyLanes] = {};
    for (uint32_t c = 0; c < in.cells; ++c)
      lane[c % kCvtEnergyLanes] += cvt_cell_energy(cvt_sums(&sums[size_t(c) * kCvtSums], scale));
    for (uint32_t half = kCvtEnergyLanes / 2; half > 0; half /= 2)
      for (uint32_t i = 0; i < half; ++i) lane[i] += lane[i + half];
    return in.constant + lane[0];
  };

  // The elements of each colour, ascending (the GPU twin's lists).
  std::vector<uint32_t> colour_start(kCvtColourSlots + 1, 0), by_colour(nv);
  for (uint32_t v = 0; v < nv; ++v) ++colour_start[colour[v] + 1];
  for (uint32_t k = 0; k < kCvtColourSlots; ++k) colour_start[k + 1] += colour_start[k];
  {
    std::vector<uint32_t> fill(colour_start.begin(), colour_start.end() - 1);
    for (uint32_t v = 0; v < nv; ++v) by_colour[fill[colour[v]]++] = v;
  }
  std::vector<uint32_t> move(nv, kNoCell);  // per entry of a colour's list
  double previous = energy();
  for (int sweep = 0; sweep < in.max_sweeps; ++sweep) {
    const double threshold = 1e-18 * std::abs(previous);
    size_t moved = 0;
    for (uint32_t k = 0; k < colours; ++k) {
      const uint32_t* list = by_colour.data() + colour_start[k];
      const uint32_t count = colour_start[k + 1] - colour_start[k];
      tbb::parallel_for(uint32_t(0), count, [&](uint32_t i) {
        const uint32_t v = list[i];
        move[i] = kNoCell;
        if (!cvt_on_cell_edge(offset, neighbor, label.data(), v)) return;
        const CvtSums e = cvt_sums(&contribution[size_t(v) * kCvtSums], scale);
        move[i] = cvt_best_move(offset, neighbor, faces, label.data(), sums.data(), size.data(), scale, e, in.normal[v],
                                in.on_loop[v] != 0, v, threshold);
      });
      for (uint32_t i = 0; i < count; ++i) {
        if (move[i] == kNoCell) continue;
        const uint32_t v = list[i];
        const long long* c = &contribution[size_t(v) * kCvtSums];
        for (int j = 0; j < kCvtSums; ++j) {
          sums[size_t(label[v]) * kCvtSums + j] -= c[j];
          sums[size_t(move[i]) * kCvtSums + j] += c[j];
        }
        --size[label[v]];
        ++size[move[i]];
        label[v] = move[i];
        ++moved;
      }
    }
    const double now = energy();
    if (cvt_sweeps_stop(previous, now, moved, in.tolerance, out)) break;
    previous = now;
  }
  return Status::Ok();
}

}  // namespace vpr::cpu
