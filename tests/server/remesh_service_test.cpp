// The RPCs end to end, in this process: a real gRPC server on a free loopback
// port, the embedded queue and a CPU worker, driven through the generated
// stub. The result must be byte-identical to what `vpremesh local` writes
// (read the Draco file, run_pipeline, encode_draco with its defaults).
#include "server/remesh_service.h"

#include <draco/compression/expert_encode.h>
#include <draco/mesh/mesh.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <thread>

#include "io/mesh_io.h"
#include "server/embedded_queue.h"
#include "server/worker_pool.h"
#include "test_meshes.h"

namespace vpr::service {
namespace {

struct Server {
  MetricsRegistry registry;
  ServiceMetrics metrics{registry};
  std::unique_ptr<EmbeddedQueue> queue;
  std::unique_ptr<WorkerPool> pool;
  std::unique_ptr<RemeshServiceImpl> service;
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<v1::RemeshService::Stub> stub;

  explicit Server(int workers, ServerLimits limits = {}) {
    EmbeddedQueueOptions qo;
    qo.limits = limits;
    queue = std::make_unique<EmbeddedQueue>(qo);
    WorkerPoolOptions wo;
    wo.workers = workers;
    wo.device = DevicePolicy::kCpu;
    wo.limits = limits;
    pool = std::make_unique<WorkerPool>(*queue, wo, &metrics);
    std::string why;
    EXPECT_EQ(pool->start(&why), size_t(workers)) << why;
    ServiceConfig config;
    config.limits = limits;
    service = std::make_unique<RemeshServiceImpl>(*queue, config, &metrics);
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(service.get());
    server = builder.BuildAndStart();
    EXPECT_GT(port, 0);
    stub = v1::RemeshService::NewStub(
        grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
  }
  ~Server() {
    queue->close();
    server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(1));
    pool->join();
  }
};

std::vector<uint8_t> draco_sphere() {
  DracoOptions lossless_enough;
  lossless_enough.speed = 10;  // keeps vertices and faces as given
  auto bytes = encode_draco(testing::icosphere(3), nullptr, lossless_enough);
  EXPECT_TRUE(bytes.ok());
  return *bytes;
}

v1::JobSpec small_spec() {
  v1::JobSpec spec;
  spec.set_target_vertices(300);
  spec.set_return_mesh(true);
  spec.set_return_saliency(true);
  spec.mutable_options()->set_resolution(128);
  spec.mutable_options()->set_seed(7);
  return spec;
}

std::vector<v1::RemeshRequest> upload(const v1::JobSpec& spec, const std::vector<uint8_t>& mesh,
                                      size_t chunk = kMaxChunkBytes) {
  std::vector<v1::RemeshRequest> out(1);
  *out[0].mutable_spec() = spec;
  for (size_t o = 0; o < mesh.size(); o += chunk) {
    out.emplace_back();
    out.back().set_mesh_chunk(mesh.data() + o, std::min(chunk, mesh.size() - o));
  }
  return out;
}

struct Outcome {
  grpc::Status status;
  std::vector<v1::JobEvent> events;
};

Outcome remesh(Server& s, const std::vector<v1::RemeshRequest>& requests,
               std::chrono::milliseconds timeout = std::chrono::minutes(5)) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + timeout);
  auto stream = s.stub->Remesh(&ctx);
  for (const auto& r : requests)
    if (!stream->Write(r)) break;
  stream->WritesDone();
  Outcome out;
  v1::JobEvent e;
  while (stream->Read(&e)) out.events.push_back(e);
  out.status = stream->Finish();
  return out;
}

grpc::Status submit(Server& s, const std::vector<v1::RemeshRequest>& requests, std::string* id) {
  grpc::ClientContext ctx;
  v1::JobRef ref;
  auto writer = s.stub->Submit(&ctx, &ref);
  for (const auto& r : requests)
    if (!writer->Write(r)) break;
  writer->WritesDone();
  grpc::Status st = writer->Finish();
  *id = ref.job_id();
  return st;
}

Outcome watch(Server& s, const std::string& id) {
  grpc::ClientContext ctx;
  v1::JobRef ref;
  ref.set_job_id(id);
  auto reader = s.stub->Watch(&ctx, ref);
  Outcome out;
  v1::JobEvent e;
  while (reader->Read(&e)) out.events.push_back(e);
  out.status = reader->Finish();
  return out;
}

