// `vpremesh submit INPUT -o OUTPUT --server ADDR --target-vertices N ...`: the
// same job as `vpremesh local`, run by a vpremesh-server. The input is
// converted to Draco (the wire format), uploaded in chunks of at most 1 MiB
// (RemeshRequest: the spec first, then mesh_chunk), and followed to its end on
// the same stream; `--no-wait` only queues it (Submit) and prints the job id.
// With several --server replicas the upload goes to the first that accepts a
// connection, and a stream lost after the job id came is picked up with Watch
// on the next replica (job_follower.h); an upload is never sent twice.
#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.h"
#include "exit_codes.h"
#include "grpc_errors.h"
#include "io/mesh_io.h"
#include "job_events.h"
#include "job_follower.h"
#include "pipeline_flags.h"
#include "replicas.h"
#include "server/job_spec.h"
#include "server_list.h"
#include "upload.h"
#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::cli {

namespace v1 = vpremesh::v1;

namespace {

struct SubmitArgs {
  std::string input, output, field_out, label, device = "any";
  ServerFlags server;
  bool json = false, no_wait = false;
  PipelineFlagValues flags;
  int quantization_bits = 0;         // upload: 0 = lossless
  int result_quantization_bits = 0;  // 0 = 14 bits, the same file as `vpremesh local -o out.drc`
  int priority = 0;
  PipelineOptions options;
};

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

int fail(const Status& s) {
  std::fprintf(stderr, "vpremesh: error: %s\n", s.to_string().c_str());
  return exit_code_for(s);
}

StatusOr<std::vector<uint8_t>> read_bytes(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return not_found(path + ": no such file");
  std::ifstream f(path, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) return not_found(path + ": cannot read");
  return bytes;
}

StatusOr<v1::JobSpec> build_spec(SubmitArgs& a, uint64_t upload_bytes) {
  PipelineOptions& o = a.options;
  VPR_RETURN_IF_ERROR(apply_pipeline_flags(a.flags, &o));
  VPR_ASSIGN_OR_RETURN(const std::vector<LevelTarget> levels, levels_from_flags(a.flags, o));
  if (o.target_vertices != 0) VPR_RETURN_IF_ERROR(validate_options(o));
  VPR_ASSIGN_OR_RETURN(v1::JobSpec spec, service::make_job_spec(o, levels));
  spec.set_mesh_size_bytes(upload_bytes);
  spec.set_label(a.label.empty() ? std::filesystem::path(a.input).filename().string() : a.label);
  spec.set_priority(a.priority);
  spec.set_return_mesh(true);  // also for --no-wait: `vpremesh watch` may want it later
  spec.set_return_saliency(true);
  // --field-out writes the input colored by its field, as `vpremesh local` does.
  spec.set_return_input_saliency(!a.field_out.empty());
  spec.set_result_quantization_bits(uint32_t(a.result_quantization_bits));
  spec.set_device(a.device == "cpu" ? v1::DEVICE_CPU : a.device == "cuda" ? v1::DEVICE_CUDA : v1::DEVICE_ANY);
  return spec;
}

int run_submit(SubmitArgs& a) {
  if (!a.no_wait && a.output.empty()) {
    std::fprintf(stderr, "vpremesh: submit: -o OUTPUT is required (unless --no-wait)\n");
    return kExitUsage;
  }
  // Check the output formats before the upload.
  for (const std::string* path : {&a.output, &a.field_out})
    if (!path->empty())
      if (auto f = format_from_path(*path); !f.ok()) return fail(f.status());
  if (a.quantization_bits < 0 || a.quantization_bits > 30)
    return fail(invalid_argument("--quantization-bits is " + std::to_string(a.quantization_bits) +
                                 ", it must be in 0..30 (0 = lossless)"));

  JobOutputs outputs;
  outputs.output = a.output;
  outputs.field_out = a.field_out;
  outputs.json = a.json;
  outputs.target_vertices = a.options.target_vertices;

  auto start = std::chrono::steady_clock::now();
  Mesh input;  // as parsed here, for --field-out
  bool glb = false;
  auto bytes = draco_upload(a.input, a.quantization_bits, a.field_out.empty() ? nullptr : &input, &glb);
  if (!bytes.ok()) return fail(bytes.status());
  input.colors.clear();  // --field-out shows the field as the saliency ramp, not behind the input's colors
  if (!a.field_out.empty()) outputs.input_mesh = &input;
  auto spec = build_spec(a, bytes->size());
  if (!spec.ok()) return fail(spec.status());
  if (glb) spec->set_input_format(v1::INPUT_FORMAT_GLTF_BINARY);
  outputs.read_ms = ms_since(start);

  Replicas replicas(a.server.servers(), a.server.deadline_s);
  const size_t target = replicas.first_reachable();
  const std::string& server = replicas.address(target);
  grpc::ClientContext context;
  replicas.set_deadline(context);
  replicas.wait_for_single_server(target, context);

  if (a.no_wait) {
    v1::JobRef ref;
    auto writer = replicas.stub(target).Submit(&context, &ref);
    upload(*writer, *spec, *bytes);
    const grpc::Status status = writer->Finish();
    if (!status.ok()) return report_call_error(status, server);
    if (a.json)
      std::printf("%s\n", nlohmann::json{{"job_id", ref.job_id()}, {"server", server}}.dump(2).c_str());
    else
      std::printf("%s\n", ref.job_id().c_str());
    return kExitOk;
  }

  start = std::chrono::steady_clock::now();
  auto stream = replicas.stub(target).Remesh(&context);
  const bool sent = upload(*stream, *spec, *bytes);
  if (sent) outputs.upload_ms = ms_since(start);
  ProgressLine progress(stderr, !a.json);
  JobOutcome outcome;
  ReattachOptions reattach;
  reattach.timeout_s = a.server.reattach_timeout_s;
  reattach.cancel_at_deadline = true;
  JobFollower follower(replicas, reattach, progress, &outcome);
  const FollowEnd end = follower.follow(
      {[&stream](v1::JobEvent* e) { return stream->Read(e); }, [&stream] { return stream->Finish(); }}, target);
  return finish_followed(end, outcome, outputs);
}

}  // namespace

