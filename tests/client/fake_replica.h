// A scripted vpremesh-server replica for the client's re-attach tests: an
// in-process gRPC server that serves one finished job, breaking its event
// streams where a test says, and records what the client asked for
// (Watch's from_sequence above all).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::testing {

namespace v1 = ::vpremesh::v1;

// A finished job's events, sequence 0..9: queued, started, two stages, the
// result (12 bytes) in three chunks with the saliency field (6 values) in two
// between them, completed. The result chunks straddle the breaks the tests
// make, so a lost or repeated chunk shows.
struct FakeJob {
  std::string id = "job-1";
  std::string result = "draco-bytes!";
  std::vector<v1::JobEvent> events;

  FakeJob() {
    auto add = [this]() -> v1::JobEvent& {
      events.emplace_back();
      events.back().set_job_id(id);
      events.back().set_sequence(events.size() - 1);
      return events.back();
    };
    add().mutable_queued()->set_position(0);
    v1::Started* started = add().mutable_started();
    started->set_worker("fake-worker");
    started->set_device("cpu");
    started->set_queue_ms(1.5);
    for (const char* name : {"render", "saliency_field"}) {
      v1::Stage* stage = add().mutable_stage();
      stage->set_name(name);
      stage->set_ms(10);
      stage->set_device("cpu");
    }
    auto saliency = [&](uint64_t offset) {
      v1::FloatChunk* c = add().mutable_saliency();
      c->set_offset(offset);
      c->set_total(6);
      for (int i = 0; i < 3; ++i) c->add_values(0.25f * float(offset + i));
    };
    auto bytes = [&](uint64_t offset) {
      v1::BytesChunk* c = add().mutable_result();
      c->set_offset(offset);
      c->set_total(result.size());
      c->set_data(result.substr(offset, 4));
    };
    saliency(0);
    bytes(0);
    bytes(4);
    saliency(3);
    bytes(8);
    v1::Completed* done = add().mutable_completed();
    done->set_input_vertices(4);
    done->set_input_faces(4);
    done->set_output_vertices(6);
    done->set_output_faces(8);
    done->set_result_bytes(result.size());
  }
};

// How one Remesh or Watch call goes.
struct CallPlan {
  uint64_t stop = std::numeric_limits<uint64_t>::max();   // end the stream before this event
  grpc::StatusCode code = grpc::StatusCode::UNAVAILABLE;  // ... with this status
  bool replay_from_zero = false;                          // ignore from_sequence, as a careless server might
  bool hold = false;                                      // at `stop`, keep the stream open until the client is gone
};

inline CallPlan breaks_at(uint64_t stop, grpc::StatusCode code = grpc::StatusCode::UNAVAILABLE) {
  CallPlan p;
  p.stop = stop;
  p.code = code;
  return p;
}
inline CallPlan holds_at(uint64_t stop) {
  CallPlan p;
  p.stop = stop;
  p.hold = true;
  return p;
}
inline CallPlan replays_from_zero() {
  CallPlan p;
  p.replay_from_zero = true;
  return p;
}

