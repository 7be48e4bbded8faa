#include "surface/edge_flips.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <unordered_set>
#include <utility>

#include "core/vec3.h"
#include "surface/mesh_edges.h"

namespace vpr {
namespace {

using Eigen::Vector3d;

Vector3d eig(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

uint64_t key2(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
}

// An edge's entry in its lower end's row.
struct Slot {
  uint32_t other;   // the higher end
  int64_t face[2];  // the first two faces in face order; face[1] -1: one face, -2: more than two
  bool look;        // a face of the edge is in the pass's recheck
};

// A flip a pass made: the edge x-y of the faces f0 = (x, y, c) and
// f1 = (y, x, d) became c-d, f0 = (c, x, d) and f1 = (d, y, c).
struct Flip {
  uint32_t x, y, c, d;
  int64_t f0, f1;
};

// Each vertex's row of the edges to vertices at or above it (sorted by the
// other end), made once for a run of passes and brought up to date after
// each pass by its flips (a pass that flips a few dozen edges of 30,000
// rebuilt them all: a millisecond and a half of a two-core pass).
struct FlipRows {
  std::vector<uint32_t> start, used;  // row a: slots[start[a] .. start[a] + used[a]), room to start[a + 1]
  std::vector<Slot> slots;
  bool built = false;

  // From each vertex's own corners (vertex_corners: in face order), one
  // vertex per task: an edge's faces in (face, corner) order, as one loop
  // over the faces' corners meets them, so the first two faces and the rows'
  // order do not depend on the thread count. Each row has room for four
  // more edges than it has (a flip adds one to each of two rows).
  void build(const Mesh& mesh) {
    const size_t nv = mesh.vertex_count();
    const VertexCorners vc = vertex_corners(mesh.indices, nv);
    const uint32_t* idx = mesh.indices.data();
    // fn(face, other) for each face edge from corner c with ends {a, other},
    // other >= a, in (face, c) order.
    auto appearances = [&](uint32_t a, auto&& fn) {
      const uint32_t* row = vc.corner.data() + vc.offset[a];
      const uint32_t n = vc.offset[a + 1] - vc.offset[a];
      for (uint32_t i = 0; i < n;) {
        const uint32_t f = row[i] / 3;
        std::array<std::pair<uint32_t, uint32_t>, 6> found;  // (corner of the edge's start, other)
        int m = 0;
        for (; i < n && row[i] / 3 == f; ++i) {
          const uint32_t k = row[i] % 3;
          const uint32_t next = idx[3 * f + (k + 1) % 3], prev = idx[3 * f + (k + 2) % 3];
          if (next >= a) found[m++] = {k, next};           // the edge from corner k (a self-edge once)
          if (prev > a) found[m++] = {(k + 2) % 3, prev};  // the edge into corner k
        }
        for (int j = 1; j < m; ++j)  // by corner: an insertion sort of at most six
          for (int q = j; q > 0 && found[q] < found[q - 1]; --q) std::swap(found[q], found[q - 1]);
        for (int j = 0; j < m; ++j) fn(f, found[j].second);
      }
    };
    start.assign(nv + 1, 0);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 1024), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t a = r.begin(); a != r.end(); ++a) {
        uint32_t count = 4;
        appearances(a, [&](uint32_t, uint32_t) { ++count; });
        start[a + 1] = count;
      }
    });
    for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    slots.assign(start[nv], Slot{});
    used.assign(nv, 0);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 1024), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t a = r.begin(); a != r.end(); ++a) {
        Slot* row = &slots[start[a]];
        uint32_t& in_use = used[a];
        appearances(a, [&](uint32_t f, uint32_t hi) {
          uint32_t k = 0;
          while (k < in_use && row[k].other != hi) ++k;
          if (k == in_use) {
            row[in_use++] = {hi, {int64_t(f), -1}, false};
          } else {
            int64_t& second = row[k].face[1];
            second = second == -1 ? int64_t(f) : -2;
          }
        });
        std::sort(row, row + in_use, [](const Slot& x, const Slot& y) { return x.other < y.other; });
      }
    });
    built = true;
  }

  Slot* find(uint32_t a, uint32_t b) {
    const uint32_t lo = std::min(a, b), hi = std::max(a, b);
    for (uint32_t k = start[lo]; k < start[lo] + used[lo]; ++k)
      if (slots[k].other == hi) return &slots[k];
    return nullptr;
  }

  // The pass's looks: the edges of the faces in recheck (empty: none).
  void look_at(const Mesh& mesh, const std::vector<char>& recheck) {
    for (Slot& slot : slots) slot.look = false;
    for (size_t f = 0; f < recheck.size(); ++f)
      if (recheck[f])
        for (int c = 0; c < 3; ++c)
          if (Slot* slot = find(mesh.indices[3 * f + c], mesh.indices[3 * f + (c + 1) % 3])) slot->look = true;
  }

  // The rows as build() would make them after `flips` (in the order made).
  // Where a flip meets what the update does not follow (an edge of more
  // than two faces, a row with no room, a corner repeated), the rows are
  // marked for a rebuild instead.
  void apply(const std::vector<Flip>& flips) {
    auto drop = [&](uint32_t a, uint32_t b) {
      Slot* slot = find(a, b);
      if (!slot) return false;
      Slot* end = &slots[start[std::min(a, b)] + used[std::min(a, b)]];
      std::copy(slot + 1, end, slot);
      --used[std::min(a, b)];
      return true;
    };
    // The edge a-b's face `from` is now `to`; its faces kept in face order.
    auto move_face = [&](uint32_t a, uint32_t b, int64_t from, int64_t to) {
      Slot* slot = find(a, b);
      if (!slot || slot->face[1] == -2) return false;
      int64_t* face = slot->face;
      if (face[0] == from)
        face[0] = to;
      else if (face[1] == from)
        face[1] = to;
      else
        return false;
      if (face[1] >= 0 && face[1] < face[0]) std::swap(face[0], face[1]);
      return true;
    };
    auto add = [&](uint32_t a, uint32_t b, int64_t f0, int64_t f1) {
      const uint32_t lo = std::min(a, b), hi = std::max(a, b);
      if (start[lo] + used[lo] == start[lo + 1] || find(a, b)) return false;
      Slot* row = &slots[start[lo]];
      uint32_t k = used[lo];
      for (; k > 0 && row[k - 1].other > hi; --k) row[k] = row[k - 1];
      row[k] = {hi, {std::min(f0, f1), std::max(f0, f1)}, false};
      ++used[lo];
      return true;
    };
    for (const Flip& f : flips) {
      const bool distinct = f.x != f.y && f.c != f.d && f.c != f.x && f.c != f.y && f.d != f.x && f.d != f.y;
      if (!(distinct && drop(f.x, f.y) && move_face(f.y, f.c, f.f0, f.f1) && move_face(f.x, f.d, f.f1, f.f0) &&
            add(f.c, f.d, f.f0, f.f1))) {
        built = false;
        return;
      }
    }
  }
};

}  // namespace

