#include "surface/offset_fit.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <array>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/vec3.h"

namespace vpr {
namespace {

using Eigen::Vector3d;

// cos(30 degrees): a sample is fitted only by a triangle within 30 degrees of
// its own input face's plane.
constexpr double kSameSide = 0.8660254037844386;

Vector3d eig(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

// The closest point of triangle abc to p, as barycentric weights of a, b, c
// (Ericson, Real-Time Collision Detection, 5.1.5).
Vector3d closest_barycentric(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  return {1 - (vb + vc) * denom, vb * denom, vc * denom};
}

// One sample of the input matched to the output: face, barycentrics of the
// nearest point, the signed distance along the face's normal, and weight.
struct Match {
  int64_t face = -1;
  Vector3d bary = Vector3d::Zero();
  Vector3d normal = Vector3d::Zero();
  double residual = 0;
  double weight = 0;
};

}  // namespace

Status fit_offsets(const Mesh& surface, const std::vector<uint32_t>& label, const std::vector<uint32_t>& cell_of_vertex,
                   const std::vector<char>& held, const OffsetFitOptions& options, Mesh* mesh, OffsetFitStats* stats) {
  OffsetFitStats st;
  const size_t nv = mesh->vertex_count(), nf = mesh->face_count(), sf = surface.face_count();
  if (label.size() != surface.vertex_count() || cell_of_vertex.size() != nv || held.size() != nv)
    return invalid_argument("offset fit: one label per surface vertex, one cell and one flag per output vertex expected");
  if (!options.enabled || nv == 0 || nf == 0) {
    if (stats) *stats = st;
    return Status::Ok();
  }
  auto pos = [&](uint32_t v) { return eig(load3d(mesh->positions.data(), v)); };

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

  // Samples: one per input face, at its centroid, weighted by its area,
  // belonging to the cell of its first labelled corner (the refined faces are
  // a sixteenth of a cell: the one-ring searched below covers the cell's
  // neighbourhood either way).
  std::vector<Vector3d> unit_normal(nf);  // the output's triangles' unit normals (zero: degenerate)
  auto match_all = [&](std::vector<Match>* out) {
    out->assign(sf, Match{});
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 1024), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t g = range.begin(); g != range.end(); ++g) {
        const uint32_t* u = &mesh->indices[3 * g];
        const Vector3d n = (pos(u[1]) - pos(u[0])).cross(pos(u[2]) - pos(u[0]));
        unit_normal[g] = n.squaredNorm() > 0 ? n.normalized() : Vector3d::Zero();
      }
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, sf, 1024), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t f = range.begin(); f != range.end(); ++f) {
        const uint32_t* t = &surface.indices[3 * f];
        const Vector3d a = eig(load3d(surface.positions.data(), t[0])), b = eig(load3d(surface.positions.data(), t[1])),
                       c = eig(load3d(surface.positions.data(), t[2]));
        const Vector3d cr = (b - a).cross(c - a);
        const double area = 0.5 * cr.norm();
        if (!(area > 0)) continue;
        const Vector3d input_normal = cr.normalized();
        uint32_t cell = UINT32_MAX;
        for (int k = 0; k < 3 && cell == UINT32_MAX; ++k) cell = label[t[k]];
        if (cell == UINT32_MAX || cell >= cells) continue;
        const Vector3d p = (a + b + c) / 3;
        Match best;
        double best_d = INFINITY;
        for (uint32_t i = vert_start[cell]; i < vert_start[cell + 1]; ++i) {
          const uint32_t v = verts_of[i];
          for (uint32_t j = face_start[v]; j < face_start[v + 1]; ++j) {
            const uint32_t g = faces_of[j];
            const Vector3d& n = unit_normal[g];
            // Only triangles parallel to the sample's face, not one that
            // cuts across a crease (its normal between the two sides').
            // Either winding: scans come with faces wound both ways.
            if (std::abs(n.dot(input_normal)) < kSameSide) continue;  // a degenerate one too (n = 0)
            const uint32_t* u = &mesh->indices[3 * g];
            const Vector3d x = pos(u[0]), y = pos(u[1]), z = pos(u[2]);
            const Vector3d bc = closest_barycentric(p, x, y, z);
            const double d = (p - (bc[0] * x + bc[1] * y + bc[2] * z)).squaredNorm();
            if (d < best_d) {
              best_d = d;
              best.face = g;
              best.bary = bc;
              best.normal = n;
              best.residual = best.normal.dot(p - x);
            }
          }
        }
        if (best.face < 0) continue;
        best.weight = area;
        (*out)[f] = best;
      }
    });
  };
  auto weighted_rms = [](const std::vector<Match>& m) {
    double sum = 0, w = 0;
    for (const Match& x : m) sum += x.weight * x.residual * x.residual, w += x.weight;
    return w > 0 ? std::sqrt(sum / w) : 0.0;
  };

  std::vector<Vector3d> start(nv);
  for (uint32_t v = 0; v < nv; ++v) start[v] = pos(v);
  std::vector<double> offset(nv, 0.0);
  std::vector<Match> match;
  std::vector<double> last_offset(nv, 0.0);  // the offsets the last round's samples were matched at
  for (int round = 0; round < options.rounds && free_count > 0; ++round) {
    match_all(&match);
    last_offset = offset;
    if (round == 0) st.rms_before = weighted_rms(match);
    // Normal equations of the residuals above, in the increment e of the
    // offsets: (A^T W A + lambda D) e = A^T W r - lambda D d.
    // The samples on one output triangle share its normal, so their terms
    // are summed per triangle first (sum w b b^T, sum w b r, sum w b; in the
    // samples' order): the system then has nine entries per triangle rather
    // than per sample.
    std::vector<std::array<double, 15>> per_face(nf, std::array<double, 15>{});
    for (const Match& m : match) {
      if (m.face < 0) continue;
      std::array<double, 15>& s = per_face[size_t(m.face)];
      for (int k = 0; k < 3; ++k) {
        const double wb = m.weight * m.bary[k];
        for (int l = 0; l < 3; ++l) s[3 * k + l] += wb * m.bary[l];
        s[9 + k] += wb * m.residual;
        s[12 + k] += wb;
      }
    }
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(9 * nf + nv);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(free_count), mass = Eigen::VectorXd::Zero(free_count);
    for (size_t g = 0; g < nf; ++g) {
      const std::array<double, 15>& s = per_face[g];
      if (!(s[12] + s[13] + s[14] > 0)) continue;
      const uint32_t* u = &mesh->indices[3 * g];
      const Vector3d n = (pos(u[1]) - pos(u[0])).cross(pos(u[2]) - pos(u[0])).normalized();
      double along[3];  // N_k . n_t
      for (int k = 0; k < 3; ++k) along[k] = unknown[u[k]] >= 0 ? normal[u[k]].dot(n) : 0.0;
      for (int k = 0; k < 3; ++k) {
        const int64_t i = unknown[u[k]];
        if (i < 0) continue;
        rhs[i] += along[k] * s[9 + k];
        mass[i] += s[12 + k];
        for (int l = 0; l < 3; ++l) {
          const double value = along[k] * along[l] * s[3 * k + l];
          if (unknown[u[l]] >= 0 && value != 0) entries.emplace_back(i, unknown[u[l]], value);
        }
      }
    }
    const double mean_mass = mass.sum() / double(free_count);
    for (uint32_t v = 0; v < nv; ++v) {
      const int64_t i = unknown[v];
      if (i < 0) continue;
      // A vertex no sample sees still gets a positive diagonal.
      const double w = options.regularization * std::max(mass[i], 1e-3 * mean_mass);
      entries.emplace_back(i, i, w);
      rhs[i] -= w * offset[v];
    }
    Eigen::SparseMatrix<double> a(free_count, free_count);
    a.setFromTriplets(entries.begin(), entries.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(a);
    if (solver.info() != Eigen::Success) break;  // keep what the earlier rounds did
    const Eigen::VectorXd e = solver.solve(rhs);
    if (solver.info() != Eigen::Success) break;
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
  }
  // The residuals of the last round's samples under the offsets kept (the
  // linear model above: no second search for the nearest triangles).
  if (!match.empty()) {
    double sum = 0, w = 0;
    for (const Match& m : match) {
      if (m.face < 0) continue;
      const uint32_t* u = &mesh->indices[3 * size_t(m.face)];
      double r = m.residual;
      for (int k = 0; k < 3; ++k) r -= m.bary[k] * normal[u[k]].dot(m.normal) * (offset[u[k]] - last_offset[u[k]]);
      sum += m.weight * r * r, w += m.weight;
    }
    st.rms_after = w > 0 ? std::sqrt(sum / w) : 0.0;
  }
  if (stats) *stats = st;
  return Status::Ok();
}

}  // namespace vpr
