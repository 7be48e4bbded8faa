#include "server/remesh_service.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <memory>
#include <mutex>

#include "server/job_spec.h"
#include "server/status_mapping.h"

namespace vpr::service {
namespace {

using EventWriter = std::function<void(const v1::JobEvent*)>;
using Finisher = std::function<void(const grpc::Status&)>;

// Collects one upload: the spec first, then the Draco file in chunks.
class Upload {
 public:
  Upload(RemeshServiceImpl& service, const Caller& caller) : service_(service) {
    submission_.tenant = caller.tenant;
    submission_.client = caller.client;
    submission_.max_jobs = caller.max_jobs;
  }

  grpc::Status add(const v1::RemeshRequest& request) {
    const ServerLimits& limits = service_.config().limits;
    if (request.has_spec()) {
      if (have_spec_) return bad("a second spec arrived; only the first RemeshRequest carries the spec");
      have_spec_ = true;
      const v1::JobSpec& spec = request.spec();
      JobOptions options;
      if (Status s = job_options_from_spec(spec, &options); !s.ok()) return to_grpc(s);
      if (options.levels.empty()) {
        if (Status s = check_target(limits, spec.target_vertices()); !s.ok()) return to_grpc(s);
      }
      for (size_t i = 0; i < options.levels.size(); ++i)
        if (options.levels[i].vertices != 0) {
          if (Status s = check_target(limits, options.levels[i].vertices); !s.ok())
            return to_grpc(invalid_argument("levels[" + std::to_string(i) + "]: " + s.message()));
        }
      if (spec.device() == v1::DEVICE_CUDA && !service_.config().has_cuda)
        return {grpc::StatusCode::FAILED_PRECONDITION,
                "device is DEVICE_CUDA but this server has no CUDA device (it runs --device cpu or found no GPU)"};
      if (spec.mesh_size_bytes() != 0) {
        if (Status s = check_upload_size(limits, spec.mesh_size_bytes(), true); !s.ok()) return to_grpc(s);
        submission_.mesh.reserve(spec.mesh_size_bytes());
      }
      submission_.spec = spec;
      return grpc::Status::OK;
    }
    if (!have_spec_) return bad("the first RemeshRequest must carry the spec, not a mesh_chunk");
    const std::string& chunk = request.mesh_chunk();
    if (Status s = check_chunk(chunk.size()); !s.ok()) return to_grpc(s);
    if (Status s = check_upload_size(limits, submission_.mesh.size() + chunk.size(), false); !s.ok()) return to_grpc(s);
    const uint64_t declared = submission_.spec.mesh_size_bytes();
    if (declared != 0 && submission_.mesh.size() + chunk.size() > declared)
      return bad("more bytes arrived than mesh_size_bytes declared (" + std::to_string(declared) + ")");
    submission_.mesh.insert(submission_.mesh.end(), chunk.begin(), chunk.end());
    if (service_.metrics()) service_.metrics()->bytes_in.inc(double(chunk.size()));
    return grpc::Status::OK;
  }

  // After the client half-closed: checks the whole upload and queues it.
  grpc::Status submit(std::string* job_id) {
    if (!have_spec_) return bad("the upload is empty: no spec arrived");
    const auto& mesh = submission_.mesh;
    const std::string tenant = submission_.tenant;
    const bool glb = submission_.spec.input_format() == v1::INPUT_FORMAT_GLTF_BINARY;
    if (Status s =
            check_upload_complete(mesh.size(), submission_.spec.mesh_size_bytes(), mesh.data(), mesh.size(), glb);
        !s.ok())
      return to_grpc(s);
    if (service_.config().admission)
      if (Status s = service_.config().admission(); !s.ok()) return to_grpc(s);
    auto id = service_.queue().submit(std::move(submission_));
    if (!id.ok()) return to_grpc(id.status());
    if (service_.metrics()) {
      service_.metrics()->submitted.inc();
      if (!tenant.empty()) service_.metrics()->tenant_submitted(tenant).inc();
    }
    *job_id = *id;
    return grpc::Status::OK;
  }

 private:
  static grpc::Status bad(const std::string& m) { return {grpc::StatusCode::INVALID_ARGUMENT, m}; }

  RemeshServiceImpl& service_;
  JobSubmission submission_;
  bool have_spec_ = false;
};

// Feeds one job's events to one stream, one write in flight at a time, then
// finishes the stream with the job's outcome: OK after `completed`, the
// failure's code after `failed` or `cancelled`. Woken by the queue after
// every new event and by the stream after every write.
class EventPump : public std::enable_shared_from_this<EventPump> {
 public:
  EventPump(JobQueue& queue, std::string job_id, EventWriter write, Finisher finish, uint64_t from_sequence = 0)
      : queue_(queue),
        job_id_(std::move(job_id)),
        write_(std::move(write)),
        finish_(std::move(finish)),
        next_(from_sequence) {}

