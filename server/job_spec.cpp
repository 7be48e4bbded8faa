#include "server/job_spec.h"

#include <cmath>
#include <sstream>

namespace vpr::service {
namespace {

template <class T>
std::string str(T v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Each check: zero takes the default; anything else must lie in the range,
// and the error names the proto field and that range.
Status int_field(const char* name, int64_t value, int64_t lo, int64_t hi, int default_value, int* out,
                 bool odd = false) {
  if (value == 0) {
    *out = default_value;
    return Status::Ok();
  }
  if (value < lo || value > hi || (odd && value % 2 == 0))
    return invalid_argument(std::string(name) + " is " + str(value) + "; it must be " + (odd ? "odd and " : "") +
                            "in [" + str(lo) + ", " + str(hi) + "] (0 = default " + str(default_value) + ")");
  *out = int(value);
  return Status::Ok();
}

// Float ranges: lo_open / hi_open say whether the bound itself is excluded.
Status float_field(const char* name, float value, float lo, bool lo_open, float hi, bool hi_open, float default_value,
                   float* out) {
  if (value == 0.0f) {
    *out = default_value;
    return Status::Ok();
  }
  const bool above = lo_open ? value > lo : value >= lo;
  const bool below = hi_open ? value < hi : value <= hi;
  if (!std::isfinite(value) || !above || !below)
    return invalid_argument(std::string(name) + " is " + str(value) + "; it must be in " + (lo_open ? "(" : "[") +
                            str(lo) + ", " + str(hi) + (hi_open ? ")" : "]") + " (0 = default " + str(default_value) +
                            ")");
  *out = value;
  return Status::Ok();
}

}  // namespace

Status pipeline_options_from_proto(const v1::PipelineOptions& p, PipelineOptions* out) {
  const PipelineOptions d;
  PipelineOptions& o = *out;
  VPR_RETURN_IF_ERROR(int_field("options.views", p.views(), 6, 14, d.views.count, &o.views.count));
  if (o.views.count != 6 && o.views.count != 14)
    return invalid_argument("options.views is " + str(p.views()) + "; it must be 6 or 14 (0 = default 6)");
  VPR_RETURN_IF_ERROR(
      int_field("options.resolution", p.resolution(), 64, 4096, d.views.resolution, &o.views.resolution));
  o.sampling.seed = p.seed() == 0 ? d.sampling.seed : p.seed();
  o.views.pca_align = !p.no_pca();
  if (p.rotation_size() != 0) {
    if (p.rotation_size() != 9)
      return invalid_argument("options.rotation has " + str(p.rotation_size()) +
                              " numbers; it must have 9 (row-major 3x3) or none");
    std::array<double, 9> r{};
    for (int i = 0; i < 9; ++i) {
      if (!std::isfinite(p.rotation(i)))
        return invalid_argument("options.rotation[" + str(i) + "] is not a finite number");
      r[i] = p.rotation(i);
    }
    o.views.user_rotation = r;
  } else {
    o.views.user_rotation.reset();
  }

  VPR_RETURN_IF_ERROR(
      int_field("options.median_size", p.median_size(), 1, 31, d.image.median_size, &o.image.median_size, true));
  VPR_RETURN_IF_ERROR(int_field("options.gaussian_size", p.gaussian_size(), 1, 63, d.image.gaussian_size,
                                &o.image.gaussian_size, true));
  VPR_RETURN_IF_ERROR(float_field("options.gaussian_sigma", p.gaussian_sigma(), 0, true, 100, false,
                                  d.image.gaussian_sigma, &o.image.gaussian_sigma));
  VPR_RETURN_IF_ERROR(
      int_field("options.threshold_c", p.threshold_c(), -255, 255, d.image.threshold_c, &o.image.threshold_c));
  VPR_RETURN_IF_ERROR(int_field("options.skeleton_lambda", p.skeleton_lambda(), 2, 64, d.image.skeleton_lambda,
                                &o.image.skeleton_lambda));
  VPR_RETURN_IF_ERROR(float_field("options.thin_feature_px", p.thin_feature_px(), 0, true, 4096, false,
                                  d.image.thin_feature_px, &o.image.thin_feature_px));

  VPR_RETURN_IF_ERROR(int_field("options.knn", p.knn(), 1, 64, d.field.k, &o.field.k));
  VPR_RETURN_IF_ERROR(float_field("options.beta", p.beta(), 0, true, 1, true, d.field.beta, &o.field.beta));
  VPR_RETURN_IF_ERROR(float_field("options.min_importance", p.min_importance(), 0, true, 1, false,
                                  d.field.min_importance, &o.field.min_importance));
  if (!std::isfinite(p.depth_scale()) || p.depth_scale() < 0 || p.depth_scale() > 1e6f)
    return invalid_argument("options.depth_scale is " + str(p.depth_scale()) +
                            "; it must be in [0, 1e6] (0 = automatic)");
  o.field.depth_scale = p.depth_scale();

  VPR_RETURN_IF_ERROR(float_field("options.mu", p.mu(), 0, false, 0.5f, false, d.awlop.mu, &o.awlop.mu));
  VPR_RETURN_IF_ERROR(int_field("options.awlop_k", p.awlop_k(), 1, 64, d.awlop.k, &o.awlop.k));
  VPR_RETURN_IF_ERROR(
      int_field("options.awlop_iterations", p.awlop_iterations(), 1, 200, d.awlop.iterations, &o.awlop.iterations));
  VPR_RETURN_IF_ERROR(int_field("options.awlop_samples", p.awlop_samples(), 1, 32,
                                d.awlop.attraction_samples_per_target, &o.awlop.attraction_samples_per_target));
  switch (p.awlop_support()) {
    case v1::AWLOP_SUPPORT_TARGET:
      o.awlop.support = AwlopSupport::kTargetSpacing;
      break;
    case v1::AWLOP_SUPPORT_PAPER:
      o.awlop.support = AwlopSupport::kPaper;
      break;
    default:
      return invalid_argument("options.awlop_support is " + str(int(p.awlop_support())) +
                              "; it must be AWLOP_SUPPORT_TARGET (0) or AWLOP_SUPPORT_PAPER (1)");
  }
  VPR_RETURN_IF_ERROR(float_field("options.awlop_h_factor", p.awlop_h_factor(), 0, true, 100, false, d.awlop.h_factor,
                                  &o.awlop.h_factor));
  float drop = 0;
  VPR_RETURN_IF_ERROR(
      float_field("options.drop_parts_smaller_than", p.drop_parts_smaller_than(), 0, true, 1, false, 0.0f, &drop));
  o.drop_parts_smaller_than = drop;
  if (p.has_anisotropy()) {
    const float a = p.anisotropy();
    if (!std::isfinite(a) || a < 0 || a > 0.5f)
      return invalid_argument("options.anisotropy is " + str(a) + "; it must be in [0, 0.5] (unset = default " +
                              str(float(d.anisotropy)) + ", 0 = isotropic)");
    o.anisotropy = a;
  } else {
    o.anisotropy = d.anisotropy;
  }
  if (p.density().empty()) {
    o.density = d.density;
  } else {
    auto mode = parse_density_mode(p.density());
    if (!mode.ok()) return invalid_argument("options." + mode.status().message());
    o.density = *mode;
  }
  return Status::Ok();
}

Status job_options_from_spec(const v1::JobSpec& spec, JobOptions* out) {
  std::vector<LevelTarget> levels;
  for (const v1::LevelTarget& l : spec.levels()) {
    LevelTarget level;
    level.vertices = l.vertices();
    level.fraction = l.fraction();
    level.min_ssim = l.min_ssim();
    level.screen_px = l.screen_px();
    levels.push_back(level);
  }
  if (!levels.empty()) {
    if (spec.target_vertices() != 0)
      return invalid_argument("target_vertices is " + str(spec.target_vertices()) + " and levels has " +
                              str(levels.size()) + " entries; give one or the other");
    if (Status s = check_levels(levels); !s.ok()) return invalid_argument("levels: " + s.message());
  } else if (spec.target_vertices() < kMinTargetVertices || spec.target_vertices() > kMaxTargetVertices)
    return invalid_argument("target_vertices is " + str(spec.target_vertices()) + "; it must be in [" +
                            str(kMinTargetVertices) + ", " + str(kMaxTargetVertices) + "]");
  if (spec.priority() < -10 || spec.priority() > 10)
    return invalid_argument("priority is " + str(spec.priority()) + "; it must be in [-10, 10]");
  if (spec.result_quantization_bits() > 30)
    return invalid_argument("result_quantization_bits is " + str(spec.result_quantization_bits()) +
                            "; it must be in [1, 30] (0 = default " + str(kDefaultResultQuantizationBits) + ")");
  if (!v1::DevicePreference_IsValid(spec.device()))
    return invalid_argument("device is " + str(int(spec.device())) +
                            "; it must be DEVICE_ANY (0), DEVICE_CPU (1) or DEVICE_CUDA (2)");
  if (!v1::InputFormat_IsValid(spec.input_format()))
    return invalid_argument("input_format is " + str(int(spec.input_format())) +
                            "; it must be INPUT_FORMAT_DRACO (0) or INPUT_FORMAT_GLTF_BINARY (1)");
  JobOptions o;
  o.input_format = spec.input_format() == v1::INPUT_FORMAT_GLTF_BINARY ? MeshFormat::kGltf : MeshFormat::kDraco;
  o.pipeline.target_vertices = spec.target_vertices();
  VPR_RETURN_IF_ERROR(pipeline_options_from_proto(spec.options(), &o.pipeline));
  o.pipeline.keep_saliency_points = spec.return_saliency_points();
  // Backstop: the pipeline's own checks (its messages do not name proto fields).
  PipelineOptions checked = o.pipeline;
  if (!levels.empty()) checked.target_vertices = kMinTargetVertices;  // each level's was checked above
  if (Status s = validate_options(checked); !s.ok()) return invalid_argument("options: " + s.message());
  o.levels = std::move(levels);
  o.priority = spec.priority();
  o.result_quantization_bits =
      spec.result_quantization_bits() == 0 ? kDefaultResultQuantizationBits : int(spec.result_quantization_bits());
  o.device = spec.device();
  *out = std::move(o);
  return Status::Ok();
}

StatusOr<v1::PipelineOptions> pipeline_options_to_proto(const PipelineOptions& o) {
  // Values for which zero on the wire means "default", so zero cannot be sent.
  if (o.image.threshold_c == 0)
    return invalid_argument("threshold C = 0 cannot be sent (0 in options.threshold_c means the default 3)");
  if (o.sampling.seed == 0) return invalid_argument("seed 0 cannot be sent (0 in options.seed means the default 1)");
  if (o.awlop.iterations == 0)
    return invalid_argument("0 AWLOP iterations cannot be sent (0 in options.awlop_iterations means the default 10)");
  if (o.awlop.mu == 0.0f) return invalid_argument("mu = 0 cannot be sent (0 in options.mu means the default 0.45)");
  // Options the API does not carry must be at their defaults.
  const PipelineOptions d;
  if (o.views.margin != d.views.margin) return invalid_argument("the view margin is not part of the API");
  if (o.sampling.adaptive_min_samples != d.sampling.adaptive_min_samples)
    return invalid_argument("sampling.adaptive_min_samples is not part of the API");
  if (!o.debug_dir.empty()) return invalid_argument("debug_dir is a local option; the service does not take it");

  v1::PipelineOptions p;
  p.set_views(uint32_t(o.views.count));
  p.set_resolution(uint32_t(o.views.resolution));
  p.set_seed(o.sampling.seed);
  p.set_no_pca(!o.views.pca_align);
  if (o.views.user_rotation)
    for (double r : *o.views.user_rotation) p.add_rotation(float(r));
  p.set_median_size(uint32_t(o.image.median_size));
  p.set_gaussian_size(uint32_t(o.image.gaussian_size));
  p.set_gaussian_sigma(o.image.gaussian_sigma);
  p.set_threshold_c(o.image.threshold_c);
  p.set_skeleton_lambda(uint32_t(o.image.skeleton_lambda));
  p.set_thin_feature_px(o.image.thin_feature_px);
  p.set_knn(uint32_t(o.field.k));
  p.set_beta(o.field.beta);
  p.set_min_importance(o.field.min_importance);
  p.set_depth_scale(o.field.depth_scale);
  p.set_mu(o.awlop.mu);
  p.set_awlop_k(uint32_t(o.awlop.k));
  p.set_awlop_iterations(uint32_t(o.awlop.iterations));
  p.set_awlop_samples(uint32_t(o.awlop.attraction_samples_per_target));
  p.set_awlop_support(o.awlop.support == AwlopSupport::kPaper ? v1::AWLOP_SUPPORT_PAPER : v1::AWLOP_SUPPORT_TARGET);
  p.set_awlop_h_factor(o.awlop.h_factor);
  p.set_density(density_mode_name(o.density));
  p.set_drop_parts_smaller_than(float(o.drop_parts_smaller_than));
  // Unset is the default: sent through a float it would come back as 0.03999...
  if (o.anisotropy != d.anisotropy) p.set_anisotropy(float(o.anisotropy));
  // Negative ints cast to uint32 above would wrap: check the result on the way back.
  PipelineOptions check = o;
  VPR_RETURN_IF_ERROR(pipeline_options_from_proto(p, &check));
  return p;
}

StatusOr<v1::JobSpec> make_job_spec(const PipelineOptions& options, const std::vector<LevelTarget>& levels) {
  v1::JobSpec spec;
  const bool chain = levels.size() > 1 || (levels.size() == 1 && levels[0].vertices == 0);
  if (chain) {
    for (const LevelTarget& l : levels) {
      v1::LevelTarget* p = spec.add_levels();
      p->set_vertices(l.vertices);
      p->set_fraction(l.fraction);
      p->set_min_ssim(l.min_ssim);
      p->set_screen_px(l.screen_px);
    }
  } else {
    spec.set_target_vertices(levels.empty() ? options.target_vertices : levels[0].vertices);
  }
  VPR_ASSIGN_OR_RETURN(*spec.mutable_options(), pipeline_options_to_proto(options));
  JobOptions check;
  VPR_RETURN_IF_ERROR(job_options_from_spec(spec, &check));
  return spec;
}

}  // namespace vpr::service
