// JobSpec <-> PipelineOptions: zero means default, every option survives a
// round trip, and every out-of-range field is refused by name.
#include "server/job_spec.h"

#include <gtest/gtest.h>

#include <cmath>

namespace vpr::service {
namespace {

v1::JobSpec spec_with_target(uint32_t n) {
  v1::JobSpec s;
  s.set_target_vertices(n);
  return s;
}

TEST(JobSpec, ZeroFieldsTakeThePipelineDefaults) {
  JobOptions o;
  ASSERT_TRUE(job_options_from_spec(spec_with_target(5000), &o).ok());
  const PipelineOptions d;
  EXPECT_EQ(o.pipeline.target_vertices, 5000u);
  EXPECT_EQ(o.pipeline.views.count, d.views.count);
  EXPECT_EQ(o.pipeline.views.resolution, d.views.resolution);
  EXPECT_EQ(o.pipeline.sampling.seed, d.sampling.seed);
  EXPECT_TRUE(o.pipeline.views.pca_align);
  EXPECT_FALSE(o.pipeline.views.user_rotation);
  EXPECT_EQ(o.pipeline.image.median_size, d.image.median_size);
  EXPECT_EQ(o.pipeline.image.threshold_c, d.image.threshold_c);
  EXPECT_EQ(o.pipeline.field.beta, d.field.beta);
  EXPECT_EQ(o.pipeline.field.depth_scale, 0.0f);
  EXPECT_EQ(o.pipeline.awlop.mu, d.awlop.mu);
  EXPECT_EQ(o.pipeline.awlop.iterations, d.awlop.iterations);
  EXPECT_EQ(o.pipeline.awlop.support, AwlopSupport::kTargetSpacing);
  EXPECT_EQ(o.result_quantization_bits, kDefaultResultQuantizationBits);
  EXPECT_EQ(o.device, v1::DEVICE_ANY);
  EXPECT_EQ(o.input_format, MeshFormat::kDraco);
  v1::JobSpec gltf = spec_with_target(5000);
  gltf.set_input_format(v1::INPUT_FORMAT_GLTF_BINARY);
  ASSERT_TRUE(job_options_from_spec(gltf, &o).ok());
  EXPECT_EQ(o.input_format, MeshFormat::kGltf);
}

TEST(JobSpec, RoundTripKeepsEveryOption) {
  PipelineOptions in;
  in.target_vertices = 12345;
  in.views.count = 14;
  in.views.resolution = 256;
  in.views.pca_align = false;
  in.views.user_rotation = std::array<double, 9>{0, 1, 0, -1, 0, 0, 0, 0, 1};
  in.sampling.seed = 42;
  in.image.median_size = 5;
  in.image.gaussian_size = 9;
  in.image.gaussian_sigma = 1.5f;
  in.image.threshold_c = -2;
  in.image.skeleton_lambda = 6;
  in.image.thin_feature_px = 12.5f;
  in.field.k = 7;
  in.field.beta = 0.6f;
  in.field.min_importance = 0.3f;
  in.field.depth_scale = 2.0f;
  in.awlop.mu = 0.3f;
  in.awlop.k = 16;
  in.awlop.iterations = 25;
  in.awlop.attraction_samples_per_target = 4;
  in.awlop.support = AwlopSupport::kPaper;
  in.awlop.h_factor = 3.0f;
  in.anisotropy = 0;  // isotropic: sent explicitly, not taken for "unset"

  auto spec = make_job_spec(in);
  ASSERT_TRUE(spec.ok()) << spec.status().to_string();
  JobOptions out;
  ASSERT_TRUE(job_options_from_spec(*spec, &out).ok());
  const PipelineOptions& o = out.pipeline;
  EXPECT_EQ(o.target_vertices, in.target_vertices);
  EXPECT_EQ(o.views.count, 14);
  EXPECT_EQ(o.views.resolution, 256);
  EXPECT_FALSE(o.views.pca_align);
  ASSERT_TRUE(o.views.user_rotation);
  EXPECT_EQ(*o.views.user_rotation, *in.views.user_rotation);
  EXPECT_EQ(o.sampling.seed, 42u);
  EXPECT_EQ(o.image.median_size, 5);
  EXPECT_EQ(o.image.gaussian_size, 9);
  EXPECT_EQ(o.image.gaussian_sigma, 1.5f);
  EXPECT_EQ(o.image.threshold_c, -2);
  EXPECT_EQ(o.image.skeleton_lambda, 6);
  EXPECT_EQ(o.image.thin_feature_px, 12.5f);
  EXPECT_EQ(o.field.k, 7);
  EXPECT_EQ(o.field.beta, 0.6f);
  EXPECT_EQ(o.field.min_importance, 0.3f);
  EXPECT_EQ(o.field.depth_scale, 2.0f);
  EXPECT_EQ(o.awlop.mu, 0.3f);
  EXPECT_EQ(o.awlop.k, 16);
  EXPECT_EQ(o.awlop.iterations, 25);
  EXPECT_EQ(o.awlop.attraction_samples_per_target, 4);
  EXPECT_EQ(o.awlop.support, AwlopSupport::kPaper);
  EXPECT_EQ(o.awlop.h_factor, 3.0f);
  EXPECT_EQ(o.anisotropy, 0.0);
}

TEST(JobSpec, DefaultOptionsRoundTripToDefaults) {
  PipelineOptions in;
  in.target_vertices = 1000;
  auto spec = make_job_spec(in);
  ASSERT_TRUE(spec.ok());
  JobOptions out;
  ASSERT_TRUE(job_options_from_spec(*spec, &out).ok());
  const PipelineOptions d;
  EXPECT_EQ(out.pipeline.views.count, d.views.count);
  EXPECT_EQ(out.pipeline.awlop.h_factor, d.awlop.h_factor);
  EXPECT_EQ(out.pipeline.field.min_importance, d.field.min_importance);
  EXPECT_EQ(out.pipeline.anisotropy, d.anisotropy);
  // A spec that never set it (an older client) gets the default too.
  v1::JobSpec old = *spec;
  old.mutable_options()->clear_anisotropy();
  ASSERT_TRUE(job_options_from_spec(old, &out).ok());
  EXPECT_EQ(out.pipeline.anisotropy, d.anisotropy);
}

// Each bad value is refused, and the message names the proto field.
struct BadField {
  const char* field;
  void (*set)(v1::JobSpec*);
};

class JobSpecValidation : public ::testing::TestWithParam<BadField> {};

TEST_P(JobSpecValidation, NamesTheField) {
  v1::JobSpec spec = spec_with_target(1000);
  GetParam().set(&spec);
  JobOptions o;
  const Status s = job_options_from_spec(spec, &o);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find(GetParam().field), std::string::npos) << s.message();
}

INSTANTIATE_TEST_SUITE_P(
    Fields, JobSpecValidation,
    ::testing::Values(
        BadField{"target_vertices", [](v1::JobSpec* s) { s->set_target_vertices(0); }},
        BadField{"target_vertices", [](v1::JobSpec* s) { s->set_target_vertices(99); }},
        BadField{"target_vertices", [](v1::JobSpec* s) { s->set_target_vertices(2'000'001); }},
        BadField{"priority", [](v1::JobSpec* s) { s->set_priority(11); }},
        BadField{"result_quantization_bits", [](v1::JobSpec* s) { s->set_result_quantization_bits(31); }},
        BadField{"device", [](v1::JobSpec* s) { s->set_device(v1::DevicePreference(7)); }},
        BadField{"input_format", [](v1::JobSpec* s) { s->set_input_format(v1::InputFormat(5)); }},
        BadField{"options.views", [](v1::JobSpec* s) { s->mutable_options()->set_views(8); }},
        BadField{"options.resolution", [](v1::JobSpec* s) { s->mutable_options()->set_resolution(32); }},
        BadField{"options.rotation", [](v1::JobSpec* s) { s->mutable_options()->add_rotation(1); }},
        BadField{"options.median_size", [](v1::JobSpec* s) { s->mutable_options()->set_median_size(4); }},
        BadField{"options.gaussian_size", [](v1::JobSpec* s) { s->mutable_options()->set_gaussian_size(65); }},
        BadField{"options.gaussian_sigma", [](v1::JobSpec* s) { s->mutable_options()->set_gaussian_sigma(-1); }},
        BadField{"options.gaussian_sigma", [](v1::JobSpec* s) { s->mutable_options()->set_gaussian_sigma(NAN); }},
        BadField{"options.skeleton_lambda", [](v1::JobSpec* s) { s->mutable_options()->set_skeleton_lambda(1); }},
        BadField{"options.knn", [](v1::JobSpec* s) { s->mutable_options()->set_knn(65); }},
        BadField{"options.beta", [](v1::JobSpec* s) { s->mutable_options()->set_beta(1.0f); }},
        BadField{"options.min_importance", [](v1::JobSpec* s) { s->mutable_options()->set_min_importance(1.5f); }},
        BadField{"options.depth_scale", [](v1::JobSpec* s) { s->mutable_options()->set_depth_scale(-1); }},
        BadField{"options.mu", [](v1::JobSpec* s) { s->mutable_options()->set_mu(0.6f); }},
        BadField{"options.awlop_k", [](v1::JobSpec* s) { s->mutable_options()->set_awlop_k(100); }},
        BadField{"options.awlop_iterations", [](v1::JobSpec* s) { s->mutable_options()->set_awlop_iterations(201); }},
        BadField{"options.awlop_samples", [](v1::JobSpec* s) { s->mutable_options()->set_awlop_samples(33); }},
        BadField{"options.awlop_support",
                 [](v1::JobSpec* s) { s->mutable_options()->set_awlop_support(v1::AwlopSupport(5)); }},
        BadField{"options.awlop_h_factor", [](v1::JobSpec* s) { s->mutable_options()->set_awlop_h_factor(-2); }},
        BadField{"options.anisotropy", [](v1::JobSpec* s) { s->mutable_options()->set_anisotropy(0.6f); }},
        BadField{"options.anisotropy", [](v1::JobSpec* s) { s->mutable_options()->set_anisotropy(NAN); }}));

TEST(JobSpec, ValuesThatZeroWouldHideCannotBeSent) {
  PipelineOptions o;
  o.target_vertices = 1000;
  o.sampling.seed = 0;
  EXPECT_EQ(make_job_spec(o).status().code(), StatusCode::kInvalidArgument);
  o.sampling.seed = 1;
  o.image.threshold_c = 0;
  const Status s = make_job_spec(o).status();
  EXPECT_NE(s.message().find("threshold_c"), std::string::npos) << s.message();
  o.image.threshold_c = 3;
  o.views.resolution = -5;  // would wrap to a huge uint32
  EXPECT_FALSE(make_job_spec(o).ok());
}

}  // namespace
}  // namespace vpr::service
