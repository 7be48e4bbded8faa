#include "pipeline_flags.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace vpr::cli {

void add_pipeline_flags(CLI::App* cmd, PipelineOptions& o, PipelineFlagValues& values) {
  cmd->add_option("-n,--target-vertices", o.target_vertices, "Output vertex count (within 2%)");
  cmd->add_option("--lod", values.lod,
                  "Levels of detail instead of -n: counts or fractions of the input's vertices, e.g. 20000,5000,0.01; "
                  "the views and the field are computed once for all");
  cmd->add_option("--tries-ahead", values.tries_ahead,
                  "A visual target's search makes its next try after a pass beside the one it runs: auto (with 8 "
                  "or more threads, with --cold-tries), on, both (the next tries after a pass and after a failure) or "
                  "off (the same outcome every way); on and both start every try cold")
      ->check(CLI::IsMember({"auto", "on", "both", "off"}))
      ->capture_default_str();
  cmd->add_flag("--cold-tries", values.cold_tries,
                "A visual target's tries near an earlier one (below a pass, or above a failure before the first pass) "
                "start from scratch instead of from its surface and cells (slower; for measuring)");
  cmd->add_flag("--levels-one-at-a-time", values.levels_one_at_a_time,
                "Run a --lod chain's levels one after another instead of side by side (the same meshes; for "
                "measuring)");
  cmd->add_option("--min-ssim", values.min_ssim,
                  "A level with a visual target: the fewest vertices whose output keeps this mean SSIM against the "
                  "input over the job's views (after any --lod levels)");
  cmd->add_option("--screen-px", values.screen_px,
                  "With --min-ssim (default 0.97): the model's size on screen in pixels; the level keeps the bound "
                  "when seen at that size");
  cmd->add_option("--views", o.views.count, "Number of views: 6 (axes) or 14 (axes + diagonals)")
      ->check(CLI::IsMember({6, 14}))
      ->capture_default_str();
  cmd->add_option("--resolution", o.views.resolution, "Snapshot resolution in pixels")->capture_default_str();
  cmd->add_option("--seed", o.sampling.seed, "Random seed of the sampler")->capture_default_str();
  cmd->add_flag("--no-pca", values.no_pca, "Use the model's own axes instead of its principal axes");
  cmd->add_option("--rotation", values.rotation, "User rotation, 9 numbers (row-major 3x3)")->expected(9);
  // The paper's constants (Sections III-V), each with its default.
  cmd->add_option("--median-size", o.image.median_size, "Median pre-filter window")->capture_default_str();
  cmd->add_option("--gaussian-size", o.image.gaussian_size, "Eq. (1) Gaussian window n")->capture_default_str();
  cmd->add_option("--gaussian-sigma", o.image.gaussian_sigma, "Eq. (1) Gaussian sigma")->capture_default_str();
  cmd->add_option("--threshold-c", o.image.threshold_c, "Eq. (3) threshold C")->capture_default_str();
  cmd->add_option("--skeleton-lambda", o.image.skeleton_lambda, "Eq. (5) lambda")->capture_default_str();
  cmd->add_option("--thin-feature-px", o.image.thin_feature_px, "Thin feature size at 512 px")->capture_default_str();
  cmd->add_option("--knn", o.field.k, "Algorithm 1: k of the k-NN graph")->capture_default_str();
  cmd->add_option("--beta", o.field.beta, "Algorithm 1: I = beta^depth")->capture_default_str();
  cmd->add_option("--min-importance", o.field.min_importance, "Floor of the importance")->capture_default_str();
  cmd->add_option("--depth-scale", o.field.depth_scale, "Field depth per output spacing (0 = automatic)")
      ->capture_default_str();
  cmd->add_option("--mu", o.awlop.mu, "Eq. (17) repulsion strength")->capture_default_str();
  cmd->add_option("--awlop-samples", o.awlop.attraction_samples_per_target,
                  "Surface samples AWLOP attracts to, per target vertex")
      ->capture_default_str();
  cmd->add_option("--awlop-k", o.awlop.k, "AWLOP neighbours")->capture_default_str();
  cmd->add_option("--awlop-iterations", o.awlop.iterations, "AWLOP iterations")->capture_default_str();
  cmd->add_option("--awlop-support", values.awlop_support, "h from 'target' spacing or 'paper' (input edges)")
      ->check(CLI::IsMember({"target", "paper"}))
      ->capture_default_str();
  cmd->add_option("--view-bias", o.attention.view_bias,
                  "Attention field: weight of the front-top bias (+y up, +z front), 0 = off")
      ->capture_default_str();
  cmd->add_option(
         "--visibility-bias", o.visibility.view_bias,
         "Attention field: weight of the front-top views in the visibility cue (+y up, +z front), 0 = all alike")
      ->capture_default_str();
  cmd->add_flag("--image-cue", values.image_cue,
                "Attention field: add the image cue (the views' feature pixels near each vertex, weighted)");
  cmd->add_option("--attention-sigma", o.attention.coarse_sigma,
                  "Attention field: coarse curvature scale, a fraction of the bounding-box diagonal")
      ->capture_default_str();
  cmd->add_option("--attention-top", o.attention_boost.top,
                  "Perception density: share of the vertices (the field's highest) whose density is raised")
      ->capture_default_str();
  cmd->add_option("--attention-boost", o.attention_boost.boost,
                  "Perception density: the density's factor at the field's top (1: no raise)")
      ->capture_default_str();
  cmd->add_option("--concave-weight", o.attention.concave_weight,
                  "Attention field: share of a concave edge's curvature the cue keeps (1: |H|, 0: convex only)")
      ->capture_default_str();
  cmd->add_option("--anisotropy", o.anisotropy,
                  "CVT anisotropy, a share of the bounding-box diagonal: cells stretch where the surface turns "
                  "least (0: isotropic)")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  cmd->add_option("--cvt-elements", o.cvt_elements_per_vertex,
                  "Surface elements per output vertex that the CVT's cells are made of, away from open edges")
      ->check(CLI::Range(4.0, 64.0))
      ->capture_default_str();
  cmd->add_option("--cvt-rim-elements", o.cvt_rim_elements_per_vertex,
                  "Surface elements per output vertex near open edges (rims, a fin's foot)")
      ->check(CLI::Range(4.0, 64.0))
      ->capture_default_str();
  cmd->add_option("--cvt-rim-band", o.cvt_rim_band,
                  "How far from an open edge --cvt-rim-elements holds, in output spacings (0: nowhere)")
      ->check(CLI::Range(0.0, 16.0))
      ->capture_default_str();
  cmd->add_option("--drop-parts-smaller-than", o.drop_parts_smaller_than,
                  "Leave out connected parts whose bounding-box diagonal is below this share of the model's "
                  "(0: keep every part)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option(
         "--density", values.density,
         "Vertex density: curvature (CVT on the surface, denser where curved), perception (curvature x the attention "
         "field), uniform, or "
         "paper (the paper's sampling, AWLOP and advancing front)")
      ->check(CLI::IsMember({"perception", "curvature", "uniform", "paper"}))
      ->capture_default_str();
}

