// The Python package (client/python) against the real server: installed
// with pip, offline, into a fresh virtual environment on the system's Python
// (Debian's python3-grpcio and python3-protobuf), then driven by
// python_package_test.py over TLS with a tenant's token. The Draco file the
// package returned is decoded here.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "auth_harness.h"
#include "test_meshes.h"

namespace fs = std::filesystem;

namespace vpr::testing {
namespace {

// Runs a command line; its exit code, with its output in *output.
int run(const std::string& command, std::string* output) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return -1;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) output->append(buf, n);
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// client/python and proto/ side by side, as in the repository, so that the
// package's build finds the proto where a user's `pip install
// ./client/python` does, without writing its build folder into the source.
void copy_package(const fs::path& root, const fs::path& to) {
  fs::create_directories(to / "client");
  const auto skip_builds = [](const fs::path& p) {
    const std::string name = p.filename().string();
    return name == "build" || name.find(".egg-info") != std::string::npos || name == "__pycache__" ||
           name.find("_pb2") != std::string::npos;
  };
  for (auto it = fs::recursive_directory_iterator(root / "client" / "python"); it != fs::end(it); ++it) {
    if (skip_builds(it->path())) {
      it.disable_recursion_pending();
      continue;
    }
    const fs::path target = to / "client" / "python" / fs::relative(it->path(), root / "client" / "python");
    if (it->is_directory())
      fs::create_directories(target);
    else
      fs::copy_file(it->path(), target);
  }
  fs::copy(root / "proto", to / "proto", fs::copy_options::recursive);
}

TEST(PythonPackage, InstallsOfflineAndDrivesTheServer) {
  const fs::path dir = fs::temp_directory_path() / ("vpremesh_python_package_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "out");
  ASSERT_TRUE(make_certificates(dir.string()));
  const std::string token = "python-package-token";
  write_tokens((dir / "tokens.txt").string(), {{"pytest", token}});
  write_file((dir / "small.drc").string(), lossless_draco(icosphere(3)));
  write_file((dir / "large.drc").string(), lossless_draco(icosphere(5)));
  ServerProcess server({"--workers", "1", "--device", "cpu", "--auth-tokens", (dir / "tokens.txt").string(),
                        "--tls-cert", (dir / "server.pem").string(), "--tls-key", (dir / "server.key").string()});
  ASSERT_TRUE(server.started()) << server.log();
  // Mutual TLS: only clients with a certificate signed by ca.pem get through.
  ServerProcess mtls({"--workers", "1", "--device", "cpu", "--tls-cert", (dir / "server.pem").string(), "--tls-key",
                      (dir / "server.key").string(), "--tls-client-ca", (dir / "ca.pem").string()});
  ASSERT_TRUE(mtls.started()) << mtls.log();

  // --without-pip and the system's pip (--python) spare ensurepip's seconds;
  // --no-index proves no network is needed; --no-build-isolation builds with
  // the system's setuptools and wheel.
  copy_package(VPR_SOURCE_DIR, dir / "src");
  const std::string venv = (dir / "venv").string(), python = venv + "/bin/python";
  std::string log;
  ASSERT_EQ(run("'" VPR_PYTHON "' -m venv --system-site-packages --without-pip '" + venv + "'", &log), 0) << log;
  ASSERT_EQ(run("'" VPR_PYTHON "' -m pip --python '" + python +
                    "' install --quiet --no-index --no-build-isolation --no-cache-dir --disable-pip-version-check '" +
                    (dir / "src" / "client" / "python").string() + "'",
                &log),
            0)
      << log;

  const std::string env = "VPR_SERVER=" + server.address() + " VPR_MTLS_SERVER=" + mtls.address() +
                          " VPR_CERTS=" + dir.string() + " VPR_TOKEN=" + token +
                          " VPR_TLS_CA=" + (dir / "ca.pem").string() + " VPR_SMALL=" + (dir / "small.drc").string() +
                          " VPR_LARGE=" + (dir / "large.drc").string() + " VPR_OUT=" + (dir / "out").string();
  const int code = run(env + " '" + python + "' '" VPR_SOURCE_DIR "/tests/service/python_package_test.py'", &log);
  ASSERT_EQ(code, 0) << log << "\n" << server.log();
  std::printf("%s", log.c_str());  // which Python tests ran

  std::ifstream summary(dir / "out" / "result.json");
  const nlohmann::json j = nlohmann::json::parse(summary);
  auto result = read_mesh((dir / "out" / "result.drc").string());
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  EXPECT_EQ(result->vertex_count(), size_t(j["output_vertices"]));
  EXPECT_EQ(result->vertex_count(), size_t(j["saliency_values"]));
  EXPECT_NEAR(double(result->vertex_count()), double(j["target"]), 0.02 * double(j["target"]));
  EXPECT_GT(result->face_count(), 0u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vpr::testing
