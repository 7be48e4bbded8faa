// The pipeline's options as command-line flags, shared by `local` and
// `submit` so both take the same names and defaults.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"

namespace vpr::cli {

// Flags that need a conversion after parsing.
struct PipelineFlagValues {
  std::string awlop_support = "target";
  std::string density = "curvature";
  bool no_pca = false;
  bool image_cue = false;
  std::vector<double> rotation;
};

// -n/--target-vertices, views, seed, rotation and the paper's constants
// (Sections III-V), each bound to `o` with its default.
void add_pipeline_flags(CLI::App* cmd, PipelineOptions& o, PipelineFlagValues& values);

// Applies the converted flags to `o`; INVALID_ARGUMENT for a bad rotation.
Status apply_pipeline_flags(const PipelineFlagValues& values, PipelineOptions* o);

}  // namespace vpr::cli