TEST(RemeshService, RemeshStreamsTheSameResultAsVpremeshLocal) {
  Server s(1);
  const std::vector<uint8_t> mesh = draco_sphere();
  const Outcome out = remesh(s, upload(small_spec(), mesh, 1000));  // several chunks
  ASSERT_TRUE(out.status.ok()) << out.status.error_message();

  // queued, started, one stage each, payloads, completed; sequences 0, 1, 2, ...
  ASSERT_GE(out.events.size(), 5u);
  EXPECT_TRUE(out.events.front().has_queued());
  EXPECT_TRUE(out.events[1].has_started());
  EXPECT_EQ(out.events[1].started().device(), "cpu");
  std::vector<std::string> stages;
  std::string result;
  std::vector<float> saliency;
  for (size_t i = 0; i < out.events.size(); ++i) {
    const v1::JobEvent& e = out.events[i];
    EXPECT_EQ(e.sequence(), i);
    if (e.has_stage()) stages.push_back(e.stage().name());
    if (e.has_result()) {
      EXPECT_EQ(e.result().offset(), result.size());
      EXPECT_LE(e.result().data().size(), kMaxChunkBytes);
      result += e.result().data();
    }
    if (e.has_saliency()) {
      EXPECT_EQ(e.saliency().offset(), saliency.size());
      saliency.insert(saliency.end(), e.saliency().values().begin(), e.saliency().values().end());
    }
  }
  ASSERT_TRUE(out.events.back().has_completed());
  const v1::Completed& done = out.events.back().completed();
  EXPECT_EQ(stages, (std::vector<std::string>{"views", "render", "image_saliency", "unproject", "visibility",
                                              "saliency_field", "density", "cvt", "meshing"}));
  EXPECT_EQ(done.input_vertices(), 642u);
  EXPECT_EQ(done.result_bytes(), result.size());
  EXPECT_EQ(saliency.size(), done.output_vertices());
  EXPECT_NEAR(double(done.output_vertices()), 300.0, 6.0);
  EXPECT_GE(done.total_ms(), done.run_ms());

  // What `vpremesh local in.drc -o out.drc --seed 7 --resolution 128 -n 300` computes.
  auto input = parse_mesh(mesh.data(), mesh.size(), MeshFormat::kDraco);
  ASSERT_TRUE(input.ok());
  PipelineOptions local;
  local.target_vertices = 300;
  local.views.resolution = 128;
  local.sampling.seed = 7;
  auto expected = run_pipeline(*input, local);
  ASSERT_TRUE(expected.ok()) << expected.status().to_string();
  auto expected_bytes = encode_draco(expected->mesh, expected->saliency.data(), DracoOptions{});
  ASSERT_TRUE(expected_bytes.ok());
  EXPECT_EQ(result, std::string(expected_bytes->begin(), expected_bytes->end()));
  EXPECT_EQ(saliency, expected->saliency);

  // Watch replays the whole history of the finished job.
  const Outcome replay = watch(s, out.events[0].job_id());
  EXPECT_TRUE(replay.status.ok());
  ASSERT_EQ(replay.events.size(), out.events.size());
  for (size_t i = 0; i < out.events.size(); ++i)
    EXPECT_EQ(replay.events[i].SerializeAsString(), out.events[i].SerializeAsString());
}

// The optional payloads: the saliency points (x, y, z in the input's units),
// the per-view debug PNGs and the field on the input mesh.
// Issue 16: a caller that sets no payload switch gets the mesh and one
// saliency value per output vertex; one that says false gets the summary.
TEST(RemeshService, ResultAndSaliencyComeBackUnlessTurnedOff) {
  Server s(1);
  const std::vector<uint8_t> mesh = draco_sphere();
  for (int explicit_off : {0, 1}) {
    v1::JobSpec spec = small_spec();
    spec.clear_return_mesh();
    spec.clear_return_saliency();
    if (explicit_off) {
      spec.set_return_mesh(false);
      spec.set_return_saliency(false);
    }
    const Outcome out = remesh(s, upload(spec, mesh));
    ASSERT_TRUE(out.status.ok()) << out.status.error_message();
    ASSERT_TRUE(out.events.back().has_completed());
    std::string result;
    size_t saliency = 0;
    for (const v1::JobEvent& e : out.events) {
      if (e.has_result()) result += e.result().data();
      if (e.has_saliency()) saliency += size_t(e.saliency().values_size());
    }
    const uint32_t vertices = out.events.back().completed().output_vertices();
    if (explicit_off) {
      EXPECT_TRUE(result.empty());
      EXPECT_EQ(saliency, 0u);
      continue;
    }
    auto decoded = parse_mesh(reinterpret_cast<const uint8_t*>(result.data()), result.size(), MeshFormat::kDraco);
    ASSERT_TRUE(decoded.ok()) << decoded.status().to_string();
    EXPECT_EQ(decoded->vertex_count(), vertices);
    EXPECT_EQ(saliency, size_t(vertices));
  }
}

