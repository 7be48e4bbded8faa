// Following a job's events to its end, across server replicas (`vpremesh
// submit` while it waits, `vpremesh watch`). When the stream breaks with
// UNAVAILABLE (the server died, the connection was reset, the server is
// shutting down) and the job's id is known, the job is picked up again with
// Watch(job_id, from_sequence = the next event) on the next --server replica,
// round robin, after a short exponential backoff, until --reattach-timeout
// passes without an event, the --deadline passes, or the job ends. Watch, unlike
// the Remesh call that uploaded the job, does not cancel the job when it breaks.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "job_events.h"
#include "progress.h"
#include "replicas.h"
#include "vpremesh/v1/remesh.pb.h"

namespace vpr::cli {

// An open call that yields a job's events: read until false, then finish for
// the call's status (ClientReader or ClientReaderWriter).
struct EventStream {
  std::function<bool(vpremesh::v1::JobEvent*)> read;
  std::function<grpc::Status()> finish;
};

struct ReattachOptions {
  double timeout_s = 60;  // without any new event; 0: never re-attach
  std::chrono::milliseconds first_backoff{100};
  std::chrono::milliseconds max_backoff{2000};  // the backoff doubles up to this
  // submit: the Remesh call cancels its job when the --deadline passes, and a
  // Watch that took over does not; with this the follower cancels it instead.
  bool cancel_at_deadline = false;
};

// How following ended. The job's end, when it came, is in the JobOutcome.
struct FollowEnd {
  grpc::Status call;   // the last stream's status
  Status problem;      // a malformed event (the server broke the protocol)
  std::string server;  // the replica of the last stream
  size_t index = 0;    // its place in the list
  std::string note;    // why the command did not re-attach, for the error line
};

class JobFollower {
 public:
  // outcome->job_id, when already known (watch), is the job re-attached to;
  // otherwise the first event names it.
  JobFollower(Replicas& replicas, ReattachOptions options, ProgressLine& progress, JobOutcome* outcome);

  // Follows `stream`, open on replica `index`, and the Watch calls that pick
  // the job up after it, to the job's end or to an error that stops it.
  FollowEnd follow(EventStream stream, size_t index);
  // The same from Watch(job_id, from event 0) on replica `index`.
  FollowEnd watch(size_t index);

  // The sequence number of the next event to process: every event is
  // processed once, whatever a server replays.
  uint64_t next_sequence() const { return next_sequence_; }

 private:
  FollowEnd follow_streams(EventStream stream, size_t index);
  void consume(const vpremesh::v1::JobEvent& event);
  EventStream open_watch(size_t index);
  void cancel_job(size_t index);

  Replicas& replicas_;
  ReattachOptions options_;
  ProgressLine& progress_;
  JobOutcome* outcome_;
  uint64_t next_sequence_ = 0;
  int stages_ = 0;            // stage events so far, for the progress line
  bool reattaching_ = false;  // the first stream was lost: Watch calls stand in for it
  Status problem_;
};

// The command's end after following: the call's error when the job did not
// end (with the note), a malformed event, or finish_job. Returns the exit code.
int finish_followed(const FollowEnd& end, const JobOutcome& outcome, const JobOutputs& outputs);

}  // namespace vpr::cli