class FakeReplica final : public v1::RemeshService::Service {
 public:
  // listen: "127.0.0.1:0" picks a free port; a given one lets a test start
  // the client before the server.
  explicit FakeReplica(FakeJob job = {}, const std::string& listen = "127.0.0.1:0") : job_(std::move(job)) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort(listen, grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(this);
    server_ = builder.BuildAndStart();
  }
  ~FakeReplica() override { server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2)); }

  int port() const { return port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  const FakeJob& job() const { return job_; }

  // One plan per Remesh or Watch call, in order; calls after them follow
  // `then` (by default: the whole job from the asked event).
  void plan(std::vector<CallPlan> plans, CallPlan then = {}) {
    std::lock_guard<std::mutex> lock(mutex_);
    plans_.assign(plans.begin(), plans.end());
    then_ = then;
  }
  // Submit reads the upload, then holds until the client is gone (an
  // accepted upload whose reply never arrives).
  void hold_submit() {
    std::lock_guard<std::mutex> lock(mutex_);
    hold_submit_ = true;
  }
  // GetJob and CancelJob answer UNAVAILABLE (a draining replica).
  void refuse_unary() {
    std::lock_guard<std::mutex> lock(mutex_);
    refuse_unary_ = true;
  }

  std::vector<uint64_t> watch_from() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return watch_from_;
  }
  int remesh_calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return remesh_calls_;
  }
  int submit_calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return submit_calls_;
  }
  int unary_calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return unary_calls_;
  }
  int cancel_calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return cancel_calls_;
  }
  uint64_t uploaded_bytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return uploaded_bytes_;
  }
  // Waits until a call with `hold` has sent its events and holds.
  bool wait_holding(std::chrono::seconds limit) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, limit, [this] { return holding_; });
  }

  grpc::Status Remesh(grpc::ServerContext* context,
                      grpc::ServerReaderWriter<v1::JobEvent, v1::RemeshRequest>* stream) override {
    // As vpremesh-server: headers before reading the upload, which the
    // client waits for before it half-closes (client/upload.h).
    stream->SendInitialMetadata();
    v1::RemeshRequest request;
    bool spec = false;
    uint64_t bytes = 0;
    while (stream->Read(&request)) {
      spec = spec || request.has_spec();
      bytes += request.mesh_chunk().size();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++remesh_calls_;
      uploaded_bytes_ += bytes;
    }
    if (!spec) return {grpc::StatusCode::INVALID_ARGUMENT, "no spec"};
    return play(context, 0, [stream](const v1::JobEvent& e) { return stream->Write(e); });
  }

  grpc::Status Submit(grpc::ServerContext* context, grpc::ServerReader<v1::RemeshRequest>* reader,
                      v1::JobRef* response) override {
    reader->SendInitialMetadata();  // as Remesh
    v1::RemeshRequest request;
    while (reader->Read(&request)) {
    }
    bool hold = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++submit_calls_;
      hold = hold_submit_;
      holding_ = holding_ || hold;
    }
    if (hold) {
      changed_.notify_all();
      while (!context->IsCancelled()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      return {grpc::StatusCode::CANCELLED, "the client went away"};
    }
    response->set_job_id(job_.id);
    return grpc::Status::OK;
  }

  grpc::Status Watch(grpc::ServerContext* context, const v1::JobRef* ref,
                     grpc::ServerWriter<v1::JobEvent>* writer) override {
    if (ref->job_id() != job_.id) return {grpc::StatusCode::NOT_FOUND, "job " + ref->job_id() + " not found"};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      watch_from_.push_back(ref->from_sequence());
    }
    return play(context, ref->from_sequence(), [writer](const v1::JobEvent& e) { return writer->Write(e); });
  }

  grpc::Status GetJob(grpc::ServerContext*, const v1::JobRef* ref, v1::JobStatus* status) override {
    return answer(*ref, status);
  }
  grpc::Status CancelJob(grpc::ServerContext*, const v1::JobRef* ref, v1::JobStatus* status) override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++cancel_calls_;
    }
    return answer(*ref, status);
  }

 private:
  template <class Write>
  grpc::Status play(grpc::ServerContext* context, uint64_t from, Write write) {
    CallPlan p;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      p = plans_.empty() ? then_ : plans_.front();
      if (!plans_.empty()) plans_.pop_front();
    }
    for (uint64_t s = p.replay_from_zero ? 0 : from; s < job_.events.size() && s < p.stop; ++s)
      if (!write(job_.events[s])) return {grpc::StatusCode::CANCELLED, "the client went away"};
    if (p.stop >= job_.events.size()) return grpc::Status::OK;
    if (p.hold) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        holding_ = true;
      }
      changed_.notify_all();
      while (!context->IsCancelled()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      return {grpc::StatusCode::CANCELLED, "the client went away"};
    }
    return {p.code, "fake replica lost"};
  }

  grpc::Status answer(const v1::JobRef& ref, v1::JobStatus* status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++unary_calls_;
      if (refuse_unary_) return {grpc::StatusCode::UNAVAILABLE, "the server is draining"};
    }
    if (ref.job_id() != job_.id) return {grpc::StatusCode::NOT_FOUND, "job " + ref.job_id() + " not found"};
    status->set_job_id(job_.id);
    status->set_state(v1::JOB_STATE_SUCCEEDED);
    status->set_worker("fake-worker");
    *status->mutable_summary() = job_.events.back().completed();
    return grpc::Status::OK;
  }

  const FakeJob job_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<CallPlan> plans_;
  CallPlan then_;
  bool refuse_unary_ = false, hold_submit_ = false;
  bool holding_ = false;
  std::vector<uint64_t> watch_from_;
  int remesh_calls_ = 0, submit_calls_ = 0, unary_calls_ = 0, cancel_calls_ = 0;
  uint64_t uploaded_bytes_ = 0;
};

}  // namespace vpr::testing
