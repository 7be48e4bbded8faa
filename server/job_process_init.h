// The payloads of the kInit and kJob frames (server/job_channel.h): what a
// job process is told about its worker, and each job it runs.
#pragma once

#include <string>

#include "server/job.h"
#include "server/worker_pool.h"

namespace vpr::service {

// The worker context a job process recreates (without renderer, metrics and
// callbacks, which are the process's own) and its limits.
std::string encode_init(const WorkerContext& ctx, const JobProcessOptions& options);
bool decode_init(const std::string& payload, WorkerContext* ctx, JobProcessOptions* options);

// Moves the upload out of *job.
std::string encode_job(ClaimedJob* job);
bool decode_job(const std::string& payload, ClaimedJob* job);

}  // namespace vpr::service
