// The service end to end: the real vpremesh-server on a free loopback port,
// driven by the real `vpremesh` client and by the C++ stubs. Every test starts
// its own server (ServerProcess stops it, also when the test fails).
#include <arpa/inet.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "grpc/health/v1/health.grpc.pb.h"
#include "grpc/reflection/v1alpha/reflection.grpc.pb.h"
#include "http_get.h"
#include "io/png_io.h"
#include "service_harness.h"
#include "test_meshes.h"

namespace fs = std::filesystem;

namespace vpr::testing {
namespace {

// A job that runs for seconds in stages of about a second each (14 views at
// 1024 px on the CPU twins, also where a GPU is): long enough to be caught
// running, short enough to cancel cheaply.
const char* const kHeavyModel = "../shared/models/spot.obj";
const char* const kHeavyFlags = "-n 2000 --views 14 --resolution 1024 --device cpu";

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vpremesh_service_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // START_SERVER stops the test at once when the server does not come up.
  std::unique_ptr<ServerProcess> start(const std::vector<std::string>& flags = {}) {
    return std::make_unique<ServerProcess>(flags);
  }

  fs::path dir_;
};

#define START_SERVER(var, ...)   \
  auto var = start(__VA_ARGS__); \
  ASSERT_TRUE(var->started()) << var->log()

// An icosphere as a GLB whose base-color texture (2 x 2 PNG, top row red,
// bottom row blue, clamped) maps by height: v = (1 - z) / 2.
std::string textured_sphere_glb() {
  const Mesh m = icosphere(3);
  const size_t nv = m.vertex_count();
  std::vector<float> uv;
  for (size_t v = 0; v < nv; ++v) uv.insert(uv.end(), {0.5f, 0.5f * (1 - m.positions[3 * v + 2])});
  const uint8_t rgb[12] = {255, 0, 0, 255, 0, 0, 0, 0, 255, 0, 0, 255};
  auto png = encode_rgb_png(2, 2, rgb);
  EXPECT_TRUE(png.ok());
  std::string bin(reinterpret_cast<const char*>(m.positions.data()), 12 * nv);
  bin.append(reinterpret_cast<const char*>(m.indices.data()), 4 * m.indices.size());
  bin.append(reinterpret_cast<const char*>(uv.data()), 8 * nv);
  const size_t at_png = bin.size();
  bin.append(png->begin(), png->end());
  while (bin.size() % 4) bin += '\0';
  nlohmann::json views = nlohmann::json::array();
  for (auto [offset, length] : std::vector<std::pair<size_t, size_t>>{{0, 12 * nv},
                                                                      {12 * nv, 4 * m.indices.size()},
                                                                      {12 * nv + 4 * m.indices.size(), 8 * nv},
                                                                      {at_png, png->size()}})
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}});
  const nlohmann::json root = {
      {"asset", {{"version", "2.0"}}},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 2}}}, {"indices", 1}, {"material", 0}}}}}}},
      {"materials", {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
      {"textures", {{{"source", 0}, {"sampler", 0}}}},
      {"samplers", {{{"wrapS", 33071}, {"wrapT", 33071}}}},
      {"images", {{{"bufferView", 3}, {"mimeType", "image/png"}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"}},
        {{"bufferView", 1}, {"componentType", 5125}, {"count", m.indices.size()}, {"type", "SCALAR"}},
        {{"bufferView", 2}, {"componentType", 5126}, {"count", nv}, {"type", "VEC2"}}}},
      {"bufferViews", views},
      {"buffers", {{{"byteLength", bin.size()}}}}};
  std::string text = root.dump();
  while (text.size() % 4) text += ' ';
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  return "glTF" + u32(2) + u32(uint32_t(28 + text.size() + bin.size())) + u32(uint32_t(text.size())) + "JSON" + text +
         u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
}

// A textured .glb goes to the server as it is (a Draco upload would carry no
// texture): the result has the texture's colors, the same file as local's.
TEST_F(ServiceTest, SubmitSendsATexturedGlbAsItIs) {
  START_SERVER(server);
  std::ofstream(path("sphere.glb"), std::ios::binary) << textured_sphere_glb();
  CliRun local = run_cli("local " + path("sphere.glb") + " -o " + path("local.drc") + " -n 300 --seed 7");
  ASSERT_EQ(local.code, 0) << local.err;
  CliRun remote = run_cli("submit " + path("sphere.glb") + " -o " + path("remote.drc") + " -n 300 --seed 7 --server " +
                          server->address());
  ASSERT_EQ(remote.code, 0) << remote.err << "\n" << server->log();
  auto file = [](const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  };
  EXPECT_TRUE(file(path("local.drc")) == file(path("remote.drc")));
  auto mesh = read_mesh(path("remote.drc"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  ASSERT_EQ(mesh->colors.size(), 3 * mesh->vertex_count());
  size_t checked = 0;
  for (size_t v = 0; v < mesh->vertex_count(); ++v) {
    const double z = mesh->absolute(v, 2);
    if (std::abs(z) < 0.6) continue;  // the bilinear blend between the rows
    ++checked;
    const uint8_t expected[3] = {uint8_t(z > 0 ? 255 : 0), 0, uint8_t(z > 0 ? 0 : 255)};
    for (int c = 0; c < 3; ++c) EXPECT_EQ(mesh->colors[3 * v + c], expected[c]) << "vertex " << v;
  }
  EXPECT_GT(checked, 50u);
}

// `vpremesh submit` gives what `vpremesh local` gives with the same seed:
// the same vertices at the same positions. status, watch and cancel then
// answer for the finished job.
TEST_F(ServiceTest, SubmitEqualsLocalAndJobCommandsAnswer) {
  START_SERVER(server, {"--metrics-listen", "127.0.0.1:0"});
  const std::string model = "../shared/models/spot.obj";
  CliRun local = run_cli("local " + model + " -o " + path("local.drc") + " -n 800 --seed 7 --json --field-out " +
                         path("local_field.ply"));
  ASSERT_EQ(local.code, 0) << local.err;
  CliRun remote = run_cli("submit " + model + " -o " + path("remote.drc") + " -n 800 --seed 7 --json --server " +
                          server->address() + " --field-out " + path("field.ply"));
  ASSERT_EQ(remote.code, 0) << remote.err << "\n" << server->log();
  EXPECT_EQ(remote.err, "");  // --json: no progress lines

  const nlohmann::json lj = nlohmann::json::parse(local.out), rj = nlohmann::json::parse(remote.out);
  EXPECT_EQ(rj["input"]["vertices"], 2930);
  EXPECT_EQ(rj["output"]["vertices"], lj["output"]["vertices"]);
  EXPECT_EQ(rj["output"]["faces"], lj["output"]["faces"]);
  std::vector<std::string> stages;
  for (const auto& s : rj["stages"]) stages.push_back(s["name"]);
  for (const char* stage :
       {"read", "upload", "queue", "render", "image_saliency", "saliency_field", "cvt", "meshing", "write"})
    EXPECT_NE(std::find(stages.begin(), stages.end(), stage), stages.end()) << stage << "\n" << remote.out;

  auto a = read_mesh(path("local.drc")), b = read_mesh(path("remote.drc"));
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->vertex_count(), b->vertex_count());
  EXPECT_EQ(b->vertex_count(), size_t(rj["output"]["vertices"]));
  const auto pa = sorted_positions(*a), pb = sorted_positions(*b);
  size_t differing = 0;
  for (size_t i = 0; i < pa.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (std::abs(pa[i][k] - pb[i][k]) > 1e-5f) ++differing;
  EXPECT_EQ(differing, 0u);
  // remesh.proto: the default result quantization is local's, so the files match.
  auto file = [](const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  };
  EXPECT_TRUE(file(path("local.drc")) == file(path("remote.drc")));
  auto saliency = read_saliency(path("remote.drc"));
  ASSERT_TRUE(saliency.ok());
  EXPECT_EQ(saliency->size(), b->vertex_count());
  // --field-out: the input mesh colored by its field, the same file as local's.
  auto field = read_saliency(path("field.ply"));
  ASSERT_TRUE(field.ok()) << field.status().to_string();
  EXPECT_EQ(field->size(), size_t(rj["input"]["vertices"]));
  EXPECT_TRUE(file(path("local_field.ply")) == file(path("field.ply")));

  const std::string job = rj["job_id"];
  const std::string at = " --server " + server->address();
  CliRun status = run_cli("status " + job + at + " --json");
  ASSERT_EQ(status.code, 0) << status.err;
  const nlohmann::json sj = nlohmann::json::parse(status.out);
  EXPECT_EQ(sj["state"], "JOB_STATE_SUCCEEDED");
  EXPECT_EQ(sj["summary"]["output_vertices"], rj["output"]["vertices"]);

  // watch replays the whole job; off a terminal, each stage is a plain line.
  CliRun watch = run_cli("watch " + job + at + " -o " + path("watched.ply"));
  ASSERT_EQ(watch.code, 0) << watch.err;
  EXPECT_EQ(watch.err.find('\r'), std::string::npos);
  EXPECT_NE(watch.err.find("job " + job + ": stage 1 "), std::string::npos) << watch.err;
  EXPECT_NE(watch.err.find("completed"), std::string::npos) << watch.err;
  EXPECT_NE(watch.out.find("queue "), std::string::npos) << watch.out;
  EXPECT_NE(watch.out.find("meshing"), std::string::npos) << watch.out;
  auto watched = read_mesh(path("watched.ply"));
  ASSERT_TRUE(watched.ok());
  EXPECT_EQ(watched->vertex_count(), b->vertex_count());

  // Cancelling a finished job changes nothing.
  CliRun cancel = run_cli("cancel " + job + at);
  EXPECT_EQ(cancel.code, 0) << cancel.err;
  EXPECT_NE(cancel.out.find("SUCCEEDED"), std::string::npos) << cancel.out;

  CliRun unknown = run_cli("status no-such-job" + at);
  EXPECT_EQ(unknown.code, 7) << unknown.err;
  EXPECT_NE(unknown.err.find("vpremesh: NOT_FOUND: "), std::string::npos) << unknown.err;

  // The process that ran the job answers /metrics (and keeps serving) with
  // what it did.
  const int port = testing::metrics_port(server->log());
  ASSERT_GT(port, 0) << server->log();
  const std::string page = testing::http_get(port, "/metrics");
  EXPECT_EQ(page.rfind("HTTP/1.1 200 OK\r\n", 0), 0u) << page;
  EXPECT_EQ(testing::sample(page, "vpremesh_jobs_submitted_total"), 1) << page;
  EXPECT_EQ(testing::sample(page, "vpremesh_jobs_finished_total{state=\"succeeded\"}"), 1) << page;
  EXPECT_GE(testing::sample(page, "vpremesh_workers"), 1) << page;
  EXPECT_NE(testing::http_get(port, "/metrics").find("vpremesh_queue_length 0\n"), std::string::npos);
  EXPECT_EQ(page.find("vpremesh_queue_workers"), std::string::npos) << "the embedded queue knows no fleet";
  EXPECT_EQ(run_cli("status " + job + at).code, 0) << server->log();
}

// Sixteen jobs at once, each with its own target: every one completes, with
// its own result (no job gets another's mesh), and the first equals a local
// run on the same upload.
// Issue 19 through the service: a Draco upload of a model 1e6 away (64-bit
// positions) or resized by 1e-6 comes back as the plain model's result moved
// or resized, and stray vertices are ignored and reported.
TEST_F(ServiceTest, FarAndResizedUploadsGiveTheSameResultTransformed) {
  START_SERVER(server);
  struct Case {
    const char* name;
    double scale, shift;
    int strays;
  };
  const Case cases[] = {{"plain", 1, 0, 0}, {"moved", 1, 1e6, 0}, {"tiny", 1e-6, 0, 0}, {"strays", 1, 0, 100}};
  std::vector<Mesh> out;
  for (const Case& c : cases) {
    const std::string obj = path(std::string(c.name) + ".obj");
    std::ofstream(obj) << bumpy_sphere_obj(c.scale, c.shift, c.strays);
    // The upload is Draco: convert first, so the server gets the file as given.
    const std::string drc = path(std::string(c.name) + ".drc");
    auto mesh = read_mesh(obj);
    ASSERT_TRUE(mesh.ok());
    ASSERT_TRUE(write_mesh(drc, *mesh, nullptr, DracoOptions{0, 10, 10}).ok());
    CliRun r = run_cli("submit " + drc + " -o " + path(std::string(c.name) + "_out.drc") +
                       " -n 300 --json --result-quantization-bits 30 --server " + server->address());
    ASSERT_EQ(r.code, 0) << c.name << ": " << r.err << "\n" << server->log();
    EXPECT_EQ(nlohmann::json::parse(r.out)["ignored_vertices"], c.strays) << c.name;
    auto back = read_mesh(path(std::string(c.name) + "_out.drc"));
    ASSERT_TRUE(back.ok()) << back.status().to_string();
    out.push_back(std::move(back).value());
  }
  const Mesh& plain = out[0];
  for (size_t i = 1; i < out.size(); ++i) {
    const Case& c = cases[i];
    ASSERT_EQ(out[i].vertex_count(), plain.vertex_count()) << c.name;
    ASSERT_EQ(out[i].face_count(), plain.face_count()) << c.name;
    // Sequential connectivity keeps the order: vertex by vertex.
    double worst = 0;
    for (size_t v = 0; v < plain.vertex_count(); ++v)
      for (int a = 0; a < 3; ++a)
        worst = std::max(worst, std::fabs((out[i].absolute(v, a) - c.shift) / c.scale - plain.absolute(v, a)));
    std::printf("  %-7s max deviation %.3g of the diagonal\n", c.name, worst / plain.scale);
    EXPECT_LT(worst, 1e-5 * plain.scale) << c.name;
  }
}

TEST_F(ServiceTest, SixteenConcurrentJobsAllComplete) {
  START_SERVER(server, {"--workers", "2", "--max-jobs-per-client", "16"});
  const std::vector<uint8_t> sphere = lossless_draco(icosphere(3));
  ASSERT_FALSE(sphere.empty());
  write_file(path("sphere.drc"), sphere);
  auto stub = make_stub(server->address());
  constexpr int kJobs = 16;
  auto target = [](int i) { return uint32_t(300 + 20 * i); };
  std::vector<std::future<RemeshOutcome>> jobs;
  for (int i = 0; i < kJobs; ++i)
    jobs.push_back(
        std::async(std::launch::async, [&, i] { return remesh(*stub, make_spec(target(i), sphere.size()), sphere); }));
  std::vector<RemeshOutcome> results;
  for (auto& j : jobs) results.push_back(j.get());

  std::set<std::string> ids;
  for (int i = 0; i < kJobs; ++i) {
    const RemeshOutcome& r = results[i];
    ASSERT_TRUE(r.status.ok()) << i << ": " << r.status.error_message() << "\n" << server->log();
    ASSERT_TRUE(r.completed()) << i;
    ids.insert(r.job_id);
    auto mesh = parse_mesh(reinterpret_cast<const uint8_t*>(r.result.data()), r.result.size(), MeshFormat::kDraco);
    ASSERT_TRUE(mesh.ok()) << i << ": " << mesh.status().to_string();
    EXPECT_EQ(mesh->vertex_count(), r.last()->completed().output_vertices()) << i;
    EXPECT_EQ(r.saliency.size(), mesh->vertex_count()) << i;
    // Within 2% of its own target, which is 20 vertices from the next one's.
    EXPECT_LE(std::abs(double(mesh->vertex_count()) - target(i)), 0.02 * target(i)) << i;
    EXPECT_EQ(r.last()->completed().input_vertices(), 642u) << i;
  }
  EXPECT_EQ(ids.size(), size_t(kJobs));

  CliRun local = run_cli("local " + path("sphere.drc") + " -o " + path("local.drc") + " -n 300 --json");
  ASSERT_EQ(local.code, 0) << local.err;
  auto a = read_mesh(path("local.drc"));
  auto b = parse_mesh(reinterpret_cast<const uint8_t*>(results[0].result.data()), results[0].result.size(),
                      MeshFormat::kDraco);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->vertex_count(), b->vertex_count());
  const auto pa = sorted_positions(*a), pb = sorted_positions(*b);
  for (size_t i = 0; i < pa.size(); ++i)
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(pa[i][k], pb[i][k], 1e-5f) << i;
}

// `vpremesh cancel` stops a running job; `vpremesh watch` on it ends with
// CANCELLED and exit code 6.
TEST_F(ServiceTest, CancelWhileRunning) {
  START_SERVER(server, {"--workers", "1"});
  const std::string at = " --server " + server->address();
  CliRun submit = run_cli(std::string("submit ") + kHeavyModel + " " + kHeavyFlags + " --no-wait" + at);
  ASSERT_EQ(submit.code, 0) << submit.err;
  const std::string job = submit.out.substr(0, submit.out.find('\n'));
  ASSERT_FALSE(job.empty());
  auto stub = make_stub(server->address());
  ASSERT_TRUE(wait_for_state(*stub, job, [](v1::JobState s) { return s != v1::JOB_STATE_QUEUED; }));
  ASSERT_EQ(get_job(*stub, job).state(), v1::JOB_STATE_RUNNING);

  auto watch = std::async(std::launch::async, [&] { return run_cli("watch " + job + at + " -o " + path("w.ply")); });
  CliRun cancel = run_cli("cancel " + job + at);
  EXPECT_EQ(cancel.code, 0) << cancel.err;
  const CliRun watched = watch.get();
  EXPECT_EQ(watched.code, 6) << watched.out << watched.err;
  EXPECT_NE(watched.err.find("vpremesh: CANCELLED: "), std::string::npos) << watched.err;
  EXPECT_FALSE(fs::exists(path("w.ply")));

  ASSERT_TRUE(wait_for_state(*stub, job, is_terminal));
  EXPECT_EQ(get_job(*stub, job).state(), v1::JOB_STATE_CANCELLED);
  CliRun status = run_cli("status " + job + at);
  EXPECT_EQ(status.code, 0);
  EXPECT_NE(status.out.find("CANCELLED"), std::string::npos) << status.out;
}

// A deadline shorter than the job: DEADLINE_EXCEEDED (exit 8), the job is
// stopped, and the server goes on serving.
TEST_F(ServiceTest, DeadlineShorterThanTheJob) {
  START_SERVER(server, {"--workers", "1"});
  const std::string at = " --server " + server->address();
  CliRun late = run_cli(std::string("submit ") + kHeavyModel + " -o " + path("late.ply") + " " + kHeavyFlags +
                        " --deadline 0.3" + at);
  EXPECT_EQ(late.code, 8) << late.out << late.err;
  EXPECT_NE(late.err.find("vpremesh: DEADLINE_EXCEEDED: "), std::string::npos) << late.err;
  EXPECT_FALSE(fs::exists(path("late.ply")));

  // The job id is on the progress lines ("job ID: queued, ...").
  const size_t at_job = late.err.find("job ");
  ASSERT_NE(at_job, std::string::npos) << late.err;
  const std::string job = late.err.substr(at_job + 4, late.err.find(':', at_job) - at_job - 4);
  auto stub = make_stub(server->address());
  ASSERT_TRUE(wait_for_state(*stub, job, is_terminal));
  EXPECT_NE(get_job(*stub, job).state(), v1::JOB_STATE_SUCCEEDED);

  CliRun next = run_cli("submit ../shared/models/suzanne.obj -o " + path("next.ply") + " -n 300" + at);
  EXPECT_EQ(next.code, 0) << next.err << "\n" << server->log();
  auto mesh = read_mesh(path("next.ply"));
  ASSERT_TRUE(mesh.ok());
  EXPECT_NEAR(double(mesh->vertex_count()), 300.0, 6.0);
}

// Uploads over --max-upload-mib: refused before the bytes are sent when the
// size is declared (the CLI), and while they arrive when it is not.
TEST_F(ServiceTest, UploadOverTheLimitIsResourceExhausted) {
  START_SERVER(server, {"--max-upload-mib", "1"});
  const std::vector<uint8_t> big = lossless_draco(icosphere(7));  // 163,842 vertices, about 2 MiB
  ASSERT_GT(big.size(), size_t(1) << 20);
  write_file(path("big.drc"), big);
  CliRun r = run_cli("submit " + path("big.drc") + " -o " + path("o.ply") + " -n 1000 --server " + server->address());
  EXPECT_EQ(r.code, 4) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.rfind("vpremesh: RESOURCE_EXHAUSTED: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("1.0 MiB"), std::string::npos) << r.err;

  auto stub = make_stub(server->address());
  RemeshOutcome undeclared = remesh(*stub, make_spec(1000, 0), big);
  EXPECT_EQ(undeclared.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << undeclared.status.error_message();
  EXPECT_NE(undeclared.status.error_message().find("1.0 MiB"), std::string::npos) << undeclared.status.error_message();

  // The server is still there.
  RemeshOutcome small = remesh(*stub, make_spec(300, 0), lossless_draco(icosphere(3)));
  EXPECT_TRUE(small.status.ok() && small.completed()) << small.status.error_message();
}

// Bytes that start like Draco but are not: INVALID_ARGUMENT (exit 3).
TEST_F(ServiceTest, CorruptDracoIsInvalidArgument) {
  START_SERVER(server);
  const std::string corrupt = std::string("DRACO\x02\x02\x01\x01\x00\x00garbage", 18);
  write_file(path("corrupt.drc"), std::vector<uint8_t>(corrupt.begin(), corrupt.end()));
  CliRun r =
      run_cli("submit " + path("corrupt.drc") + " -o " + path("o.ply") + " -n 500 --server " + server->address());
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("vpremesh: INVALID_ARGUMENT: "), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("o.ply")));

  auto stub = make_stub(server->address());
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  RemeshOutcome obj = remesh(*stub, make_spec(500, text.size()), std::vector<uint8_t>(text.begin(), text.end()));
  EXPECT_EQ(obj.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << obj.status.error_message();
}

// The GLB container around a JSON document and a BIN chunk (glTF 2.0, 4.4).
std::vector<uint8_t> glb_with(const nlohmann::json& root, std::string bin) {
  std::string text = root.dump();
  while (text.size() % 4) text += ' ';
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const std::string out = "glTF" + u32(2) + u32(uint32_t(28 + text.size() + bin.size())) + u32(uint32_t(text.size())) +
                          "JSON" + text + u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
  return std::vector<uint8_t>(out.begin(), out.end());
}

// input_format INPUT_FORMAT_GLTF_BINARY: a Draco-compressed .glb remeshes;
// the same bytes as Draco, and a .glb declaring 1e9 indices in 23 KB, are
// refused with one line each, and the server goes on serving.
TEST_F(ServiceTest, GltfBinaryUploads) {
  START_SERVER(server);
  auto stub = make_stub(server->address());
  const Mesh sphere = icosphere(3);  // 642 vertices
  auto glb = encode_gltf(sphere, nullptr, DracoOptions{}, true);
  ASSERT_TRUE(glb.ok()) << glb.status().to_string();
  v1::JobSpec spec = make_spec(300, glb->size());
  spec.set_input_format(v1::INPUT_FORMAT_GLTF_BINARY);
  RemeshOutcome good = remesh(*stub, spec, *glb);
  ASSERT_TRUE(good.status.ok() && good.completed()) << good.status.error_message();
  EXPECT_EQ(good.last()->completed().input_vertices(), 642u);
  auto result =
      parse_mesh(reinterpret_cast<const uint8_t*>(good.result.data()), good.result.size(), MeshFormat::kDraco);
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  EXPECT_NEAR(double(result->vertex_count()), 300.0, 6.0);
  EXPECT_EQ(good.saliency.size(), result->vertex_count());

  RemeshOutcome as_draco = remesh(*stub, make_spec(300, glb->size()), *glb);
  EXPECT_EQ(as_draco.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(as_draco.status.error_message().find("not a Draco file"), std::string::npos)
      << as_draco.status.error_message();

  // Plain accessors, then the index accessor's count raised to 1e9.
  DracoOptions plain;
  plain.gltf_draco = false;
  auto bytes = encode_gltf(sphere, nullptr, plain, true);
  ASSERT_TRUE(bytes.ok());
  uint32_t json_size = 0;
  std::memcpy(&json_size, bytes->data() + 12, 4);
  nlohmann::json root = nlohmann::json::parse(bytes->begin() + 20, bytes->begin() + 20 + json_size);
  root["accessors"][1]["count"] = 1000000000;
  const size_t bin_at = 20 + json_size + 8;
  const std::vector<uint8_t> hostile =
      glb_with(root, std::string(bytes->begin() + std::ptrdiff_t(bin_at), bytes->end()));
  ASSERT_LT(hostile.size(), size_t(1) << 16);
  v1::JobSpec hostile_spec = make_spec(300, hostile.size());
  hostile_spec.set_input_format(v1::INPUT_FORMAT_GLTF_BINARY);
  RemeshOutcome refused = remesh(*stub, hostile_spec, hostile);
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.status.error_message();
  EXPECT_NE(refused.status.error_message().find("the limit is"), std::string::npos) << refused.status.error_message();
  EXPECT_EQ(refused.status.error_message().find('\n'), std::string::npos) << refused.status.error_message();

  RemeshOutcome again = remesh(*stub, spec, *glb);
  EXPECT_TRUE(again.status.ok() && again.completed()) << again.status.error_message();
}

// A level-of-detail chain through the service (issue 20): three meshes with
// the asked counts, streamed level by level, each with its field and each
// equal to `vpremesh submit --lod`'s files; the front-half stages run once.
// A bad level list is INVALID_ARGUMENT before any event.
TEST_F(ServiceTest, LevelsOfDetailStreamLevelByLevel) {
  START_SERVER(server);
  auto stub = make_stub(server->address());
  const Mesh sphere = icosphere(4);  // 2,562 vertices
  const std::vector<uint8_t> drc = lossless_draco(sphere);
  v1::JobSpec spec = make_spec(0, drc.size());
  for (const auto& [vertices, fraction] : {std::pair{1200u, 0.0}, std::pair{0u, 0.25}, std::pair{300u, 0.0}}) {
    v1::LevelTarget* l = spec.add_levels();
    l->set_vertices(vertices);
    l->set_fraction(fraction);
  }
  RemeshOutcome out = remesh(*stub, spec, drc, [](const v1::JobEvent&) {});
  ASSERT_TRUE(out.status.ok() && out.completed()) << out.status.error_message() << "\n" << server->log();
  const uint32_t asked[3] = {1200, 641, 300};
  std::map<uint32_t, std::string> meshes;
  std::map<uint32_t, size_t> fields;
  std::map<std::string, int> front_stages;
  uint32_t last_level = 0;
  for (const v1::JobEvent& e : out.events) {
    uint32_t level = last_level;
    if (e.has_result()) level = e.result().level(), meshes[level] += e.result().data();
    if (e.has_saliency()) level = e.saliency().level(), fields[level] += size_t(e.saliency().values_size());
    if (e.has_stage() && e.stage().front_half()) ++front_stages[e.stage().name()];
    if (e.has_stage() && !e.stage().front_half()) level = e.stage().level();
    EXPECT_GE(level, last_level) << "levels arrive in order";
    last_level = level;
  }
  for (const char* name : {"views", "render", "image_saliency", "saliency_field"})
    EXPECT_EQ(front_stages[name], 1) << name;
  const v1::Completed& done = out.last()->completed();
  ASSERT_EQ(done.levels_size(), 3);
  for (uint32_t i = 0; i < 3; ++i) {
    auto mesh = parse_mesh(reinterpret_cast<const uint8_t*>(meshes[i].data()), meshes[i].size(), MeshFormat::kDraco);
    ASSERT_TRUE(mesh.ok()) << "level " << i << ": " << mesh.status().to_string();
    EXPECT_NEAR(double(mesh->vertex_count()), asked[i], 0.02 * asked[i]) << "level " << i;
    EXPECT_EQ(fields[i], mesh->vertex_count()) << "level " << i;
    EXPECT_EQ(done.levels(int(i)).target_vertices(), asked[i]);
    EXPECT_EQ(done.levels(int(i)).output_vertices(), mesh->vertex_count());
    EXPECT_EQ(done.levels(int(i)).result_bytes(), meshes[i].size());
  }

  // The CLI writes one file per level, the same meshes.
  write_file(path("sphere.drc"), drc);
  CliRun cli = run_cli("submit " + path("sphere.drc") + " --lod 1200,0.25,300 -o " + path("out.drc") +
                       " --quantization-bits 0 --server " + server->address());
  ASSERT_EQ(cli.code, 0) << cli.err << "\n" << server->log();
  for (uint32_t i = 0; i < 3; ++i) {
    std::ifstream f(path("out.lod" + std::to_string(i) + ".drc"), std::ios::binary);
    EXPECT_TRUE(std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()) == meshes[i])
        << "level " << i;
  }

  v1::JobSpec bad = make_spec(0, drc.size());
  bad.add_levels()->set_fraction(1.5);
  RemeshOutcome refused = remesh(*stub, bad, drc, [](const v1::JobEvent&) {});
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused.status.error_message().find("levels: level 0: fraction 1.5"), std::string::npos)
      << refused.status.error_message();
  EXPECT_TRUE(refused.events.empty());
  v1::JobSpec both = make_spec(500, drc.size());
  both.add_levels()->set_vertices(300);
  EXPECT_EQ(remesh(*stub, both, drc, [](const v1::JobEvent&) {}).status.error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
}

// --max-queue 1 --workers 1: one job runs, one waits, the next is refused.
TEST_F(ServiceTest, FullQueueIsResourceExhausted) {
  START_SERVER(server, {"--max-queue", "1", "--workers", "1", "--max-jobs-per-client", "8"});
  const std::string at = " --server " + server->address();
  auto stub = make_stub(server->address());
  CliRun first = run_cli(std::string("submit ") + kHeavyModel + " " + kHeavyFlags + " --no-wait" + at);
  ASSERT_EQ(first.code, 0) << first.err;
  const std::string running = first.out.substr(0, first.out.find('\n'));
  ASSERT_TRUE(wait_for_state(*stub, running, [](v1::JobState s) { return s != v1::JOB_STATE_QUEUED; }));
  CliRun second = run_cli(std::string("submit ") + kHeavyModel + " " + kHeavyFlags + " --no-wait --json" + at);
  ASSERT_EQ(second.code, 0) << second.err;
  const std::string waiting = nlohmann::json::parse(second.out)["job_id"];
  EXPECT_EQ(get_job(*stub, waiting).state(), v1::JOB_STATE_QUEUED);

  CliRun third = run_cli(std::string("submit ") + kHeavyModel + " " + kHeavyFlags + " --no-wait" + at);
  EXPECT_EQ(third.code, 4) << third.out << third.err;
  EXPECT_EQ(third.err.rfind("vpremesh: RESOURCE_EXHAUSTED: ", 0), 0u) << third.err;
  EXPECT_NE(third.err.find("--max-queue"), std::string::npos) << third.err;

  for (const std::string& job : {waiting, running}) EXPECT_EQ(run_cli("cancel " + job + at).code, 0);
}

// SIGTERM while a job runs and two wait: the running one finishes, the
// waiting ones fail UNAVAILABLE, health turns away from SERVING, and the
// server exits 0.
TEST_F(ServiceTest, SigtermDrains) {
  START_SERVER(server, {"--workers", "1", "--max-jobs-per-client", "8"});
  auto stub = make_stub(server->address());
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  auto health = grpc::health::v1::Health::NewStub(channel);
  auto check = [&](grpc::health::v1::HealthCheckResponse* response) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    return health->Check(&context, grpc::health::v1::HealthCheckRequest(), response);
  };
  grpc::health::v1::HealthCheckResponse response;
  ASSERT_TRUE(check(&response).ok());
  EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::SERVING);

  // A job that runs for seconds (14 views at 1024 px on the CPU), and two behind it.
  auto spot = read_mesh("../shared/models/spot.obj");
  ASSERT_TRUE(spot.ok());
  const std::vector<uint8_t> upload = lossless_draco(*spot);
  std::promise<void> started, queued1, queued2;
  auto signal_on = [](std::promise<void>& p, bool (v1::JobEvent::*has)() const) {
    return [&p, has, done = std::make_shared<bool>(false)](const v1::JobEvent& e) {
      if (!*done && (e.*has)()) {
        *done = true;
        p.set_value();
      }
    };
  };
  v1::JobSpec heavy = make_spec(1500, upload.size());
  heavy.mutable_options()->set_views(14);
  heavy.mutable_options()->set_resolution(1024);
  heavy.set_device(v1::DEVICE_CPU);
  auto running = std::async(
      std::launch::async, [&] { return remesh(*stub, heavy, upload, signal_on(started, &v1::JobEvent::has_started)); });
  ASSERT_EQ(started.get_future().wait_for(kJobLimit), std::future_status::ready);
  auto waiting1 = std::async(std::launch::async, [&] {
    return remesh(*stub, make_spec(1500, upload.size()), upload, signal_on(queued1, &v1::JobEvent::has_queued));
  });
  auto waiting2 = std::async(std::launch::async, [&] {
    return remesh(*stub, make_spec(1500, upload.size()), upload, signal_on(queued2, &v1::JobEvent::has_queued));
  });
  ASSERT_EQ(queued1.get_future().wait_for(kJobLimit), std::future_status::ready);
  ASSERT_EQ(queued2.get_future().wait_for(kJobLimit), std::future_status::ready);

  auto exit_code = std::async(std::launch::async, [&] { return server->terminate(); });
  // Draining: health answers NOT_SERVING while the running job finishes, or
  // the server already refuses new calls.
  const auto give_up = std::chrono::steady_clock::now() + kJobLimit;
  grpc::Status health_status;
  do {
    health_status = check(&response);
  } while (health_status.ok() && response.status() == grpc::health::v1::HealthCheckResponse::SERVING &&
           std::chrono::steady_clock::now() < give_up);
  if (health_status.ok())
    EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::NOT_SERVING);
  else
    EXPECT_EQ(health_status.error_code(), grpc::StatusCode::UNAVAILABLE) << health_status.error_message();

  const RemeshOutcome done = running.get();
  EXPECT_TRUE(done.status.ok()) << done.status.error_message();
  EXPECT_TRUE(done.completed());
  EXPECT_FALSE(done.result.empty());
  for (auto* f : {&waiting1, &waiting2}) {
    const RemeshOutcome r = f->get();
    const bool failed_event =
        r.last() && r.last()->has_failed() && r.last()->failed().code() == int(grpc::StatusCode::UNAVAILABLE);
    EXPECT_TRUE(failed_event || r.status.error_code() == grpc::StatusCode::UNAVAILABLE)
        << r.status.error_code() << " " << r.status.error_message();
    EXPECT_FALSE(r.completed());
  }
  EXPECT_EQ(exit_code.get(), 0) << server->log();
}