// The rows and the faces they were last brought up to date for.
struct FlipRowsKept::Rows {
  FlipRows rows;
  std::vector<uint32_t> faces;
};
FlipRowsKept::FlipRowsKept() = default;
FlipRowsKept::~FlipRowsKept() = default;

namespace {

// A run's rows: the kept ones where they are of this mesh's faces (else
// marked to be made afresh), or the run's own where none are kept.
FlipRows* run_rows(const Mesh& mesh, FlipRowsKept* kept, FlipRows* own) {
  if (!kept) return own;
  if (!kept->rows) kept->rows = std::make_unique<FlipRowsKept::Rows>();
  if (kept->rows->faces != mesh.indices) kept->rows->rows.built = false;
  return &kept->rows->rows;
}

// At a run's end: the faces the kept rows are now of.
void end_run(const Mesh& mesh, FlipRowsKept* kept) {
  if (kept) kept->rows->faces = mesh.indices;
}

// One pass of edge flips over the interior edges, in one order for one mesh:
// the edge x-y between the faces (x, y, c) and (y, x, d) becomes c-d when
// want(x, y, c, d) says so, unless c-d exists already (or an earlier flip of
// the pass made it) or a face was flipped earlier in the pass. Returns the
// number of flips. Edges are visited in (min end, max end) order; each
// vertex's row lists the edges to higher vertices (rows, not a hash of the
// edges: a pass runs many times per job), made on the first pass of a run
// and updated by each pass's flips at its end.
// recheck: per face, empty on the first pass (every edge is looked at). A
// later pass looks only at edges with a face in it, and the pass leaves in
// it the faces it flipped and those of wanted edges it passed over because
// c-d existed: want() depends on the vertices' positions alone, which no pass
// moves, so any other edge has the same two faces as last pass (a flip never
// makes an edge that exists) and gets the same "no" (the same flips as
// looking at every edge, for a fraction of want()'s calls).
template <class Want>
size_t flip_pass(Mesh* mesh, FlipRows* rows, std::vector<char>* recheck, Want want) {
  const size_t nv = mesh->vertex_count(), nf = mesh->face_count();
  const bool every_edge = recheck->empty();
  if (!rows->built) rows->build(*mesh);
  rows->look_at(*mesh, *recheck);
  const std::vector<uint32_t>& start = rows->start;
  const std::vector<uint32_t>& used = rows->used;
  const std::vector<Slot>& slots = rows->slots;
  // Edges this pass's flips made (a hash: a pass can make thousands, which a
  // sorted list took quadratic time to keep); the rows change only after
  // the pass.
  std::unordered_set<uint64_t> made;
  auto exists = [&](uint32_t a, uint32_t b) {
    const uint32_t lo = std::min(a, b), hi = std::max(a, b);
    for (uint32_t k = start[lo]; k < start[lo] + used[lo]; ++k)
      if (slots[k].other == hi) return true;
    return made.count(key2(a, b)) > 0;
  };
  // An edge x-y between its faces (x, y, c) and (y, x, d) as they are now:
  // false where they share no third pair of ends.
  struct Quad {
    uint32_t x, y, c, d;
    bool consistent;  // the second face runs y -> x
  };
  auto quad_of = [&](uint32_t a, const Slot& slot, Quad* q) {
    const uint32_t b = slot.other;
    // Rotate f0 to (x, y, c) with {x, y} = {a, b}; f1 then runs (y, x, d).
    const uint32_t* t0 = &mesh->indices[3 * slot.face[0]];
    const uint32_t* t1 = &mesh->indices[3 * slot.face[1]];
    int k0 = 0;
    while (!((t0[k0] == a || t0[k0] == b) && (t0[(k0 + 1) % 3] == a || t0[(k0 + 1) % 3] == b))) ++k0;
    q->x = t0[k0], q->y = t0[(k0 + 1) % 3], q->c = t0[(k0 + 2) % 3];
    q->d = UINT32_MAX;
    for (int k = 0; k < 3; ++k)
      if (t1[k] != a && t1[k] != b) q->d = t1[k];
    if (q->d == UINT32_MAX || q->c == q->d) return false;
    q->consistent = false;
    for (int k = 0; k < 3; ++k) q->consistent = q->consistent || (t1[k] == q->y && t1[(k + 1) % 3] == q->x);
    return true;
  };
  // want() of every edge the loop below looks at, first, in parallel: a flip
  // rewrites only its two faces, and the loop passes over an edge with a
  // face flipped earlier in the pass, so every edge it does take still has
  // the faces it has now. (want() reads the positions alone; the same flips.)
  // Each looked-at edge's quad is kept for the loop (valid: it has one).
  std::vector<Quad> quads(slots.size());
  std::vector<char> valid(slots.size(), 0), wanted(slots.size(), 0);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 1024), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t a = r.begin(); a != r.end(); ++a)
      for (uint32_t j = start[a]; j < start[a] + used[a]; ++j) {
        const Slot& slot = slots[j];
        if (slot.face[1] < 0 || !(every_edge || slot.look)) continue;
        Quad& q = quads[j];
        valid[j] = quad_of(a, slot, &q);
        wanted[j] = valid[j] && q.consistent && want(q.x, q.y, q.c, q.d);
      }
  });
  std::vector<char> touched(nf, 0);
  std::vector<char> next_recheck(nf, 0);
  std::vector<Flip> flipped;
  for (uint32_t a = 0; a < nv; ++a)
    for (uint32_t j = start[a]; j < start[a] + used[a]; ++j) {
      const Slot& slot = slots[j];
      if (slot.face[1] < 0 || !(every_edge || slot.look)) continue;
      const int64_t f0 = slot.face[0], f1 = slot.face[1];
      if (touched[f0] || touched[f1]) continue;
      // An edge not wanted stays so while its faces stay (want() reads the
      // positions, which no pass moves): only a wanted one whose c-d exists
      // is kept for the next pass (c-d may be flipped away meanwhile).
      if (!wanted[j]) continue;
      const uint32_t x = quads[j].x, y = quads[j].y, c = quads[j].c, d = quads[j].d;
      if (exists(c, d)) {
        next_recheck[f0] = next_recheck[f1] = 1;
        continue;
      }
      uint32_t* t0 = &mesh->indices[3 * f0];
      uint32_t* t1 = &mesh->indices[3 * f1];
      t0[0] = c, t0[1] = x, t0[2] = d;
      t1[0] = d, t1[1] = y, t1[2] = c;
      made.insert(key2(c, d));  // no second c-d this pass
      touched[f0] = touched[f1] = 1;
      next_recheck[f0] = next_recheck[f1] = 1;
      flipped.push_back({x, y, c, d, f0, f1});
    }
  rows->apply(flipped);
  recheck->swap(next_recheck);
  return flipped.size();
}