  // Subscribes and sends what is already there.
  void start() {
    std::weak_ptr<EventPump> weak = shared_from_this();
    auto token = queue_.subscribe(job_id_, [weak] {
      if (auto self = weak.lock()) self->pump();
    });
    if (!token.ok()) return stop(to_grpc(token.status()));
    {
      std::lock_guard<std::recursive_mutex> lock(mu_);
      token_ = *token;
    }
    pump();
  }

  void pump() {
    std::lock_guard<std::recursive_mutex> lock(mu_);
    if (writing_ || done_) return;
    auto batch = queue_.events(job_id_, next_, 1);
    if (!batch.ok()) return finish_locked(to_grpc(batch.status()));
    if (!batch->events.empty()) {
      current_ = std::move(batch->events.front());
      ++next_;
      if (current_.has_failed()) outcome_ = to_grpc(current_.failed());
      if (current_.has_cancelled()) outcome_ = to_grpc(current_.cancelled());
      writing_ = true;
      write_(&current_);
    } else if (batch->ended) {
      // A re-attached Watch (from_sequence past the end) never saw the last
      // event: the job's status has the outcome.
      if (next_ > 0 && outcome_.ok()) {
        auto status = queue_.status(job_id_);
        if (status.ok() && status->has_failure()) outcome_ = to_grpc(status->failure());
      }
      finish_locked(outcome_);
    }
  }

  void on_write_done(bool ok) {
    {
      std::lock_guard<std::recursive_mutex> lock(mu_);
      writing_ = false;
      if (!ok) return finish_locked({grpc::StatusCode::CANCELLED, "the stream broke while sending events"});
      if (pending_finish_) return finish_locked(*pending_finish_);
    }
    pump();
  }

  // Ends the stream now (or after the write in flight).
  void stop(const grpc::Status& status) {
    std::lock_guard<std::recursive_mutex> lock(mu_);
    if (writing_) {
      if (!pending_finish_) pending_finish_ = status;
      return;
    }
    finish_locked(status);
  }

  // The stream is done (OnDone): no call reaches it any more.
  void detach() {
    uint64_t token = 0;
    {
      std::lock_guard<std::recursive_mutex> lock(mu_);
      done_ = true;
      token = token_;
    }
    if (token) queue_.unsubscribe(job_id_, token);
  }

 private:
  void finish_locked(const grpc::Status& status) {
    if (done_) return;
    done_ = true;
    finish_(status);
  }

  JobQueue& queue_;
  const std::string job_id_;
  std::recursive_mutex mu_;
  EventWriter write_;
  Finisher finish_;
  uint64_t token_ = 0;
  uint64_t next_ = 0;
  bool writing_ = false, done_ = false;
  std::optional<grpc::Status> pending_finish_;
  grpc::Status outcome_ = grpc::Status::OK;
  v1::JobEvent current_;  // the event being written
};

// Why a call ended early: its deadline, or the client. A client whose
// deadline passes usually cancels the call itself a moment before the
// server's own timer (set later, on arrival) fires; so a cancellation within
// a second of the deadline counts as the deadline.
Status cancel_reason(grpc::CallbackServerContext* context, const char* rpc) {
  if (context->deadline() <= std::chrono::system_clock::now() + std::chrono::seconds(1))
    return Status(StatusCode::kDeadlineExceeded, std::string("the ") + rpc + " call's deadline passed");
  return Status(StatusCode::kCancelled, std::string("the client cancelled or disconnected from ") + rpc);
}

class RemeshReactor final : public grpc::ServerBidiReactor<v1::RemeshRequest, v1::JobEvent> {
 public:
  RemeshReactor(RemeshServiceImpl& service, grpc::CallbackServerContext* context, const Caller& caller)
      : service_(service), context_(context), caller_(caller), upload_(service, caller) {
    // Headers first, before any of the upload is read: the client half-closes
    // only once they arrived, and gRPC stops retrying a call at its headers,
    // so an upload this server may accept (at the half-close) is never sent
    // again (client/channel.h).
    StartSendInitialMetadata();
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    if (ok) {
      grpc::Status s = upload_.add(request_);
      if (!s.ok()) return finish_upload(s);
      return StartRead(&request_);
    }
    if (context_->IsCancelled()) return finish_upload({grpc::StatusCode::CANCELLED, "cancelled during the upload"});
    std::string id;
    grpc::Status s = upload_.submit(&id);
    if (!s.ok()) return finish_upload(s);
    std::shared_ptr<EventPump> pump = std::make_shared<EventPump>(
        service_.queue(), id, [this](const v1::JobEvent* e) { StartWrite(e); },
        [this](const grpc::Status& st) { Finish(st); });
    bool cancelled = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      job_id_ = id;
      pump_ = pump;
      cancelled = cancelled_;
    }
    stream_id_ = service_.add_stream([weak = std::weak_ptr<EventPump>(pump)](const grpc::Status& st) {
      if (auto p = weak.lock()) p->stop(st);
    });
    if (cancelled) cancel_job();
    pump->start();
  }