// The upload: a .drc file as it is (the server validates it), any other
// format parsed here and encoded with sequential connectivity (speed 10),
// which keeps every vertex and face in its order, so the server runs on
// exactly what `vpremesh local` would (with lossless positions).
StatusOr<std::vector<uint8_t>> draco_upload(const std::string& path, int quantization_bits, Mesh* parsed, bool* glb) {
  if (glb) *glb = false;
  VPR_ASSIGN_OR_RETURN(const MeshFormat format, format_from_path(path));
  if (format == MeshFormat::kDraco) {
    if (parsed) {
      VPR_ASSIGN_OR_RETURN(*parsed, read_mesh(path));
    }
    return read_bytes(path);
  }
  VPR_ASSIGN_OR_RETURN(Mesh mesh, read_mesh(path));
  // A textured .glb goes as it is, so that the server samples its textures
  // as `local` does; a .gltf with its images beside it cannot, and keeps its
  // vertex colors only (docs/formats.md, "Colors").
  if (glb && !mesh.textures.empty()) {
    VPR_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_bytes(path));
    if (bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0) {
      *glb = true;
      if (parsed) *parsed = std::move(mesh);
      return bytes;
    }
  }
  DracoOptions draco;
  draco.position_bits = quantization_bits;
  draco.speed = 10;
  auto bytes = encode_draco(mesh, nullptr, draco);
  if (!bytes.ok()) return Status(bytes.status().code(), path + ": " + bytes.status().message());
  if (parsed) *parsed = std::move(mesh);
  return bytes;
}

Command add_submit_command(CLI::App& app) {
  auto args = std::make_shared<SubmitArgs>();
  CLI::App* cmd = app.add_subcommand("submit", "Remesh a file on a vpremesh-server");
  cmd->add_option("input", args->input, "Input mesh (.drc .glb .gltf .obj .ply .off .stl)")->required();
  cmd->add_option("-o,--output", args->output, "Output mesh (.drc .glb .gltf .ply .obj)");
  add_server_list_flags(cmd, args->server);
  add_reattach_flag(cmd, args->server);
  add_pipeline_flags(cmd, args->options, args->flags);
  cmd->add_option("--field-out", args->field_out,
                  "Write the input mesh colored by its saliency field, as local --field-out (.ply .drc .obj)");
  cmd->add_flag("--json", args->json, "Print a JSON report instead of the table (no progress lines)");
  cmd->add_flag("--no-wait", args->no_wait, "Only queue the job and print its id (follow it with watch)");
  cmd->add_option("--quantization-bits", args->quantization_bits,
                  "Draco position bits of the upload, 1..30 (0 = lossless)")
      ->capture_default_str();
  cmd->add_option("--result-quantization-bits", args->result_quantization_bits,
                  "Draco position bits of the result, 1..30 (0 = 14, as local writes .drc)")
      ->check(CLI::Range(0, 30))
      ->capture_default_str();
  cmd->add_option("--priority", args->priority, "Higher runs first, -10..10")
      ->check(CLI::Range(-10, 10))
      ->capture_default_str();
  cmd->add_option("--label", args->label, "A name for the server's logs (default: the input's file name)");
  cmd->add_option("--device", args->device, "any, cpu or cuda")
      ->check(CLI::IsMember({"any", "cpu", "cuda"}))
      ->capture_default_str();
  return [args]() { return run_submit(*args); };
}

}  // namespace vpr::cli
