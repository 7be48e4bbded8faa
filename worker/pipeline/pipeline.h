// The whole remeshing pipeline (paper Sections III-V), stage by stage:
//   views -> snapshots -> image saliency -> unprojection -> saliency field ->
//   adaptive sampling -> AWLOP -> meshing.
// Plain arrays in, plain arrays out; nothing here knows about gRPC.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/exec_context.h"
#include "core/mesh.h"
#include "core/status.h"
#include "job_device.h"
#include "render/snapshot.h"
#include "render/views.h"
#include "resample/adaptive_sampling.h"
#include "resample/awlop.h"
#include "saliency/attention_field.h"
#include "saliency/image_saliency.h"
#include "saliency/saliency_field.h"
#include "saliency/visibility.h"
#include "surface/cluster_mesh.h"
#include "surface/meshing.h"
#include "surface/surface_cvt.h"
#include "surface/surface_density.h"

namespace vpr {

// Supported output sizes. Below the minimum the views carry more detail than
// the mesh can hold; the maximum bounds one job's memory (about 1 KiB a vertex).
inline constexpr uint32_t kMinTargetVertices = 100;
inline constexpr uint32_t kMaxTargetVertices = 2'000'000;

// A job's front half (views, snapshots, image saliency, unprojection, the
// field) runs once; its back half runs once per level of detail.
inline constexpr int kFrontHalf = -1;

struct StageTiming {
  std::string name;        // "render", "image_saliency", ...
  double ms = 0;           // wall time
  std::string device;      // "cpu", "cuda", "egl: ...", "osmesa: ..."
  std::string note;        // e.g. why a stage fell back to the CPU
  int level = kFrontHalf;  // kFrontHalf (shared by every level), else the level's index
};

// Where the parallel stages run. kAuto: a CUDA GPU when the build has the twins
// and a device answers, else the CPU. kCuda: the GPU is required
// (UNAVAILABLE when there is none); a stage that fails on it still reruns on
// the CPU and its timing says why.
enum class DevicePolicy { kAuto, kCpu, kCuda };

// How the surface CVT's sweeps run. In colour rounds (cvt_sweeps.h), then
// the CPU's sweeps finishing: another local minimum of the same energy than
// the CPU's sweeps alone, so the two meshes differ within the tolerances
// tests/pipeline/pipeline_gpu_test.cpp states. kAuto: colour rounds where the
// job runs on a GPU (a GPU failure reruns them on the CPU, the same labels),
// the CPU's sweeps alone elsewhere. kColourRounds: colour rounds on either
// device (on a CPU their reference: the GPU path's mesh, bit for bit,
// without a GPU). kSlabs: the CPU's sweeps alone (the CPU path's mesh, bit
// for bit, on a GPU too).
enum class CvtSweeps { kAuto, kColourRounds, kSlabs };

struct PipelineOptions {
  uint32_t target_vertices = 0;  // required: output vertex count (within 2%)
  ViewOptions views;
  RendererKind renderer = RendererKind::kAuto;
  // A renderer to reuse (a warm worker keeps one: creating a GL context costs
  // tens of milliseconds). Null: the job creates its own of kind `renderer`.
  Renderer* shared_renderer = nullptr;
  DevicePolicy device = DevicePolicy::kAuto;
  int cuda_device = 0;                    // which GPU, when one is used
  DeviceBudget* device_budget = nullptr;  // null: no per-job device memory limit
  ImageSaliencyOptions image;
  SaliencyFieldOptions field;       // the paper's field, for DensityMode::kPaper
  AttentionFieldOptions attention;  // the field of the other density modes
  VisibilityOptions visibility;     // its visibility cue over the views
  SamplingOptions sampling;
  AwlopOptions awlop;
  MeshingOptions meshing;
  // The back half. kPaper: adaptive sampling, AWLOP, advancing front (the
  // paper's). The others: a CVT on the input surface with that density, then
  // its dual (surface_cvt.h, cluster_mesh.h); polygon soups without usable
  // connectivity take the paper's back half whatever is asked.
  // kCurvature by default: measured against kPerception and kUniform on every
  // shared model (docs/quality.md, "What the guidance buys") it wins on SSIM and
  // Hausdorff; kPerception becomes the default once it wins (docs/perception.md).
  DensityMode density = DensityMode::kCurvature;
  // kPerception's attention term: the field's top share raised, up to a
  // factor at the top (surface_density.h; --attention-top, --attention-boost).
  AttentionBoost attention_boost;
  // An attention map to use instead of the attention field: one value per
  // vertex of the given mesh, in its order (higher: more looked at; only the
  // order counts for kPerception's term). For measuring what a predictor
  // could buy (measured fixation as an oracle, docs/perception.md) and for
  // callers with their own maps. Null: the attention field.
  std::shared_ptr<const std::vector<float>> attention_map;
  CvtOptions cvt;                   // its seed is sampling.seed; its anisotropy is set from `anisotropy`
  // The CVT's anisotropy as a share of the bounding-box diagonal (each
  // element at (x, a n) in R^6, surface_cvt.h); 0: isotropic. 0.04 by
  // default: measured on every shared model at 0, 0.02, 0.04, 0.06 and 0.08
  // (docs/quality.md, "Anisotropic cells"), 0.04 gave the best mean SSIM,
  // mean Hausdorff distance and share of small angles, and SSIM above the
  // isotropic CVT's on 27 of 30 cases.
  double anisotropy = 0.04;
  ClusterMeshOptions cluster_mesh;  // the dual's relaxation and L2 fit (cluster_mesh.h)
  // Surface elements per output vertex at the mean spacing (the refinement's
  // edge length is the target spacing over sqrt of this), and within
  // cvt_rim_band output spacings of an open edge (a rim, a fin's foot). The
  // CVT holds its mean SSIM and FLIP with 10 and takes 16-30% less time on 2
  // cores (docs/quality.md, docs/performance.md: issue 15, session 27); at a
  // rim the dual needs more elements per cell to keep a rim cell between two
  // others (10 everywhere once cut a notch into cube_no_bottom's rim, and
  // still costs the open models' mean distance).
  double cvt_elements_per_vertex = 10;
  double cvt_rim_elements_per_vertex = 16;
  double cvt_rim_band = 1.5;
  std::string debug_dir;  // when set: per-view PNGs and saliency points as PLY
  // Keep the saliency points' positions in PipelineResult (the service
  // returns them on request; a local run does not pay for the copy).
  bool keep_saliency_points = false;
  // Connected parts whose bounding-box diagonal is below this share of the
  // model's are left out (`--drop-parts-smaller-than`); 0, the default, keeps
  // every part (issue 19: parts are never dropped unless asked).
  double drop_parts_smaller_than = 0;
  // The most vertices a level whose count is found at run time (a fraction
  // of the input, a visual target) may have: a server's --max-target-vertices.
  uint32_t max_level_vertices = kMaxTargetVertices;
  // A chain of count levels runs its levels' back halves side by side (the
  // surface CVT's stages, on the CPU, whose bits do not depend on the
  // threads): the cores one level's serial steps leave idle run the others.
  // The levels are still delivered in order, each with the same bits as
  // alone; false runs them one at a time (`--levels-one-at-a-time`).
  bool levels_side_by_side = true;
  // A visual target's search makes its next try after a pass ahead, beside
  // the try it runs (the same outcome; run_visual_target): -1 where the
  // machine has 8 or more threads and warm starts are off, 0 never, 1 always
  // (warm starts then off); 2 also the next try after a failure (measured on
  // the H100 machine: no faster than 1, more work; docs/benchmarks.md).
  int visual_target_ahead = -1;
  // A visual target's tries below a passing one (within 15%), or above a
  // failing one before the first pass (within 10% of its surface's count),
  // start from its surface and CVT cells instead of from scratch
  // (run_visual_target): a few sweeps instead of a dozen. -1 above then
  // makes no try ahead.
  bool visual_target_warm = true;
  // A try started from a failing one's cells (a cut start) that fails by
  // less than this is run again from scratch at the same count, and the
  // search takes that score: a cut start's score differs from a cold one's
  // by up to about 0.0013 either way (docs/benchmarks.md), so such a failure
  // says nothing, and taken as one it raises the bracket's low end past
  // counts that pass. 0 never confirms.
  double visual_target_confirm = 0.002;
  CvtSweeps cvt_sweeps = CvtSweeps::kAuto;
  // On a GPU job the render's drawn geometry (smooth corner normals, shared
  // corners) is built on the device (render/drawn_geometry.h); false builds
  // it on the host (the same images; for benchmarks, `--render-prep host`).
  bool render_prep_on_gpu = true;
  // On a GPU job the snapshots stay on the device: GL reads them into pixel
  // buffers that CUDA maps (render/device_snapshots.h), and stages 2-3 and the
  // visibility cue start there. false reads them back to the host and uploads
  // them again (the same images; for benchmarks, `--render-readback host`).
  bool render_interop = true;
  // On a GPU job the dual's projections onto the cells' faces (placing its
  // vertices, the relaxation rounds) run on the device
  // (surface/dual_projection.h); false runs them on the host (the same mesh;
  // for benchmarks, `--dual-projection host`).
  bool dual_projection_on_gpu = true;
  // Called at every stage boundary; returning false cancels the job there.
  std::function<bool()> keep_going;
  // Called as each stage ends, e.g. to stream progress; the StageTiming is
  // final. The pipeline never makes two calls of these callbacks (nor of a
  // chain's level callback) at once, though levels run side by side may make
  // them from different threads.
  std::function<void(const StageTiming&)> on_stage;
  // Called as each stage starts, with its name (the service's job processes
  // report the stage a crash happened in).
  std::function<void(const char*)> on_stage_begin;
};

// One level of a chain: exactly one of a vertex count, a share of the input's
// vertices (those faces use), or a visual fidelity (the fewest vertices whose
// output keeps the mean SSIM of the job's own views at or above min_ssim;
// visual_target.h).
struct LevelTarget {
  uint32_t vertices = 0;
  double fraction = 0;  // (0, 1]
  double min_ssim = 0;  // (0, 1)
  // With min_ssim: the size in pixels at which the model is seen (a screen-
  // size target: the views are judged at this resolution, so a model seen
  // small needs fewer vertices); 0 = the job's snapshot resolution. [64, 4096].
  uint32_t screen_px = 0;
};
inline constexpr size_t kMaxLevels = 16;

// How a level's count was found (a visual target's search; zeros otherwise).
struct LevelSearch {
  double min_ssim = 0;  // the bound asked
  double ssim = 0;      // the score the chosen count reached
  int tries = 0;        // back halves run to find it
  int made_ahead = 0;   // tries made ahead beside the search's (PipelineOptions::visual_target_ahead)
  int taken = 0;        // of those, the ones the search then asked for
  int confirmed = 0;    // cut starts run again from scratch (PipelineOptions::visual_target_confirm), in tries
};

struct PipelineResult {
  int level = 0;        // index in the job's level list (0 for a one-target job)
  uint32_t target = 0;  // the vertex count this level asked for (a visual target: the count chosen)
  LevelSearch search;
  Mesh mesh;                            // the remeshed surface, in the input's frame (its origin)
  std::vector<float> saliency;          // #V_out importance values in [min_importance, 1]
  std::vector<float> input_importance;  // #V_in: the saliency field on the input mesh
  size_t saliency_points = 0;           // 3D points unprojected from feature pixels
  // Input vertices no face uses: left out of every stage (their field value
  // in input_importance is the field's floor).
  size_t ignored_vertices = 0;
  size_t dropped_parts = 0;  // parts left out by drop_parts_smaller_than
  // x, y, z per saliency point, in the input's units; only with
  // PipelineOptions::keep_saliency_points (empty otherwise).
  std::vector<float> saliency_point_positions;
  std::vector<StageTiming> stages;
  double total_ms = 0;
  std::string renderer;    // renderer description
  std::string device;      // where the twins ran: "cpu" or "cuda:0 NVIDIA H100 ..."
  std::string cpu_reason;  // why the CPU under DevicePolicy::kAuto ("built without CUDA", no device, ...)
  AwlopStats awlop;
  MeshingStats meshing;
  std::string back_half;  // "surface CVT (perception density)" or "paper (AWLOP, advancing front)"
  CvtStats cvt;
  ClusterMeshStats cluster_mesh;
};

// Checks options that do not depend on the mesh (target range, constants).
Status validate_options(const PipelineOptions& options);

// One target: options.target_vertices.
StatusOr<PipelineResult> run_pipeline(const Mesh& input, const PipelineOptions& options);

// A level-of-detail chain: the front half once, then the back half of each
// level in the order given; on_level gets each level's result as soon as it
// is done (level 0 holds the front half's stage timings; its error, if any,
// ends the job). options.target_vertices is not used. Errors:
// INVALID_ARGUMENT for a bad level list (check_levels), else run_pipeline's.
using LevelCallback = std::function<Status(PipelineResult&& level)>;
Status run_pipeline_levels(const Mesh& input, const PipelineOptions& options, const std::vector<LevelTarget>& levels,
                           const LevelCallback& on_level);

// A level list's own checks (1 to kMaxLevels levels, each with exactly one
// target in range), naming the level and the limit.
Status check_levels(const std::vector<LevelTarget>& levels);
// Vertex counts of the levels with a count or a share of input_vertices (the
// vertices faces use); 0 for a visual target. INVALID_ARGUMENT when a share
// gives a count outside [kMinTargetVertices, max_vertices].
StatusOr<std::vector<uint32_t>> level_counts(const std::vector<LevelTarget>& levels, size_t input_vertices,
                                             uint32_t max_vertices = kMaxTargetVertices);

}  // namespace vpr
