// The RemeshService RPCs on gRPC's callback API. Talks to the workers only
// through JobQueue; uploads are checked here (spec, sizes, chunking) and the
// mesh itself is decoded by the worker.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <mutex>

#include "server/authenticator.h"
#include "server/job_queue.h"
#include "server/limits.h"
#include "server/service_metrics.h"
#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::service {

struct ServiceConfig {
  ServerLimits limits;
  bool has_cuda = false;  // DEVICE_CUDA jobs are FAILED_PRECONDITION without a GPU
  // OK while jobs can be accepted; UNAVAILABLE (with the reason) when no
  // worker is live. Null: always OK.
  std::function<Status()> admission;
  // Who may call, and as which tenant; null: everyone, as nobody in particular.
  const Authenticator* auth = nullptr;
};

class RemeshServiceImpl final : public v1::RemeshService::CallbackService {
 public:
  RemeshServiceImpl(JobQueue& queue, ServiceConfig config, ServiceMetrics* metrics)
      : queue_(queue), config_(std::move(config)), metrics_(metrics) {}

  grpc::ServerBidiReactor<v1::RemeshRequest, v1::JobEvent>* Remesh(grpc::CallbackServerContext* context) override;
  grpc::ServerReadReactor<v1::RemeshRequest>* Submit(grpc::CallbackServerContext* context,
                                                     v1::JobRef* response) override;
  grpc::ServerWriteReactor<v1::JobEvent>* Watch(grpc::CallbackServerContext* context,
                                                const v1::JobRef* request) override;
  grpc::ServerUnaryReactor* GetJob(grpc::CallbackServerContext* context, const v1::JobRef* request,
                                   v1::JobStatus* response) override;
  grpc::ServerUnaryReactor* CancelJob(grpc::CallbackServerContext* context, const v1::JobRef* request,
                                      v1::JobStatus* response) override;

  JobQueue& queue() { return queue_; }
  const ServiceConfig& config() const { return config_; }
  ServiceMetrics* metrics() { return metrics_; }

  // The caller of an RPC, or UNAUTHENTICATED.
  grpc::Status identify(const grpc::ServerContextBase& context, Caller* caller) const;
  // OK when the caller may see the job: it exists and, with authentication,
  // is the caller's own; else the queue's NOT_FOUND.
  grpc::Status check_access(const Caller& caller, const std::string& job_id);

  // A replica leaving a shared (Redis) queue: ends every Remesh and Watch
  // stream now with `why` (UNAVAILABLE, so clients re-attach elsewhere) and
  // leaves their jobs running; from now on a cancelled stream no longer
  // cancels its job either.
  void end_streams(const Status& why);

  // Streams register their stop function while they follow a job.
  using StreamStopper = std::function<void(const grpc::Status&)>;
  uint64_t add_stream(StreamStopper stop);
  void remove_stream(uint64_t id);
  bool ending_streams() const { return ending_streams_; }

 private:
  JobQueue& queue_;
  ServiceConfig config_;
  ServiceMetrics* metrics_;
  std::mutex streams_mu_;
  std::map<uint64_t, StreamStopper> streams_;
  uint64_t next_stream_ = 1;
  std::atomic<bool> ending_streams_{false};
};

}  // namespace vpr::service