// A run of up to max_passes flip passes (to the first that flips nothing),
// on the kept rows where given; returns the number of flips.
template <class Want>
size_t run_flips(Mesh* mesh, FlipRowsKept* kept, int max_passes, Want want) {
  std::vector<char> recheck;
  FlipRows own;
  FlipRows* rows = run_rows(*mesh, kept, &own);
  size_t total = 0;
  for (int pass = 0; pass < max_passes; ++pass) {
    const size_t flips = flip_pass(mesh, rows, &recheck, want);
    total += flips;
    if (flips == 0) break;
  }
  end_run(*mesh, kept);
  return total;
}

}  // namespace

// Edge flips towards the Delaunay triangulation of the vertices on the
// surface: an interior edge whose two opposite angles sum to more than pi is
// flipped, unless the flip would fold the surface, cross a crease (faces
// more than 30 degrees apart), or make an edge that exists already. The
// vertices stay where the CVT put them; only the connectivity improves.
void delaunay_flips(Mesh* mesh, FlipRowsKept* kept) {
  auto p = [&](uint32_t v) { return eig(load3d(mesh->positions.data(), v)); };
  auto cos_at = [&](uint32_t o, uint32_t a, uint32_t b) {
    const Vector3d u = (p(a) - p(o)).normalized(), w = (p(b) - p(o)).normalized();
    return std::clamp(u.dot(w), -1.0, 1.0);
  };
  auto normal = [&](uint32_t a, uint32_t b, uint32_t c) { return (p(b) - p(a)).cross(p(c) - p(a)).normalized(); };
  const double crease = kCreaseCos;
  run_flips(mesh, kept, 20, [&](uint32_t x, uint32_t y, uint32_t c, uint32_t d) {
    // The opposite angles' sum against pi, by their cosines where they
    // decide it: acos falls by at least t - s from s to t, so a sum of
    // cosines above 1e-6 puts the angles more than 1e-6 below pi, one below
    // -1e-6 more than 1e-6 above; acos, twice an edge, only in between
    // (the same answers: the margin is far beyond its rounding).
    const double cc = cos_at(c, x, y), cd = cos_at(d, y, x);
    if (cc + cd > 1e-6) return false;
    if (!(cc + cd < -1e-6) && std::acos(cc) + std::acos(cd) <= M_PI + 1e-9) return false;
    const Vector3d n0 = normal(x, y, c), n1 = normal(y, x, d);
    if (n0.dot(n1) < crease) return false;
    const Vector3d m0 = normal(c, x, d), m1 = normal(d, y, c);
    return m0.dot(n0 + n1) > 0 && m1.dot(n0 + n1) > 0 && m0.dot(m1) >= crease;
  });
}