// Health answers SERVING; reflection lists the service and serves its
// descriptor; a client with no server gets UNAVAILABLE (exit 5).
TEST_F(ServiceTest, HealthReflectionAndUnreachableServer) {
  START_SERVER(server);
  auto channel = grpc::CreateChannel(server->address(), grpc::InsecureChannelCredentials());
  {
    auto health = grpc::health::v1::Health::NewStub(channel);
    grpc::ClientContext context;
    grpc::health::v1::HealthCheckRequest request;
    grpc::health::v1::HealthCheckResponse response;
    ASSERT_TRUE(health->Check(&context, request, &response).ok());
    EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::SERVING);
  }
  namespace refl = grpc::reflection::v1alpha;
  auto reflection = refl::ServerReflection::NewStub(channel);
  grpc::ClientContext context;
  auto stream = reflection->ServerReflectionInfo(&context);
  refl::ServerReflectionRequest request;
  request.set_list_services("");
  ASSERT_TRUE(stream->Write(request));
  refl::ServerReflectionResponse response;
  ASSERT_TRUE(stream->Read(&response));
  std::set<std::string> services;
  for (const auto& s : response.list_services_response().service()) services.insert(s.name());
  EXPECT_TRUE(services.count("vpremesh.v1.RemeshService")) << response.DebugString();
  EXPECT_TRUE(services.count("grpc.health.v1.Health")) << response.DebugString();

  request.set_file_containing_symbol("vpremesh.v1.RemeshService");
  ASSERT_TRUE(stream->Write(request));
  ASSERT_TRUE(stream->Read(&response));
  ASSERT_GT(response.file_descriptor_response().file_descriptor_proto_size(), 0) << response.DebugString();
  google::protobuf::FileDescriptorProto file;
  ASSERT_TRUE(file.ParseFromString(response.file_descriptor_response().file_descriptor_proto(0)));
  EXPECT_EQ(file.package(), "vpremesh.v1");
  std::set<std::string> methods;
  for (const auto& service : file.service())
    if (service.name() == "RemeshService")
      for (const auto& m : service.method()) methods.insert(m.name());
  EXPECT_EQ(methods, (std::set<std::string>{"Remesh", "Submit", "Watch", "GetJob", "CancelJob"}));
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());

  // A port nothing listens on: bound, then closed.
  const std::string closed = vpr::testing::closed_loopback_address();
  ASSERT_FALSE(closed.empty());
  CliRun r = run_cli("status some-job --server " + closed);
  EXPECT_EQ(r.code, 5) << r.err;
  EXPECT_EQ(r.err.rfind("vpremesh: UNAVAILABLE: cannot reach the server at " + closed, 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
}  // namespace vpr::testing