// An upload with vertex colors, as Draco and as GLB: the result's Draco file
// carries colors for every output vertex, red on top and blue below as the
// input's, and the job ran a colors stage.
TEST(RemeshService, ColorsOfTheUploadComeBackInTheResult) {
  Server s(1);
  Mesh sphere = testing::icosphere(3);
  for (size_t v = 0; v < sphere.vertex_count(); ++v) {
    const bool top = sphere.positions[3 * v + 2] > 0;
    sphere.colors.insert(sphere.colors.end(), {uint8_t(top ? 255 : 0), 0, uint8_t(top ? 0 : 255)});
  }
  DracoOptions sequential;
  sequential.speed = 10;
  DracoOptions plain;
  plain.gltf_draco = false;
  for (bool glb : {false, true}) {
    auto bytes = glb ? encode_gltf(sphere, nullptr, plain, true) : encode_draco(sphere, nullptr, sequential);
    ASSERT_TRUE(bytes.ok());
    v1::JobSpec spec = small_spec();
    if (glb) spec.set_input_format(v1::INPUT_FORMAT_GLTF_BINARY);
    const Outcome out = remesh(s, upload(spec, *bytes));
    ASSERT_TRUE(out.status.ok()) << out.status.error_message();
    ASSERT_TRUE(out.events.back().has_completed()) << out.events.back().DebugString();
    std::string result;
    bool colors_stage = false;
    for (const v1::JobEvent& e : out.events) {
      if (e.has_result()) result += e.result().data();
      if (e.has_stage() && e.stage().name() == "colors") colors_stage = true;
    }
    EXPECT_TRUE(colors_stage) << (glb ? "GLB" : "Draco");
    auto decoded = parse_mesh(reinterpret_cast<const uint8_t*>(result.data()), result.size(), MeshFormat::kDraco);
    ASSERT_TRUE(decoded.ok()) << decoded.status().to_string();
    ASSERT_EQ(decoded->colors.size(), 3 * decoded->vertex_count());
    // Away from the equator each vertex is one of the two colors exactly.
    size_t checked = 0;
    for (size_t v = 0; v < decoded->vertex_count(); ++v) {
      const double z = decoded->absolute(v, 2);
      if (std::abs(z) < 0.2) continue;
      ++checked;
      const uint8_t* c = &decoded->colors[3 * v];
      EXPECT_EQ(c[0], z > 0 ? 255 : 0) << "vertex " << v;
      EXPECT_EQ(c[2], z > 0 ? 0 : 255) << "vertex " << v;
    }
    EXPECT_GT(checked, 200u);
  }
}

