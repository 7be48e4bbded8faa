// The Python client (python_client.py, on stubs generated from remesh.proto
// at build time) against the real server: a mesh in, `completed` out, and the
// Draco file it wrote read back here.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "service_harness.h"
#include "test_meshes.h"

namespace fs = std::filesystem;

namespace vpr::testing {
namespace {

TEST(PythonClient, RemeshesASmallMesh) {
  const fs::path dir = fs::temp_directory_path() / ("vpremesh_python_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  ServerProcess server({"--workers", "1"});
  ASSERT_TRUE(server.started()) << server.log();
  const std::string mesh = (dir / "sphere.drc").string(), out = (dir / "result.drc").string();
  write_file(mesh, lossless_draco(icosphere(3)));

  const std::string cmd = "PYTHONPATH='" VPR_PYTHON_STUBS "' '" VPR_PYTHON "' '" VPR_PYTHON_CLIENT "' --server " +
                          server.address() + " --mesh " + mesh + " --target 300 --out " + out;
  std::string stdout_text;
  FILE* pipe = ::popen((cmd + " 2>&1").c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) stdout_text.append(buf, n);
  const int status = ::pclose(pipe);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << stdout_text << "\n" << server.log();

  const nlohmann::json j = nlohmann::json::parse(stdout_text);
  EXPECT_EQ(j["input_vertices"], 642);
  auto result = read_mesh(out);
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  EXPECT_EQ(result->vertex_count(), size_t(j["output_vertices"]));
  EXPECT_NEAR(double(result->vertex_count()), 300.0, 6.0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vpr::testing