// Crease edges the dual missed: two crease vertices next to each other on
// their crease but not joined, with an edge x-y of two off-crease vertices
// between them, cut the crease (the triangles (x, y, c) and (y, x, d) lean
// across it, a chamfer). Flipping x-y to c-d puts the crease back. Wanted
// where c and d are feature vertices, at least one with a crease line (two
// corners may be a face's diagonal apart) along which c-d runs (within 20
// degrees), x and y are not feature vertices (so x-y is not itself a
// crease, however bent the pair is: a chamfer's two faces often meet at 50
// degrees), and neither new face turns against the old pair. Delaunay flips
// never undo these (their faces are more than 30 degrees apart).
void restore_crease_edges(Mesh* mesh, const std::vector<char>& on_feature, const std::vector<Vector3d>& line,
                          FlipRowsKept* kept) {
  auto p = [&](uint32_t v) { return eig(load3d(mesh->positions.data(), v)); };
  auto normal = [&](uint32_t a, uint32_t b, uint32_t c) { return (p(b) - p(a)).cross(p(c) - p(a)).normalized(); };
  constexpr double kCos20 = 0.9396926207859084;
  auto along = [&](uint32_t v, const Vector3d& dir) { return std::abs(line[v].dot(dir)) >= kCos20; };
  run_flips(mesh, kept, 8, [&](uint32_t x, uint32_t y, uint32_t c, uint32_t d) {
    if (!on_feature[c] || !on_feature[d] || on_feature[x] || on_feature[y]) return false;
    const Vector3d dir = (p(d) - p(c)).normalized();
    const bool c_line = line[c].squaredNorm() > 0, d_line = line[d].squaredNorm() > 0;
    if (!(c_line || d_line) || (c_line && !along(c, dir)) || (d_line && !along(d, dir))) return false;
    const Vector3d n0 = normal(x, y, c), n1 = normal(y, x, d);
    const Vector3d m0 = normal(c, x, d), m1 = normal(d, y, c);
    return m0.dot(n0 + n1) > 0 && m1.dot(n0 + n1) > 0;
  });
}

