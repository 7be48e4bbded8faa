// Every limit refuses just past its value and names itself (flag and value).
#include "server/limits.h"

#include <gtest/gtest.h>

namespace vpr::service {
namespace {

void expect_names(const Status& s, StatusCode code, const std::string& needle) {
  EXPECT_EQ(s.code(), code) << s.to_string();
  EXPECT_NE(s.message().find(needle), std::string::npos) << "'" << needle << "' missing from: " << s.message();
}

TEST(Limits, UploadSize) {
  ServerLimits l;
  l.max_upload_bytes = uint64_t(8) << 20;
  EXPECT_TRUE(check_upload_size(l, l.max_upload_bytes, false).ok());
  expect_names(check_upload_size(l, l.max_upload_bytes + 1, false), StatusCode::kResourceExhausted,
               "--max-upload-mib 8");
  expect_names(check_upload_size(l, uint64_t(9) << 20, true), StatusCode::kResourceExhausted, "declared");
}

TEST(Limits, ChunkSize) {
  EXPECT_TRUE(check_chunk(kMaxChunkBytes).ok());
  expect_names(check_chunk(kMaxChunkBytes + 1), StatusCode::kInvalidArgument, "1 MiB");
}

TEST(Limits, TargetRange) {
  ServerLimits l;
  l.max_target_vertices = 50'000;
  EXPECT_TRUE(check_target(l, 50'000).ok());
  EXPECT_TRUE(check_target(l, kMinTargetVertices).ok());
  expect_names(check_target(l, 50'001), StatusCode::kInvalidArgument, "--max-target-vertices 50000");
  expect_names(check_target(l, kMinTargetVertices - 1), StatusCode::kInvalidArgument, "[100, 50000]");
}

TEST(Limits, QueueLength) {
  ServerLimits l;
  l.max_queue = 3;
  EXPECT_TRUE(check_queue_length(l, 2).ok());
  expect_names(check_queue_length(l, 3), StatusCode::kResourceExhausted, "--max-queue");
}

TEST(Limits, JobsPerClient) {
  ServerLimits l;
  l.max_jobs_per_client = 2;
  EXPECT_TRUE(check_client_jobs(l.max_jobs_per_client, "ipv4:1.2.3.4", 1).ok());
  const Status s = check_client_jobs(l.max_jobs_per_client, "ipv4:1.2.3.4", 2);
  expect_names(s, StatusCode::kResourceExhausted, "--max-jobs-per-client");
  expect_names(s, StatusCode::kResourceExhausted, "ipv4:1.2.3.4");
}

TEST(Limits, VertexAndFaceCountsNameTheirFlags) {
  ServerLimits l;
  l.max_vertices = 1000;
  l.max_faces = 2000;
  const Status parsed = resource_exhausted("Draco: the header declares 5000 vertices, the limit is 1000");
  const Status s = explain_mesh_limit(parsed, l);
  expect_names(s, StatusCode::kResourceExhausted, "--max-vertices 1000");
  expect_names(s, StatusCode::kResourceExhausted, "--max-faces 2000");
  // Other errors pass through untouched.
  EXPECT_EQ(explain_mesh_limit(invalid_argument("bad"), l).message(), "bad");
}

TEST(Limits, UploadMustBeANonEmptyDracoFileOfTheDeclaredSize) {
  const uint8_t draco[] = {'D', 'R', 'A', 'C', 'O', 2, 2};
  const uint8_t ply[] = {'p', 'l', 'y', '\n', 'f', 'o', 'r'};
  EXPECT_TRUE(check_upload_complete(7, 0, draco, 7).ok());
  EXPECT_TRUE(check_upload_complete(7, 7, draco, 7).ok());
  expect_names(check_upload_complete(0, 0, nullptr, 0), StatusCode::kInvalidArgument, "empty");
  expect_names(check_upload_complete(7, 9, draco, 7), StatusCode::kInvalidArgument, "mesh_size_bytes");
  expect_names(check_upload_complete(7, 0, ply, 7), StatusCode::kInvalidArgument, "not a Draco file");
  // input_format INPUT_FORMAT_GLTF_BINARY: a GLB header, and only that.
  const uint8_t glb[] = {'g', 'l', 'T', 'F', 2, 0, 0};
  EXPECT_TRUE(check_upload_complete(7, 7, glb, 7, true).ok());
  expect_names(check_upload_complete(7, 0, draco, 7, true), StatusCode::kInvalidArgument, "not a glTF binary");
  expect_names(check_upload_complete(0, 0, nullptr, 0, true), StatusCode::kInvalidArgument, "glTF binary");
}

}  // namespace
}  // namespace vpr::service
