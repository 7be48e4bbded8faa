// `vpremesh status JOB`, `vpremesh watch JOB -o OUTPUT` and `vpremesh cancel
// JOB`: jobs on a vpremesh-server, typically queued with `submit --no-wait`.
// With several --server replicas, status and cancel ask the next one when a
// replica is UNAVAILABLE, and watch re-attaches (job_follower.h).
#include <google/protobuf/util/json_util.h>

#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "exit_codes.h"
#include "grpc_errors.h"
#include "io/mesh_io.h"
#include "job_events.h"
#include "job_follower.h"
#include "replicas.h"
#include "server_list.h"
#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::cli {

namespace v1 = vpremesh::v1;

namespace {

struct JobArgs {
  std::string job_id, output, field_out;
  ServerFlags server;
  bool json = false;
};

const char* state_name(v1::JobState s) {
  switch (s) {
    case v1::JOB_STATE_QUEUED:
      return "QUEUED";
    case v1::JOB_STATE_RUNNING:
      return "RUNNING";
    case v1::JOB_STATE_SUCCEEDED:
      return "SUCCEEDED";
    case v1::JOB_STATE_FAILED:
      return "FAILED";
    case v1::JOB_STATE_CANCELLED:
      return "CANCELLED";
    default:
      return "UNSPECIFIED";
  }
}

// One line: the state and what goes with it.
std::string describe_status(const v1::JobStatus& s) {
  std::string line = "job " + s.job_id() + ": " + state_name(s.state());
  char buf[256];
  switch (s.state()) {
    case v1::JOB_STATE_QUEUED:
      std::snprintf(buf, sizeof buf, ", %u job%s ahead", s.queue_position(), s.queue_position() == 1 ? "" : "s");
      line += buf;
      break;
    case v1::JOB_STATE_RUNNING:
      line += " on " + s.worker();
      if (!s.current_stage().empty()) line += ", stage " + s.current_stage();
      break;
    case v1::JOB_STATE_SUCCEEDED: {
      const v1::Completed& c = s.summary();
      std::snprintf(buf, sizeof buf,
                    " on %s: %u vertices, %u faces -> %u vertices, %u faces; queue %.1f ms, run %.1f ms, "
                    "total %.1f ms",
                    s.worker().c_str(), c.input_vertices(), c.input_faces(), c.output_vertices(), c.output_faces(),
                    c.queue_ms(), c.run_ms(), c.total_ms());
      line += buf;
      break;
    }
    case v1::JOB_STATE_FAILED:
    case v1::JOB_STATE_CANCELLED:
      if (s.has_failure())
        line += ": " + grpc_code_name(grpc::StatusCode(s.failure().code())) + ": " + s.failure().message();
      break;
    default:
      break;
  }
  return line;
}

int print_status(const v1::JobStatus& s, bool json) {
  if (json) {
    std::string out;
    google::protobuf::util::JsonPrintOptions options;
    options.add_whitespace = true;
    options.always_print_primitive_fields = true;
    options.preserve_proto_field_names = true;
    if (!google::protobuf::util::MessageToJsonString(s, &out, options).ok()) return kExitInternal;
    std::printf("%s", out.c_str());
  } else {
    std::printf("%s\n", describe_status(s).c_str());
  }
  return kExitOk;
}

// GetJob and CancelJob: the same unary call shape, JobRef in, JobStatus out.
using UnaryJobCall = grpc::Status (v1::RemeshService::Stub::*)(grpc::ClientContext*, const v1::JobRef&, v1::JobStatus*);

// GetJob and CancelJob answer the same on every replica (the queue is
// shared), and asking again is harmless: UNAVAILABLE moves on to the next.
int run_unary(const JobArgs& a, UnaryJobCall method) {
  Replicas replicas(a.server.servers(), a.server.deadline_s);
  v1::JobRef ref;
  ref.set_job_id(a.job_id);
  for (size_t i = 0;; ++i) {
    grpc::ClientContext context;
    replicas.set_deadline(context);
    if (i == 0) replicas.wait_for_single_server(i, context);
    v1::JobStatus status;
    const grpc::Status call = (replicas.stub(i).*method)(&context, ref, &status);
    if (call.ok()) return print_status(status, a.json);
    if (call.error_code() != grpc::StatusCode::UNAVAILABLE || i + 1 == replicas.size())
      return report_call_error(call, replicas.address(i));
    std::fprintf(stderr, "vpremesh: no answer from %s (%s); trying %s\n", replicas.address(i).c_str(),
                 one_line(call.error_message()).c_str(), replicas.address(i + 1).c_str());
  }
}

int run_status(const JobArgs& a) {
  return run_unary(a, &v1::RemeshService::Stub::GetJob);
}

int run_cancel(const JobArgs& a) {
  return run_unary(a, &v1::RemeshService::Stub::CancelJob);
}

int run_watch(const JobArgs& a) {
  for (const std::string* path : {&a.output, &a.field_out})
    if (!path->empty())
      if (auto f = format_from_path(*path); !f.ok()) {
        std::fprintf(stderr, "vpremesh: error: %s\n", f.status().to_string().c_str());
        return exit_code_for(f.status());
      }
  Replicas replicas(a.server.servers(), a.server.deadline_s);
  ProgressLine progress(stderr, !a.json);
  JobOutcome outcome;
  outcome.job_id = a.job_id;
  ReattachOptions reattach;
  reattach.timeout_s = a.server.reattach_timeout_s;
  JobFollower follower(replicas, reattach, progress, &outcome);
  const FollowEnd end = follower.watch(0);
  JobOutputs outputs;
  outputs.output = a.output;
  outputs.field_out = a.field_out;
  outputs.json = a.json;
  return finish_followed(end, outcome, outputs);
}

CLI::App* add_job_subcommand(CLI::App& app, const char* name, const char* help, JobArgs& args) {
  CLI::App* cmd = app.add_subcommand(name, help);
  cmd->add_option("job", args.job_id, "Job id (printed by submit --no-wait)")->required();
  add_server_list_flags(cmd, args.server);
  cmd->add_flag("--json", args.json, "Print JSON");
  return cmd;
}

}  // namespace

Command add_status_command(CLI::App& app) {
  auto args = std::make_shared<JobArgs>();
  add_job_subcommand(app, "status", "Show a job's state on a vpremesh-server", *args);
  return [args]() { return run_status(*args); };
}

Command add_watch_command(CLI::App& app) {
  auto args = std::make_shared<JobArgs>();
  CLI::App* cmd = add_job_subcommand(app, "watch", "Follow a job to its end and write its result", *args);
  add_reattach_flag(cmd, args->server);
  cmd->add_option("-o,--output", args->output, "Output mesh (.drc .glb .gltf .ply .obj)");
  cmd->add_option("--field-out", args->field_out,
                  "Write the RESULT colored by its saliency field (watch does not have the input mesh; "
                  "submit --field-out writes the input's field, as local does)");
  return [args]() { return run_watch(*args); };
}

Command add_cancel_command(CLI::App& app) {
  auto args = std::make_shared<JobArgs>();
  add_job_subcommand(app, "cancel", "Cancel a queued or running job", *args);
  return [args]() { return run_cancel(*args); };
}

}  // namespace vpr::cli
