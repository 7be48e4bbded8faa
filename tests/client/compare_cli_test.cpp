// `vpremesh compare` through the real binary: every method in the table, each
// near the target vertex count with SSIM in (0, 1], the files of --out, and
// clear failures for bad input. And what scripts/quality.sh builds on: `vpremesh
// peers` writes each peer's mesh, `vpremesh eval --views-dir` the renderings.
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

// A unit cube, faces outward; `pull` moves the corner (1, 1, 1) out along the diagonal.
void write_cube(const fs::path& path, double pull) {
  std::ofstream f(path);
  for (int i = 0; i < 8; ++i) {
    const double s = i == 7 ? 1 + pull : 1;
    f << "v " << s * (i & 1) << ' ' << s * ((i >> 1) & 1) << ' ' << s * ((i >> 2) & 1) << "\n";
  }
  f << "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\n"
       "f 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
}

TEST(EvalCli, ViewsDirHoldsTheRenderingsSsimCompares) {
  const fs::path dir = fs::temp_directory_path() / ("vpremesh_views_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_cube(dir / "cube.obj", 0);
  write_cube(dir / "pulled.obj", 0.3);
  const int px = 96;
  const std::string common = " --resolution " + std::to_string(px) + " --samples 2000 --json --views-dir ";
  CliRun same = run_cli("eval " + (dir / "cube.obj").string() + " " + (dir / "cube.obj").string() + common +
                        (dir / "same").string());
  ASSERT_EQ(same.code, 0) << same.all();
  CliRun pulled = run_cli("eval " + (dir / "cube.obj").string() + " " + (dir / "pulled.obj").string() + common +
                          (dir / "pulled").string());
  ASSERT_EQ(pulled.code, 0) << pulled.all();
  EXPECT_LT(nlohmann::json::parse(pulled.out)["visual"]["ssim_mean"].get<double>(), 1.0);

  int differing = 0;
  for (int v = 0; v < 14; ++v) {
    char name[32];
    SCOPED_TRACE(v);
    for (const char* who : {"reference", "candidate"})
      for (const char* run : {"same", "pulled"}) {
        std::snprintf(name, sizeof name, "%s-%02d.png", who, v);
        const std::string png = slurp(dir / run / name);
        ASSERT_GT(png.size(), 24u) << run << "/" << name;
        EXPECT_EQ(png.substr(1, 3), "PNG");
        EXPECT_EQ(big_endian(png, 16), uint32_t(px));
        EXPECT_EQ(big_endian(png, 20), uint32_t(px));
      }
    std::snprintf(name, sizeof name, "-%02d.png", v);
    // The same mesh through the same cameras draws the same picture; the
    // reference is drawn the same in both runs.
    EXPECT_EQ(slurp(dir / "same" / ("reference" + std::string(name))),
              slurp(dir / "same" / ("candidate" + std::string(name))));
    EXPECT_EQ(slurp(dir / "same" / ("reference" + std::string(name))),
              slurp(dir / "pulled" / ("reference" + std::string(name))));
    differing += slurp(dir / "pulled" / ("reference" + std::string(name))) !=
                 slurp(dir / "pulled" / ("candidate" + std::string(name)));
  }
  EXPECT_GE(differing, 7);  // the pulled corner shows in at least the views that face it
  EXPECT_FALSE(fs::exists(dir / "same" / "reference-14.png"));
  EXPECT_EQ(run_cli("eval " + (dir / "cube.obj").string() + " " + (dir / "cube.obj").string() +
                    " --no-visual --views-dir " + (dir / "none").string())
                .code,
            2);
  fs::remove_all(dir);
}

TEST(PeersCli, WritesEachPeersMeshAtTheTarget) {
  const fs::path dir = fs::temp_directory_path() / ("vpremesh_peers_" + std::to_string(::getpid()));
  const int target = 800;
  CliRun r = run_cli("peers ../shared/models/spot.obj -n " + std::to_string(target) + " --only openmesh-qem --out " +
                     dir.string());
  ASSERT_EQ(r.code, 0) << r.all();
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["methods"].size(), 1u);
  const auto& m = j["methods"][0];
  EXPECT_EQ(m["method"], "OpenMesh QEM");
  ASSERT_TRUE(m["ok"].get<bool>()) << m.dump();
  EXPECT_EQ(m["file"], (dir / "openmesh-qem.ply").string());
  EXPECT_NEAR(m["vertices"].get<double>(), target, 0.02 * target);
  // The file holds the mesh that was reported.
  CliRun e = run_cli("eval ../shared/models/spot.obj " + (dir / "openmesh-qem.ply").string() +
                     " --no-visual --samples 2000 --json");
  ASSERT_EQ(e.code, 0) << e.all();
  const nlohmann::json q = nlohmann::json::parse(e.out)["candidate"];
  EXPECT_EQ(q["vertices"], m["vertices"]);
  EXPECT_EQ(q["faces"], m["faces"]);
  EXPECT_FALSE(fs::exists(dir / "cgal-isotropic.ply"));  // --only runs one peer

  EXPECT_EQ(run_cli("peers ../shared/models/spot.obj -n 800 --only qem --out " + dir.string()).code, 2);
  EXPECT_EQ(run_cli("peers no/such/file.obj -n 800 --out " + dir.string()).code, 7);
  fs::remove_all(dir);
}

}  // namespace