TEST(RemeshService, ReturnsSaliencyPointsDebugImagesAndTheInputField) {
  Server s(1);
  const std::vector<uint8_t> mesh = draco_sphere();
  v1::JobSpec spec = small_spec();
  spec.set_return_saliency_points(true);
  spec.set_return_debug_images(true);
  spec.set_return_input_saliency(true);
  const Outcome out = remesh(s, upload(spec, mesh));
  ASSERT_TRUE(out.status.ok()) << out.status.error_message();
  ASSERT_TRUE(out.events.back().has_completed());
  const v1::Completed& done = out.events.back().completed();

  std::vector<float> points, field;
  std::vector<std::string> images;
  for (const v1::JobEvent& e : out.events) {
    if (e.has_saliency_points()) {
      EXPECT_EQ(e.saliency_points().offset(), points.size());
      EXPECT_LE(size_t(e.saliency_points().values_size()) * sizeof(float), kMaxChunkBytes);
      points.insert(points.end(), e.saliency_points().values().begin(), e.saliency_points().values().end());
    }
    if (e.has_input_saliency()) {
      EXPECT_EQ(e.input_saliency().offset(), field.size());
      field.insert(field.end(), e.input_saliency().values().begin(), e.input_saliency().values().end());
    }
    if (e.has_debug_image()) {
      EXPECT_FALSE(e.debug_image().name().empty());
      EXPECT_EQ(e.debug_image().png().substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << e.debug_image().name();
      images.push_back(e.debug_image().name());
    }
  }

  // Saliency points: 3 floats each, on the input's surface (its bounding box, grown by 1%).
  auto input = parse_mesh(mesh.data(), mesh.size(), MeshFormat::kDraco);
  ASSERT_TRUE(input.ok());
  ASSERT_GT(done.saliency_points(), 0u);
  EXPECT_EQ(points.size(), 3 * done.saliency_points());
  const std::vector<float> positions = absolute_positions(*input);  // the points are in the input's units
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = positions[a];
  for (size_t i = 0; i < positions.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], positions[i]);
    hi[i % 3] = std::max(hi[i % 3], positions[i]);
  }
  size_t outside = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const int a = int(i % 3);
    const float margin = 0.01f * (hi[a] - lo[a]);
    if (!std::isfinite(points[i]) || points[i] < lo[a] - margin || points[i] > hi[a] + margin) ++outside;
  }
  EXPECT_EQ(outside, 0u);

  // Debug images: six views, several PNGs each.
  EXPECT_GE(images.size(), 6u);
  EXPECT_NE(std::find(images.begin(), images.end(), "view_px_overlay.png"), images.end());

  // The input field: one value per input vertex, in [min_importance, 1].
  ASSERT_EQ(field.size(), input->vertex_count());
  const float min_importance = PipelineOptions{}.field.min_importance;
  for (float v : field) {
    EXPECT_GE(v, min_importance);
    EXPECT_LE(v, 1.0f);
  }

  // The job's temporary debug directory is gone.
  const std::string prefix = "vpremesh-debug-" + out.events[0].job_id() + "-";
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::temp_directory_path()))
    EXPECT_NE(entry.path().filename().string().rfind(prefix, 0), 0u) << entry.path();
}

TEST(RemeshService, BadUploadsAreInvalidArgumentWithTheReason) {
  Server s(1);
  const std::vector<uint8_t> mesh = draco_sphere();
  auto expect = [&](const std::vector<v1::RemeshRequest>& requests, grpc::StatusCode code, const std::string& needle) {
    const Outcome out = remesh(s, requests);
    EXPECT_EQ(out.status.error_code(), code) << out.status.error_message();
    EXPECT_NE(out.status.error_message().find(needle), std::string::npos) << out.status.error_message();
  };
  expect(upload(small_spec(), {}), grpc::StatusCode::INVALID_ARGUMENT, "empty");
  const std::vector<uint8_t> ply = {'p', 'l', 'y', '\n', '1', '2', '3'};
  expect(upload(small_spec(), ply), grpc::StatusCode::INVALID_ARGUMENT, "not a Draco file");
  // A Draco header followed by garbage: the worker's decoder refuses it.
  std::vector<uint8_t> corrupt(mesh.begin(), mesh.begin() + 20);
  corrupt.resize(200, 0xAB);
  const Outcome bad = remesh(s, upload(small_spec(), corrupt));
  EXPECT_EQ(bad.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << bad.status.error_message();
  ASSERT_FALSE(bad.events.empty());
  EXPECT_TRUE(bad.events.back().has_failed());
  EXPECT_NE(bad.events.back().failed().message().find("Draco"), std::string::npos);

  v1::JobSpec spec = small_spec();
  spec.mutable_options()->set_median_size(4);
  expect(upload(spec, mesh), grpc::StatusCode::INVALID_ARGUMENT, "options.median_size");
  std::vector<v1::RemeshRequest> chunk_first = upload(small_spec(), mesh);
  chunk_first.erase(chunk_first.begin());
  expect(chunk_first, grpc::StatusCode::INVALID_ARGUMENT, "first RemeshRequest must carry the spec");
  spec = small_spec();
  spec.set_mesh_size_bytes(mesh.size() + 1);
  expect(upload(spec, mesh), grpc::StatusCode::INVALID_ARGUMENT, "mesh_size_bytes");
  spec.set_device(v1::DEVICE_CUDA);
  expect(upload(spec, mesh), grpc::StatusCode::FAILED_PRECONDITION, "DEVICE_CUDA");
  // The server is still there.
  EXPECT_TRUE(remesh(s, upload(small_spec(), mesh)).status.ok());
}

TEST(RemeshService, LimitsAreResourceExhaustedNamingTheFlag) {
  ServerLimits limits;
  limits.max_upload_bytes = 2u << 20;
  limits.max_queue = 1;
  limits.max_jobs_per_client = 10;
  Server s(0, limits);  // no worker: jobs stay queued
  std::string id;
  std::vector<uint8_t> big(3u << 20, 0);
  big[0] = 'D';
  grpc::Status st = submit(s, upload(small_spec(), big), &id);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(st.error_message().find("--max-upload-mib 2"), std::string::npos) << st.error_message();
  st = submit(s, upload(small_spec(), draco_sphere(), kMaxChunkBytes + 1), &id);
  EXPECT_TRUE(st.ok()) << st.error_message();  // the sphere is smaller than one chunk
  std::vector<uint8_t> two_mib((2u << 20) - 8, 'x');
  std::copy_n("DRACO", 5, two_mib.begin());
  st = submit(s, upload(small_spec(), two_mib, kMaxChunkBytes + 8), &id);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("chunk"), std::string::npos) << st.error_message();
  st = submit(s, upload(small_spec(), draco_sphere()), &id);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(st.error_message().find("--max-queue"), std::string::npos) << st.error_message();
}

