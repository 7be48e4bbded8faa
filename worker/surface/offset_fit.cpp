#include "surface/offset_fit.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>

#include "core/step_marks.h"
#include "core/vec3.h"
#include "surface/offset_match.h"
#include "surface/offset_system.h"

namespace vpr {
namespace {

using Eigen::Vector3d;

Vector3d eig(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

// The fit with its samples on the device (options.device_samples) or here.
Status fit(const Mesh& surface, const std::vector<uint32_t>& label, const std::vector<uint32_t>& cell_of_vertex,
           const std::vector<char>& held, const OffsetFitOptions& options, bool on_device, Mesh* mesh,
           OffsetFitStats* stats) {
  OffsetFitStats st;
  const size_t nv = mesh->vertex_count(), nf = mesh->face_count();
  if (label.size() != surface.vertex_count() || cell_of_vertex.size() != nv || held.size() != nv)
    return invalid_argument(
        "offset fit: one label per surface vertex, one cell and one flag per output vertex expected");
  if (!options.enabled || nv == 0 || nf == 0) {
    if (stats) *stats = st;
    return Status::Ok();
  }
  auto pos = [&](uint32_t v) { return eig(load3d(mesh->positions.data(), v)); };
  StepMarks marks(on_device ? "fit_device" : "fit_host");

  // Faces around each output vertex (CSR), and each cell's output vertices
  // (the manifold repair may split a cell's vertex in two).
  std::vector<uint32_t> face_start(nv + 1, 0), faces_of(3 * nf);
  for (uint32_t v : mesh->indices) ++face_start[v + 1];
  for (size_t v = 0; v < nv; ++v) face_start[v + 1] += face_start[v];
  {
    std::vector<uint32_t> fill(face_start.begin(), face_start.end() - 1);
    for (size_t f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) faces_of[fill[mesh->indices[3 * f + c]]++] = uint32_t(f);
  }
  uint32_t cells = 0;
  for (uint32_t c : cell_of_vertex) cells = std::max(cells, c + 1);
  std::vector<uint32_t> vert_start(cells + 1, 0), verts_of(nv);
  for (uint32_t c : cell_of_vertex) ++vert_start[c + 1];
  for (uint32_t c = 0; c < cells; ++c) vert_start[c + 1] += vert_start[c];
  {
    std::vector<uint32_t> fill(vert_start.begin(), vert_start.end() - 1);
    for (uint32_t v = 0; v < nv; ++v) verts_of[fill[cell_of_vertex[v]]++] = v;
  }

  // Vertex normals (area-weighted face normals) and the bound on each offset.
  std::vector<Vector3d> normal(nv, Vector3d::Zero());
  std::vector<double> edge_sum(nv, 0.0), edge_count(nv, 0.0);
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* t = &mesh->indices[3 * f];
    const Vector3d a = pos(t[0]), b = pos(t[1]), c = pos(t[2]);
    const Vector3d n = (b - a).cross(c - a);  // twice the area times the unit normal
    for (int k = 0; k < 3; ++k) {
      normal[t[k]] += n;
      const double len = (pos(t[(k + 1) % 3]) - pos(t[k])).norm();
      edge_sum[t[k]] += len, edge_count[t[k]] += 1;
      edge_sum[t[(k + 1) % 3]] += len, edge_count[t[(k + 1) % 3]] += 1;
    }
  }
  std::vector<int64_t> unknown(nv, -1);
  std::vector<double> bound(nv, 0.0);
  int64_t free_count = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    const double len = normal[v].norm();
    if (held[v] || !(len > 0) || edge_count[v] == 0) {
      ++st.held_vertices;
      continue;
    }
    normal[v] /= len;
    bound[v] = options.max_offset_per_edge * edge_sum[v] / edge_count[v];
    unknown[v] = free_count++;
  }
  st.free_vertices = size_t(free_count);
  marks.mark("rows_normals");

  // The samples, matched to the output's triangles and summed per triangle
  // (offset_match.h), on the device or here.
  const OffsetSamples samples{&surface, &label, cells, mesh, &vert_start, &verts_of, &face_start, &faces_of};
  std::unique_ptr<OffsetSampleSet> sample_set;
  if (on_device) {
    VPR_ASSIGN_OR_RETURN(sample_set, options.device_samples(samples));
  } else {
    sample_set = cpu::offset_sample_set(samples);
  }
  marks.mark("sample_set");
  auto rms = [](double wr2, double w) { return w > 0 ? std::sqrt(wr2 / w) : 0.0; };

