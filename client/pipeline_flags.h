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
  // Levels of detail (issue 20): --lod COUNT|FRACTION,... and --min-ssim S.
  std::string lod;
  bool levels_one_at_a_time = false;  // --levels-one-at-a-time
  std::string tries_ahead = "auto";    // --tries-ahead auto|on|both|off
  bool cold_tries = false;             // --cold-tries
  double min_ssim = 0;
  uint32_t screen_px = 0;
};

// -n/--target-vertices, views, seed, rotation and the paper's constants
// (Sections III-V), each bound to `o` with its default.
void add_pipeline_flags(CLI::App* cmd, PipelineOptions& o, PipelineFlagValues& values);

// Applies the converted flags to `o`; INVALID_ARGUMENT for a bad rotation.
Status apply_pipeline_flags(const PipelineFlagValues& values, PipelineOptions* o);

// The job's levels: -n alone is one level; --lod gives a list (whole numbers
// are vertex counts, numbers in (0, 1] fractions of the input's vertices) and
// --min-ssim adds a level with a visual target after them. INVALID_ARGUMENT
// for none of them, -n with the others, or a malformed list (check_levels).
StatusOr<std::vector<LevelTarget>> levels_from_flags(const PipelineFlagValues& values, const PipelineOptions& o);

// Where level N of a chain is written: out.ply -> out.lod0.ply, out.lod1.ply,
// ... (the extension keeps the format).
std::string level_path(const std::string& output, size_t level);

// "20000,5000,0.1" -> levels; INVALID_ARGUMENT naming the bad item.
StatusOr<std::vector<LevelTarget>> parse_level_list(const std::string& list);

}  // namespace vpr::cli
