// How many output vertices each part of the surface should get: a vertex
// density D per input vertex, relative (its median is about 1). The CVT
// (surface_cvt.h) spends vertices in proportion to D per unit area, by
// weighting its energy with rho = D^2 (a centroidal Voronoi tessellation of a
// surface puts points at a density proportional to rho^(1/2): Du, Faber and
// Gunzburger 1999, Gersho's conjecture in two dimensions).
#pragma once

#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "surface/edge_smoothing.h"
#include "surface/mesh_edges.h"

namespace vpr {

enum class DensityMode {
  kPerception,  // curvature term x attention term
  kCurvature,   // curvature term alone
  kUniform,     // D = 1
  kPaper,       // the paper's back half: saliency-driven sampling, AWLOP, advancing front
};

StatusOr<DensityMode> parse_density_mode(const std::string& name);  // "perception", "curvature", ...
const char* density_mode_name(DensityMode mode);

// Integrated mean curvature per vertex, |H| A_i = 1/4 sum over its edges of
// |dihedral angle| x length (Cohen-Steiner and Morvan 2003), divided by the
// vertex's area (a third of its faces'). Edges with one face count 0. No
// cotangents, so CAD slivers give no spikes; creases give large values.
std::vector<double> mean_curvature(const Mesh& mesh);

// |H| as above into *mean (when not null), and into *weighted (when not null)
// the same sums with every concave edge's term times concave_weight: the
// convex part of the curvature, where people look (docs/perception.md:
// noses, eyes, horns and rims draw the eye; the creases where surfaces meet
// do not). Concave: an edge of two faces that run along it in opposite
// directions, the far corner of one face on the outer side of the other's
// plane, for a part (faces joined by shared vertices) whose signed volume
// about its bounding-box centre is positive (outwards; negative turns the
// test round for that part alone). An edge whose two faces disagree on their
// orientation, a boundary edge and an edge of three or more faces keep their
// whole term. With concave_weight 1, *weighted equals *mean bit for bit.
void mean_curvatures(const Mesh& mesh, double concave_weight, std::vector<double>* mean,
                     std::vector<double>* weighted);

// Per face: whether its part (faces joined by shared vertices) faces outwards,
// by the part's signed volume about its own bounding-box centre, so that a
// part stored inside out among others is turned round on its own (the
// concave test of mean_curvatures).
std::vector<char> faces_outwards(const Mesh& mesh);

// The GPU twin, built when VPR_HAVE_CUDA (mean_curvature.cu): the same sums
// in the same order (curvature_terms.h), within an ulp or two of acos per
// edge term; *mean and *weighted as above.
namespace cuda {
Status mean_curvatures(const Mesh& mesh, double concave_weight, std::vector<double>* mean,
                       std::vector<double>* weighted, const ExecContext& ctx);
}  // namespace cuda

// Signed volume enclosed by the faces (about the bounding-box centre):
// positive where they face outwards.
double signed_volume(const Mesh& mesh);

// The perception density's attention term (issue 24). People fixate a
// minority of a surface (on the gaze data, 60% of the vertices get no
// fixation at all and a twentieth get most of it), so the term raises the
// density on the field's top `top` share of vertices (by rank, ties sharing
// their mean rank) and leaves the rest alone: D times boost^((q - (1 - top))
// / top) at rank q in [0, 1] above 1 - top, from 1 at the share's edge to
// `boost` at the top. Raising the top share without lowering the other
// vertices' term costs the rest of the surface only the few per cent of
// vertices the top takes (the budget is fixed), where a term about the
// median (sqrt(I / median I) clamped to [0.5, 2], until 2026-11-27) moved
// half the surface's vertices to the other half: on the gaze models at 3,000
// vertices it cost 9% more plain error for 6% less where people look
// (docs/perception.md, "A sparse attention term").
struct AttentionBoost {
  double top = 0.2;    // share of the vertices raised, in (0, 1]
  double boost = 1.5;  // D's factor at the field's top, in [1, 4]
};
// INVALID_ARGUMENT naming the option and its range.
Status check_attention_boost(const AttentionBoost& boost);

// D per vertex. Curvature term: sqrt(|H| / median |H|) clamped to [0.3, 3]
// (spacing follows the radius of curvature, bounded). Perception: times the
// attention term above (importance moves vertices towards where people look
// on top of what keeps the shape, never instead of it).
std::vector<float> vertex_density(const Mesh& mesh, const std::vector<float>& importance, DensityMode mode,
                                  const AttentionBoost& boost = {});
// The same from |H| per vertex already computed (mean_curvature(mesh)); empty
// curvature: no curvature term (uniform and paper need none).
std::vector<float> vertex_density(const std::vector<double>& curvature, const std::vector<float>& importance,
                                  DensityMode mode, const AttentionBoost& boost = {});

// Jacobi smoothing of one channel of a per-vertex value over the mesh's
// edges (each pass: half the value, half its neighbours' mean). The density
// is smoothed on the refined surface so that it changes over a few output
// spacings, not from one element to the next: a CVT cannot place well-shaped
// triangles across a tenfold jump in density.
void smooth_over_edges(const Mesh& mesh, int iterations, int channels, int channel, std::vector<float>* values);
// The same over edges already built (mesh_edges(mesh)). device: the passes'
// GPU twin (edge_smoothing.h: the same bits), or empty; when it fails, the
// host's passes run from the same values. Returns whether the device ran them.
bool smooth_over_edges(const MeshEdges& edges, int iterations, int channels, int channel, std::vector<float>* values,
                       const ScalarEdgeSmoothing& device = {});

}  // namespace vpr