  std::vector<Vector3d> start(nv);
  for (uint32_t v = 0; v < nv; ++v) start[v] = pos(v);
  std::vector<double> offset(nv, 0.0);
  // The last round's samples, for the RMS after the fit: its triangles' sums
  // and sum w r^2, sum w; each triangle's N_k . n_t (0 for a held corner);
  // the offsets the samples were matched at.
  std::vector<OffsetFaceSums> last_sums;
  double last_wr2 = 0, last_w = 0;
  std::vector<std::array<double, 3>> last_along(nf, {0, 0, 0});
  std::vector<double> last_offset(nv, 0.0);
  for (int round = 0; round < options.rounds && free_count > 0; ++round) {
    // Normal equations of the residuals, in the increment e of the
    // offsets: (A^T W A + lambda D) e = A^T W r - lambda D d.
    // The samples on one output triangle share its normal, so their terms
    // are summed per triangle first (sum w b b^T, sum w b r, sum w b; in the
    // samples' order): the system then has nine entries per triangle rather
    // than per sample.
    std::vector<OffsetFaceSums> per_face;
    double wr2 = 0, w = 0;
    VPR_RETURN_IF_ERROR(sample_set->match(&per_face, &wr2, &w));
    marks.mark("match");
    st.device_rounds += on_device;
    last_offset = offset;
    last_wr2 = wr2, last_w = w;
    if (round == 0) st.rms_before = rms(wr2, w);
    // The triangles' normals and N_k . n_t, in parallel; then the system
    // row by row and its conjugate gradients (offset_system.h: the bits of
    // Eigen's triplets and solver). The system is a mass matrix of the
    // output's triangles plus a small diagonal, whose diagonal scaling leaves
    // it well conditioned: 18-19 iterations on the shared models (on the
    // H200, igea at 10,000: 5.4 ms serial against 24.6 for the sparse
    // Cholesky factorization, which solves it should they not converge).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t g = r.begin(); g != r.end(); ++g) {
        if (!face_has_samples(per_face[g])) continue;
        const uint32_t* u = &mesh->indices[3 * g];
        const Vector3d n = (pos(u[1]) - pos(u[0])).cross(pos(u[2]) - pos(u[0])).normalized();
        for (int k = 0; k < 3; ++k) last_along[g][k] = unknown[u[k]] >= 0 ? normal[u[k]].dot(n) : 0.0;
      }
    });
    OffsetSystemInput system_input;
    system_input.indices = &mesh->indices;
    system_input.face_start = &face_start;
    system_input.faces_of = &faces_of;
    system_input.unknown = &unknown;
    system_input.per_face = &per_face;
    system_input.along = &last_along;
    system_input.offset = &offset;
    system_input.regularization = options.regularization;
    system_input.free_count = free_count;
    const OffsetSystem system = offset_system(system_input);
    last_sums = std::move(per_face);
    marks.mark("system");
    Eigen::VectorXd e;
    const bool solved = solve_offset_system(system, &e);
    marks.mark("solve");
    if (!solved) break;  // keep what the earlier rounds did
    st.clamped = 0;
    std::vector<double> next = offset;
    for (uint32_t v = 0; v < nv; ++v) {
      const int64_t i = unknown[v];
      if (i < 0 || !std::isfinite(e[i])) continue;
      next[v] = offset[v] + e[i];
      if (std::abs(next[v]) > bound[v]) {
        next[v] = std::copysign(bound[v], next[v]);
        ++st.clamped;
      }
    }
    // Apply; an offset that turns one of its triangles by more than a right
    // angle (a fold on a thin or tightly curved part) is dropped, until none does.
    auto place = [&](uint32_t v) {
      const Vector3d p = start[v] + next[v] * normal[v];
      for (int k = 0; k < 3; ++k) mesh->positions[3 * v + k] = float(p[k]);
    };
    std::vector<Vector3d> face_normal(nf);
    for (size_t f = 0; f < nf; ++f) {
      const uint32_t* t = &mesh->indices[3 * f];
      face_normal[f] = (start[t[1]] - start[t[0]]).cross(start[t[2]] - start[t[0]]);
    }
    for (uint32_t v = 0; v < nv; ++v) place(v);
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &mesh->indices[3 * f];
        if (!(face_normal[f].squaredNorm() > 0)) continue;  // degenerate before: nothing to turn
        const Vector3d n = (pos(t[1]) - pos(t[0])).cross(pos(t[2]) - pos(t[0]));
        if (n.dot(face_normal[f]) > 0) continue;
        for (int k = 0; k < 3; ++k)
          if (unknown[t[k]] >= 0 && next[t[k]] != 0) {
            next[t[k]] = 0;
            place(t[k]);
            ++st.dropped;
            changed = true;
          }
      }
    }
    offset = next;
    marks.mark("place");
  }
  // The residuals of the last round's samples under the offsets kept (the
  // linear model above: no second search for the nearest triangles), from
  // its triangles' sums (offset_wr2_change).
  if (!last_sums.empty()) {
    double wr2 = last_wr2;
    for (size_t g = 0; g < nf; ++g) {
      const uint32_t* u = &mesh->indices[3 * g];
      std::array<double, 3> a;
      for (int k = 0; k < 3; ++k) a[k] = last_along[g][k] * (offset[u[k]] - last_offset[u[k]]);
      wr2 += offset_wr2_change(last_sums[g], a);
    }
    st.rms_after = rms(std::max(wr2, 0.0), last_w);  // rounding could leave a tiny negative
  }
  if (stats) *stats = st;
  return Status::Ok();
}

}  // namespace

Status fit_offsets(const Mesh& surface, const std::vector<uint32_t>& label, const std::vector<uint32_t>& cell_of_vertex,
                   const std::vector<char>& held, const OffsetFitOptions& options, Mesh* mesh, OffsetFitStats* stats) {
  std::string device_failure;
  if (options.device_samples) {
    // A device that fails (out of its budget, say) leaves the host to fit
    // from the same start: the same bits.
    const std::vector<float> positions = mesh->positions;
    const Status on_device = fit(surface, label, cell_of_vertex, held, options, true, mesh, stats);
    if (on_device.ok()) return on_device;
    device_failure = on_device.message();
    mesh->positions = positions;
  }
  VPR_RETURN_IF_ERROR(fit(surface, label, cell_of_vertex, held, options, false, mesh, stats));
  if (stats) stats->device_failure = device_failure;
  return Status::Ok();
}

}  // namespace vpr
