#include "server/job_process_init.h"

#include <spdlog/spdlog.h>

#include "server/job_channel.h"

namespace vpr::service {

std::string encode_init(const WorkerContext& ctx, const JobProcessOptions& options) {
  FieldWriter w;
  w.str(ctx.name).str(ctx.device).u64(uint64_t(ctx.renderer_kind)).u64(uint64_t(ctx.device_policy));
  w.u64(uint64_t(ctx.cuda_device)).u64(ctx.gpu_job_bytes).str(ctx.crash_on_label);
  const ServerLimits& l = ctx.limits;
  w.u64(l.max_upload_bytes).u64(l.max_vertices).u64(l.max_faces).u64(l.max_target_vertices).u64(l.max_queue);
  w.u64(l.max_jobs_per_client);
  w.u64(options.memory_bytes).f64(options.cpu_seconds).u64(uint64_t(spdlog::get_level()));
  return w.take();
}

bool decode_init(const std::string& payload, WorkerContext* ctx, JobProcessOptions* options) {
  FieldReader r(payload);
  uint64_t renderer = 0, policy = 0, cuda = 0, gpu_bytes = 0;
  uint64_t max_vertices = 0, max_faces = 0, target = 0, max_queue = 0, per_client = 0, memory = 0, level = 0;
  ServerLimits& l = ctx->limits;
  const bool ok = r.str(&ctx->name) && r.str(&ctx->device) && r.u64(&renderer) && r.u64(&policy) && r.u64(&cuda) &&
                  r.u64(&gpu_bytes) && r.str(&ctx->crash_on_label) && r.u64(&l.max_upload_bytes) &&
                  r.u64(&max_vertices) && r.u64(&max_faces) && r.u64(&target) && r.u64(&max_queue) &&
                  r.u64(&per_client) && r.u64(&memory) && r.f64(&options->cpu_seconds) && r.u64(&level);
  if (!ok || renderer > uint64_t(RendererKind::kOsmesa) || policy > uint64_t(DevicePolicy::kCuda) ||
      level > uint64_t(spdlog::level::off))
    return false;
  ctx->renderer_kind = RendererKind(renderer);
  ctx->device_policy = DevicePolicy(policy);
  ctx->cuda_device = int(cuda);
  ctx->gpu_job_bytes = gpu_bytes;
  l.max_vertices = max_vertices;
  l.max_faces = max_faces;
  l.max_target_vertices = uint32_t(target);
  l.max_queue = max_queue;
  l.max_jobs_per_client = per_client;
  options->memory_bytes = memory;
  spdlog::set_level(spdlog::level::level_enum(level));
  return true;
}

std::string encode_job(ClaimedJob* job) {
  FieldWriter w;
  w.str(job->id).f64(job->queue_ms).str(job->spec.SerializeAsString());
  w.str(std::string_view(reinterpret_cast<const char*>(job->mesh.data()), job->mesh.size()));
  job->mesh = {};
  job->mesh.shrink_to_fit();
  return w.take();
}

bool decode_job(const std::string& payload, ClaimedJob* job) {
  FieldReader r(payload);
  std::string spec, mesh;
  if (!r.str(&job->id) || !r.f64(&job->queue_ms) || !r.str(&spec) || !r.str(&mesh)) return false;
  if (!job->spec.ParseFromString(spec)) return false;
  job->mesh.assign(mesh.begin(), mesh.end());
  return true;
}

}  // namespace vpr::service
