#include "job_follower.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <thread>

#include "exit_codes.h"
#include "grpc_errors.h"

namespace vpr::cli {

namespace v1 = vpremesh::v1;

namespace {

// The call and its context in one object: the reader goes before the context,
// as when both live on the stack.
struct WatchCall {
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<v1::JobEvent>> reader;
};

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g s", s);
  return buf;
}

}  // namespace

JobFollower::JobFollower(Replicas& replicas, ReattachOptions options, ProgressLine& progress, JobOutcome* outcome)
    : replicas_(replicas), options_(options), progress_(progress), outcome_(outcome) {}

void JobFollower::consume(const v1::JobEvent& event) {
  // A server that does not honour from_sequence replays from 0: what we have
  // is not added again (a result chunk twice would break the reassembly).
  if (event.sequence() < next_sequence_) return;
  next_sequence_ = event.sequence() + 1;
  if (!problem_.ok()) return;  // keep reading so that the call's status comes through
  if (!outcome_->job_id.empty() && !event.job_id().empty() && event.job_id() != outcome_->job_id) {
    problem_ = internal_error("an event of job " + event.job_id() + " came on the stream of job " + outcome_->job_id);
    return;
  }
  if (event.event_case() == v1::JobEvent::kStage) ++stages_;
  // A line per result chunk would flood a log; on a terminal it is a counter.
  if (event.event_case() != v1::JobEvent::kResult || progress_.terminal())
    progress_.update(ProgressLine::describe(event, stages_));
  problem_ = outcome_->add(event);
}

EventStream JobFollower::open_watch(size_t index) {
  auto call = std::make_shared<WatchCall>();
  replicas_.set_deadline(call->context);
  if (!reattaching_) replicas_.wait_for_single_server(index, call->context);
  v1::JobRef ref;
  ref.set_job_id(outcome_->job_id);
  ref.set_from_sequence(next_sequence_);
  call->reader = replicas_.stub(index).Watch(&call->context, ref);
  return {[call](v1::JobEvent* e) { return call->reader->Read(e); }, [call] { return call->reader->Finish(); }};
}

FollowEnd JobFollower::watch(size_t index) {
  return follow(open_watch(index), index);
}

FollowEnd JobFollower::follow(EventStream stream, size_t index) {
  FollowEnd end = follow_streams(std::move(stream), index);
  if (options_.cancel_at_deadline && reattaching_ && outcome_->end == JobOutcome::End::kNone &&
      end.call.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
    cancel_job(end.index);
  return end;
}

// Best effort, as the Remesh call's own cancellation is: the command fails
// with DEADLINE_EXCEEDED either way.
void JobFollower::cancel_job(size_t index) {
  v1::JobRef ref;
  ref.set_job_id(outcome_->job_id);
  for (size_t i = 0; i < replicas_.size(); ++i) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    v1::JobStatus status;
    if (replicas_.stub(index + i).CancelJob(&context, ref, &status).error_code() != grpc::StatusCode::UNAVAILABLE)
      return;
  }
}

FollowEnd JobFollower::follow_streams(EventStream stream, size_t index) {
  using Steady = std::chrono::steady_clock;
  const auto window = std::chrono::duration_cast<Steady::duration>(std::chrono::duration<double>(options_.timeout_s));
  Steady::time_point lost_since;  // the first loss since the last new event
  bool losing = false;
  auto backoff = options_.first_backoff;
  for (;;) {
    const uint64_t before = next_sequence_;
    v1::JobEvent event;
    while (stream.read(&event)) consume(event);
    FollowEnd end{stream.finish(), problem_, replicas_.address(index), index % replicas_.size(), ""};
    const bool broken = end.call.error_code() == grpc::StatusCode::UNAVAILABLE;
    if (outcome_->end != JobOutcome::End::kNone || !problem_.ok() || !broken || options_.timeout_s <= 0) {
      progress_.finish();
      return end;
    }
    if (outcome_->job_id.empty()) {
      // Not retried: a new upload could run the job twice. A transport
      // failure names the address already (as with one server); a server's
      // own UNAVAILABLE does not.
      progress_.finish();
      if (describe_call_error(end.call, end.server).find(end.server) == std::string::npos)
        end.note = "lost " + end.server + " before the job's id came; the upload is not sent again";
      return end;
    }
    const auto now = Steady::now();
    if (!losing || next_sequence_ != before) {
      losing = true;
      lost_since = now;
      backoff = options_.first_backoff;
    }
    if (now - lost_since >= window) {
      progress_.finish();
      end.note = "gave up re-attaching to job " + outcome_->job_id + " after " + seconds_text(options_.timeout_s) +
                 " without an event (--reattach-timeout)";
      return end;
    }
    const size_t next = (index + 1) % replicas_.size();
    reattaching_ = true;
    progress_.finish();
    std::fprintf(stderr, "vpremesh: lost %s (%s); re-attaching to job %s on %s from event %llu\n", end.server.c_str(),
                 one_line(end.call.error_message()).c_str(), outcome_->job_id.c_str(), replicas_.address(next).c_str(),
                 (unsigned long long)next_sequence_);
    std::fflush(stderr);

    auto wait = std::min<Steady::duration>(backoff, lost_since + window - now);
    if (replicas_.has_deadline())
      wait = std::min<Steady::duration>(wait, replicas_.deadline() - Replicas::Clock::now());
    if (wait > Steady::duration::zero()) std::this_thread::sleep_for(wait);
    backoff = std::min(backoff * 2, options_.max_backoff);
    if (replicas_.past_deadline()) {
      end.call = grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "Deadline Exceeded");
      return end;
    }
    index = next;
    stream = open_watch(index);
  }
}

int finish_followed(const FollowEnd& end, const JobOutcome& outcome, const JobOutputs& outputs) {
  // A job that failed says so in its last event; the call's status may carry
  // the same code. A failed call without such an event is the call's error.
  if (!end.call.ok() && outcome.end == JobOutcome::End::kNone) {
    std::string line = describe_call_error(end.call, end.server);
    if (!end.note.empty()) line += "; " + end.note;
    std::fprintf(stderr, "vpremesh: %s\n", line.c_str());
    return exit_code_for(end.call.error_code());
  }
  if (!end.problem.ok()) {
    std::fprintf(stderr, "vpremesh: error: %s\n", end.problem.to_string().c_str());
    return exit_code_for(end.problem);
  }
  return finish_job(outcome, outputs, end.server);
}

}  // namespace vpr::cli