TEST(RemeshService, CancelJobEndsAQueuedJobAndWatchSeesIt) {
  Server s(0);
  std::string id;
  ASSERT_TRUE(submit(s, upload(small_spec(), draco_sphere()), &id).ok());
  grpc::ClientContext ctx;
  v1::JobRef ref;
  ref.set_job_id(id);
  v1::JobStatus status;
  ASSERT_TRUE(s.stub->GetJob(&ctx, ref, &status).ok());
  EXPECT_EQ(status.state(), v1::JOB_STATE_QUEUED);
  grpc::ClientContext ctx2;
  ASSERT_TRUE(s.stub->CancelJob(&ctx2, ref, &status).ok());
  EXPECT_EQ(status.state(), v1::JOB_STATE_CANCELLED);
  const Outcome w = watch(s, id);
  EXPECT_EQ(w.status.error_code(), grpc::StatusCode::CANCELLED);
  ASSERT_EQ(w.events.size(), 2u);
  EXPECT_TRUE(w.events[1].has_cancelled());
  const Outcome missing = watch(s, "j-unknown");
  EXPECT_EQ(missing.status.error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST(RemeshService, RemeshDeadlineCancelsTheJob) {
  Server s(0);  // nothing runs, so the deadline passes while queued
  const Outcome out = remesh(s, upload(small_spec(), draco_sphere()), std::chrono::milliseconds(300));
  EXPECT_EQ(out.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  ASSERT_FALSE(out.events.empty());
  const std::string id = out.events[0].job_id();
  // The server notices the deadline on its own side; wait for it (bounded).
  v1::JobStatus status;
  for (int i = 0; i < 200 && status.state() != v1::JOB_STATE_CANCELLED; ++i) {
    grpc::ClientContext ctx;
    v1::JobRef ref;
    ref.set_job_id(id);
    ASSERT_TRUE(s.stub->GetJob(&ctx, ref, &status).ok());
    if (status.state() != v1::JOB_STATE_CANCELLED) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(status.state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(status.failure().code(), int(grpc::StatusCode::DEADLINE_EXCEEDED)) << status.failure().message();
}

TEST(RunJob, CancelledRunningJobStopsAtAStageBoundary) {
  EmbeddedQueue queue(EmbeddedQueueOptions{});
  JobSubmission sub;
  sub.spec = small_spec();
  sub.mesh = draco_sphere();
  auto id = queue.submit(std::move(sub));
  ASSERT_TRUE(id.ok());
  auto job = queue.claim("test-worker");
  ASSERT_TRUE(job);
  (void)queue.cancel(*id, Status(StatusCode::kCancelled, "stop please"));
  WorkerContext ctx;
  ctx.name = "test-worker";
  run_job(queue, std::move(*job), ctx);
  auto status = queue.status(*id);
  EXPECT_EQ(status->state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(status->failure().message(), "stop please");
  auto events = queue.events(*id, 0, 100);
  for (const auto& e : events->events) EXPECT_FALSE(e.has_stage() || e.has_result());  // stopped before any stage
}

// Draco files that encode_draco would never write: raw float positions
// (which may be NaN), or a point cloud with no faces.
std::vector<uint8_t> raw_draco(const Mesh& m, bool with_faces) {
  std::unique_ptr<draco::PointCloud> pc;
  if (with_faces) {
    auto mesh = std::make_unique<draco::Mesh>();
    mesh->SetNumFaces(m.face_count());
    for (size_t f = 0; f < m.face_count(); ++f) {
      draco::Mesh::Face face;
      for (int k = 0; k < 3; ++k) face[k] = draco::PointIndex(m.indices[3 * f + k]);
      mesh->SetFace(draco::FaceIndex(uint32_t(f)), face);
    }
    pc = std::move(mesh);
  } else {
    pc = std::make_unique<draco::PointCloud>();
  }
  pc->set_num_points(uint32_t(m.vertex_count()));
  draco::GeometryAttribute pos;
  pos.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, sizeof(float) * 3, 0);
  const int id = pc->AddAttribute(pos, true, uint32_t(m.vertex_count()));
  for (size_t i = 0; i < m.vertex_count(); ++i)
    pc->attribute(id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)), &m.positions[3 * i]);
  // The Mesh overload encodes connectivity; the PointCloud one does not.
  auto encoder = with_faces ? std::make_unique<draco::ExpertEncoder>(static_cast<const draco::Mesh&>(*pc))
                            : std::make_unique<draco::ExpertEncoder>(*pc);
  encoder->SetSpeedOptions(10, 10);  // sequential, no quantization: floats as they are
  draco::EncoderBuffer out;
  EXPECT_TRUE(encoder->EncodeToBuffer(&out).ok());
  return std::vector<uint8_t>(out.data(), out.data() + out.size());
}

v1::JobStatus run_one(const std::vector<uint8_t>& bytes) {
  EmbeddedQueue queue(EmbeddedQueueOptions{});
  JobSubmission sub;
  sub.spec = small_spec();
  sub.mesh = bytes;
  auto id = queue.submit(std::move(sub));
  auto job = queue.claim("w");
  run_job(queue, std::move(*job), WorkerContext{});
  return *queue.status(*id);
}

TEST(RunJob, NanCoordinatesAndPointCloudsFailWithTheReason) {
  Mesh m = testing::icosphere(1);
  m.positions[4] = NAN;
  v1::JobStatus nan = run_one(raw_draco(m, true));
  EXPECT_EQ(nan.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(nan.failure().code(), int(grpc::StatusCode::INVALID_ARGUMENT)) << nan.failure().message();
  EXPECT_NE(nan.failure().message().find("finite"), std::string::npos) << nan.failure().message();

  v1::JobStatus cloud = run_one(raw_draco(testing::icosphere(1), false));
  EXPECT_EQ(cloud.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(cloud.failure().code(), int(grpc::StatusCode::INVALID_ARGUMENT)) << cloud.failure().message();
  EXPECT_NE(cloud.failure().message().find("point cloud"), std::string::npos) << cloud.failure().message();
}

TEST(RunJob, VertexLimitNamesTheFlag) {
  EmbeddedQueue queue(EmbeddedQueueOptions{});
  JobSubmission sub;
  sub.spec = small_spec();
  sub.mesh = draco_sphere();  // 642 vertices
  auto id = queue.submit(std::move(sub));
  auto job = queue.claim("w");
  WorkerContext ctx;
  ctx.limits.max_vertices = 500;
  run_job(queue, std::move(*job), ctx);
  v1::JobStatus st = *queue.status(*id);
  EXPECT_EQ(st.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(st.failure().code(), int(grpc::StatusCode::RESOURCE_EXHAUSTED)) << st.failure().message();
  EXPECT_NE(st.failure().message().find("--max-vertices 500"), std::string::npos) << st.failure().message();
}

}  // namespace
}  // namespace vpr::service