  void OnWriteDone(bool ok) override {
    if (auto pump = get_pump()) pump->on_write_done(ok);
  }

  void OnCancel() override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      cancelled_ = true;
      if (job_id_.empty()) return;  // the upload's pending read fails and finishes the call
    }
    cancel_job();
  }

  void OnDone() override {
    if (stream_id_) service_.remove_stream(stream_id_);
    if (auto pump = get_pump()) pump->detach();
    delete this;
  }

 private:
  std::shared_ptr<EventPump> get_pump() {
    std::lock_guard<std::mutex> lock(mu_);
    return pump_;
  }

  // Cancels the job (a running one stops at its next stage boundary) and
  // ends the stream: the client is gone or its deadline passed.
  void cancel_job() {
    // A replica leaving a shared queue ends its streams; the jobs go on and
    // their clients re-attach elsewhere.
    if (service_.ending_streams()) return;
    const Status why = cancel_reason(context_, "Remesh");
    (void)service_.queue().cancel(job_id_, why);
    if (auto pump = get_pump()) pump->stop(to_grpc(why));
  }

  void finish_upload(const grpc::Status& s) {
    if (!s.ok()) spdlog::info("Remesh from {} refused: {}", caller_.client, s.error_message());
    Finish(s);
  }

  RemeshServiceImpl& service_;
  grpc::CallbackServerContext* context_;
  const Caller caller_;
  Upload upload_;
  v1::RemeshRequest request_;
  std::mutex mu_;
  std::string job_id_;
  std::shared_ptr<EventPump> pump_;
  bool cancelled_ = false;
  uint64_t stream_id_ = 0;
};

class SubmitReactor final : public grpc::ServerReadReactor<v1::RemeshRequest> {
 public:
  SubmitReactor(RemeshServiceImpl& service, grpc::CallbackServerContext* context, const Caller& caller,
                v1::JobRef* response)
      : context_(context), caller_(caller), upload_(service, caller), response_(response) {
    StartSendInitialMetadata();  // as Remesh: the client's retries end here
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    if (ok) {
      grpc::Status s = upload_.add(request_);
      if (!s.ok()) return finish(s);
      return StartRead(&request_);
    }
    if (context_->IsCancelled()) return finish({grpc::StatusCode::CANCELLED, "cancelled during the upload"});
    std::string id;
    grpc::Status s = upload_.submit(&id);
    if (s.ok()) response_->set_job_id(id);
    finish(s);
  }

  void OnDone() override { delete this; }

 private:
  void finish(const grpc::Status& s) {
    if (!s.ok()) spdlog::info("Submit from {} refused: {}", caller_.client, s.error_message());
    Finish(s);
  }

  grpc::CallbackServerContext* context_;
  const Caller caller_;
  Upload upload_;
  v1::JobRef* response_;
  v1::RemeshRequest request_;
};

class WatchReactor final : public grpc::ServerWriteReactor<v1::JobEvent> {
 public:
  WatchReactor(RemeshServiceImpl& service, const v1::JobRef& ref) : service_(service) {
    pump_ = std::make_shared<EventPump>(
        service.queue(), ref.job_id(), [this](const v1::JobEvent* e) { StartWrite(e); },
        [this](const grpc::Status& st) { Finish(st); }, ref.from_sequence());
    stream_id_ = service.add_stream([weak = std::weak_ptr<EventPump>(pump_)](const grpc::Status& st) {
      if (auto p = weak.lock()) p->stop(st);
    });
    pump_->start();
  }
  void OnWriteDone(bool ok) override { pump_->on_write_done(ok); }
  // Watching stops; the job goes on.
  void OnCancel() override { pump_->stop({grpc::StatusCode::CANCELLED, "the client stopped watching"}); }
  void OnDone() override {
    service_.remove_stream(stream_id_);
    pump_->detach();
    delete this;
  }

 private:
  RemeshServiceImpl& service_;
  std::shared_ptr<EventPump> pump_;
  uint64_t stream_id_ = 0;
};

