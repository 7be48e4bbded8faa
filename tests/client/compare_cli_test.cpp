// `vpremesh compare` through the real binary: every method in the table, each
// near the target vertex count with SSIM in (0, 1], the files of --out, and
// clear failures for bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.h"

namespace fs = std::filesystem;

namespace {

using vpr::testing::CliRun;
using vpr::testing::run_cli;

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

uint32_t big_endian(const std::string& s, size_t at) {
  return (uint32_t(uint8_t(s[at])) << 24) | (uint32_t(uint8_t(s[at + 1])) << 16) | (uint32_t(uint8_t(s[at + 2])) << 8) |
         uint32_t(uint8_t(s[at + 3]));
}

TEST(CompareCli, EveryMethodNearTheTargetWithSsimInRange) {
  const fs::path dir = fs::temp_directory_path() / ("vpremesh_compare_" + std::to_string(::getpid()));
  const int target = 800;
  CliRun r = run_cli("compare ../shared/models/spot.obj --target-vertices " + std::to_string(target) +
                     " --resolution 192 --samples 20000 --tile 64 --json --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["target_vertices"], target);
  const char* expected[] = {"vpremesh (ours)", "OpenMesh QEM", "meshoptimizer", "CGAL isotropic"};
  ASSERT_EQ(j["methods"].size(), std::size(expected));
  for (size_t i = 0; i < std::size(expected); ++i) {
    const auto& m = j["methods"][i];
    SCOPED_TRACE(expected[i]);
    EXPECT_EQ(m["method"], expected[i]);
    ASSERT_TRUE(m["ok"].get<bool>()) << m.dump();
    EXPECT_NEAR(m["vertices"].get<double>(), target, 0.02 * target) << m["note"];
    for (const char* key : {"ssim_mean", "ssim_worst", "line_ssim_mean", "line_ssim_worst"}) {
      EXPECT_GT(m[key].get<double>(), 0.0) << key;
      EXPECT_LE(m[key].get<double>(), 1.0) << key;
    }
    EXPECT_LE(m["ssim_worst"].get<double>(), m["ssim_mean"].get<double>());
    EXPECT_EQ(m["per_view"].size(), 14u);
    EXPECT_GT(m["hausdorff_max"].get<double>(), 0.0);
    EXPECT_LT(m["hausdorff_mean"].get<double>(), 0.01);  // every method stays on spot's surface
    EXPECT_EQ(m["non_manifold_edges"], 0);
  }

  const std::string md = slurp(dir / "table.md"), csv = slurp(dir / "table.csv");
  for (const char* name : expected) {
    EXPECT_NE(md.find(std::string("| ") + name + " |"), std::string::npos) << name;
    EXPECT_NE(csv.find(std::string(name) + ","), std::string::npos) << name;
  }
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5);  // header + four methods
  // Contact sheet: 3 views x (heat map, input, 4 methods) tiles of 64 px with 2 px gutters.
  const std::string png = slurp(dir / "contact_sheet.png");
  ASSERT_GT(png.size(), 24u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_EQ(big_endian(png, 16), 6u * 66 + 2);
  EXPECT_EQ(big_endian(png, 20), 3u * 66 + 2);
  fs::remove_all(dir);
}

TEST(CompareCli, BadInputGetsItsExitCode) {
  EXPECT_EQ(run_cli("compare no/such/file.obj --target-vertices 500").code, 7);
  EXPECT_EQ(run_cli("compare ../shared/models/spot.obj --target-vertices 5").code, 3);
  EXPECT_EQ(run_cli("compare ../shared/models/spot.obj").code, 2);
}

}  // namespace