Status apply_pipeline_flags(const PipelineFlagValues& values, PipelineOptions* o) {
  if (values.awlop_support == "paper") o->awlop.support = AwlopSupport::kPaper;
  o->density = parse_density_mode(values.density).value();
  o->views.pca_align = !values.no_pca;
  o->attention.image_cue = values.image_cue;
  o->levels_side_by_side = !values.levels_one_at_a_time;
  o->visual_target_warm = !values.cold_tries;
  o->visual_target_ahead = values.tries_ahead == "on"     ? 1
                           : values.tries_ahead == "both" ? 2
                           : values.tries_ahead == "off"  ? 0
                                                          : -1;
  if (!values.rotation.empty()) {
    if (values.rotation.size() != 9) return invalid_argument("--rotation needs 9 numbers (row-major 3x3)");
    std::array<double, 9> r{};
    for (int i = 0; i < 9; ++i) r[i] = values.rotation[i];
    o->views.user_rotation = r;
  }
  return Status::Ok();
}

std::string level_path(const std::string& output, size_t level) {
  const size_t slash = output.find_last_of('/');
  const size_t dot = output.find_last_of('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  const std::string stem = has_ext ? output.substr(0, dot) : output;
  const std::string ext = has_ext ? output.substr(dot) : "";
  return stem + ".lod" + std::to_string(level) + ext;
}

StatusOr<std::vector<LevelTarget>> parse_level_list(const std::string& list) {
  std::vector<LevelTarget> levels;
  size_t start = 0;
  while (start <= list.size()) {
    const size_t comma = std::min(list.find(',', start), list.size());
    const std::string item = list.substr(start, comma - start);
    const std::string name = "--lod item " + std::to_string(levels.size()) + " '" + item + "'";
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || errno != 0 || !std::isfinite(value))
      return invalid_argument(name + " is not a number");
    LevelTarget level;
    if (value > 1) {
      if (value != std::floor(value) || value > 4294967295.0)
        return invalid_argument(name + ": a vertex count must be a whole number");
      level.vertices = uint32_t(value);
    } else if (value > 0) {
      level.fraction = value;
    } else {
      return invalid_argument(name + ": a level must be a count above 1 or a fraction in (0, 1]");
    }
    levels.push_back(level);
    start = comma + 1;
  }
  VPR_RETURN_IF_ERROR(check_levels(levels));
  return levels;
}

// --screen-px alone: the example bound, a difference few people see.
constexpr double kDefaultMinSsim = 0.97;

StatusOr<std::vector<LevelTarget>> levels_from_flags(const PipelineFlagValues& values, const PipelineOptions& o) {
  const bool chain = !values.lod.empty() || values.min_ssim != 0 || values.screen_px != 0;
  if (o.target_vertices != 0 && chain) return invalid_argument("give -n or --lod/--min-ssim/--screen-px, not both");
  if (o.target_vertices == 0 && !chain)
    return invalid_argument("a target is required: -n, --lod, --min-ssim or --screen-px");
  if (!chain) {
    LevelTarget one;
    one.vertices = o.target_vertices;
    return std::vector<LevelTarget>{one};
  }
  std::vector<LevelTarget> levels;
  if (!values.lod.empty()) {
    VPR_ASSIGN_OR_RETURN(levels, parse_level_list(values.lod));
  }
  if (values.min_ssim != 0 || values.screen_px != 0) {
    LevelTarget visual;
    visual.min_ssim = values.min_ssim != 0 ? values.min_ssim : kDefaultMinSsim;
    visual.screen_px = values.screen_px;
    levels.push_back(visual);
  }
  VPR_RETURN_IF_ERROR(check_levels(levels));
  return levels;
}

}  // namespace vpr::cli