// Caps left at the end: a triangle (x, y, c) whose corner c lies almost on
// its edge x-y (an angle over 150 degrees there: c is within tan(15 deg) / 2 of
// |xy| from the edge) has two needle angles. Its normal means little, so the
// Delaunay flips may have refused x-y as a crease or a fold. Flipping x-y to
// c-d moves the surface by no more than that height (the tetrahedron x y c d
// is flat), so it is wanted whenever the smallest angle of the pair grows and
// both new faces turn with the other face (x, y, d) by under 60 degrees,
// creases included: a crease through x-y then runs x-c-y, c beside it.
size_t flip_caps(Mesh* mesh, FlipRowsKept* kept) {
  auto p = [&](uint32_t v) { return eig(load3d(mesh->positions.data(), v)); };
  auto angle_at = [&](uint32_t o, uint32_t a, uint32_t b) {
    const Vector3d u = (p(a) - p(o)).normalized(), w = (p(b) - p(o)).normalized();
    return std::acos(std::clamp(u.dot(w), -1.0, 1.0));
  };
  auto smallest = [&](uint32_t a, uint32_t b, uint32_t c) {
    return std::min({angle_at(a, b, c), angle_at(b, c, a), angle_at(c, a, b)});
  };
  auto normal = [&](uint32_t a, uint32_t b, uint32_t c) { return (p(b) - p(a)).cross(p(c) - p(a)).normalized(); };
  const double cap = 150 * M_PI / 180, cap_cos = std::cos(cap);
  // angle_at(o, a, b) > cap, by the cosine where it decides it (acos falls
  // by at least the cosines' difference; the same answers).
  auto is_cap = [&](uint32_t o, uint32_t a, uint32_t b) {
    const Vector3d u = (p(a) - p(o)).normalized(), w = (p(b) - p(o)).normalized();
    const double t = std::clamp(u.dot(w), -1.0, 1.0);
    if (t < cap_cos - 1e-9) return true;
    if (t > cap_cos + 1e-9) return false;
    return std::acos(t) > cap;
  };
  return run_flips(mesh, kept, 8, [&](uint32_t x, uint32_t y, uint32_t c, uint32_t d) {
    const bool c_cap = is_cap(c, x, y), d_cap = is_cap(d, y, x);
    if (c_cap == d_cap) return false;  // neither a cap, or both (their normals say nothing)
    const double before = std::min(smallest(x, y, c), smallest(y, x, d));
    if (!(std::min(smallest(c, x, d), smallest(d, y, c)) > before)) return false;
    const Vector3d other = c_cap ? normal(y, x, d) : normal(x, y, c);
    return normal(c, x, d).dot(other) > 0.5 && normal(d, y, c).dot(other) > 0.5;
  });
}

}  // namespace vpr