// A call refused before it started (no token, another tenant's job): ends
// at once with `status`.
template <class Reactor>
class Refused final : public Reactor {
 public:
  explicit Refused(const grpc::Status& status) { this->Finish(status); }
  void OnDone() override { delete this; }
};

}  // namespace

grpc::Status RemeshServiceImpl::identify(const grpc::ServerContextBase& context, Caller* caller) const {
  static const Authenticator kOpen;
  const grpc::Status s = (config_.auth ? *config_.auth : kOpen).identify(context, caller);
  if (!s.ok() && metrics_) metrics_->unauthenticated.inc();
  return s;
}

grpc::Status RemeshServiceImpl::check_access(const Caller& caller, const std::string& job_id) {
  // Without authentication every job is everyone's, as before tenants.
  if (!config_.auth || !config_.auth->enabled()) return grpc::Status::OK;
  return to_grpc(queue_.check_owner(job_id, caller.tenant));
}

uint64_t RemeshServiceImpl::add_stream(StreamStopper stop) {
  std::lock_guard<std::mutex> lock(streams_mu_);
  const uint64_t id = next_stream_++;
  streams_.emplace(id, std::move(stop));
  return id;
}

void RemeshServiceImpl::remove_stream(uint64_t id) {
  std::lock_guard<std::mutex> lock(streams_mu_);
  streams_.erase(id);
}

void RemeshServiceImpl::end_streams(const Status& why) {
  ending_streams_ = true;
  std::vector<StreamStopper> stops;
  {
    std::lock_guard<std::mutex> lock(streams_mu_);
    for (auto& [id, stop] : streams_) stops.push_back(stop);
  }
  for (const StreamStopper& stop : stops) stop(to_grpc(why));
  if (!stops.empty()) spdlog::info("ended {} stream(s): {}", stops.size(), why.message());
}

grpc::ServerBidiReactor<v1::RemeshRequest, v1::JobEvent>* RemeshServiceImpl::Remesh(
    grpc::CallbackServerContext* context) {
  Caller caller;
  if (grpc::Status s = identify(*context, &caller); !s.ok())
    return new Refused<grpc::ServerBidiReactor<v1::RemeshRequest, v1::JobEvent>>(s);
  return new RemeshReactor(*this, context, caller);
}

grpc::ServerReadReactor<v1::RemeshRequest>* RemeshServiceImpl::Submit(grpc::CallbackServerContext* context,
                                                                      v1::JobRef* response) {
  Caller caller;
  if (grpc::Status s = identify(*context, &caller); !s.ok())
    return new Refused<grpc::ServerReadReactor<v1::RemeshRequest>>(s);
  return new SubmitReactor(*this, context, caller, response);
}

grpc::ServerWriteReactor<v1::JobEvent>* RemeshServiceImpl::Watch(grpc::CallbackServerContext* context,
                                                                 const v1::JobRef* request) {
  Caller caller;
  grpc::Status s = identify(*context, &caller);
  if (s.ok()) s = check_access(caller, request->job_id());
  if (!s.ok()) return new Refused<grpc::ServerWriteReactor<v1::JobEvent>>(s);
  return new WatchReactor(*this, *request);
}

grpc::ServerUnaryReactor* RemeshServiceImpl::GetJob(grpc::CallbackServerContext* context, const v1::JobRef* request,
                                                    v1::JobStatus* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  Caller caller;
  grpc::Status allowed = identify(*context, &caller);
  if (allowed.ok()) allowed = check_access(caller, request->job_id());
  if (!allowed.ok()) {
    reactor->Finish(allowed);
    return reactor;
  }
  auto status = queue_.status(request->job_id());
  if (status.ok()) *response = *status;
  reactor->Finish(to_grpc(status.status()));
  return reactor;
}

grpc::ServerUnaryReactor* RemeshServiceImpl::CancelJob(grpc::CallbackServerContext* context, const v1::JobRef* request,
                                                       v1::JobStatus* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  Caller caller;
  grpc::Status allowed = identify(*context, &caller);
  if (allowed.ok()) allowed = check_access(caller, request->job_id());
  if (!allowed.ok()) {
    reactor->Finish(allowed);
    return reactor;
  }
  const std::string who = caller.tenant.empty() ? context->peer() : "tenant " + caller.tenant;
  auto status = queue_.cancel(request->job_id(), Status(StatusCode::kCancelled, "cancelled by CancelJob from " + who));
  if (status.ok()) *response = *status;
  reactor->Finish(to_grpc(status.status()));
  return reactor;
}

}  // namespace vpr::service
