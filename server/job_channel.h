// The channel between a worker thread and the job process it supervises
// (server/job_process.h): length-prefixed frames over a Unix socket, and a
// field codec for their payloads. The two ends are the same binary, so the
// layout is private to it (native byte order).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace vpr::service {

enum class FrameType : uint8_t {
  // Worker thread -> job process.
  kInit = 1,      // fields of JobProcessInit
  kJob,           // a ClaimedJob
  kCancelAnswer,  // reply to kCancelQuery: status code (0: keep going) and message
  // Job process -> worker thread.
  kReady,         // the renderer's description: the process takes jobs
  kInitFailed,    // why it cannot (then it exits)
  kEvent,         // a serialized v1::JobEvent of the running job
  kStep,          // the name of the step (pipeline stage, decode, encode) starting now
  kCancelQuery,   // JobQueue::cancellation for the running job
  kJobDone,       // run_job returned
};

// An upload is at most 1 MiB short of --max-upload-mib (at most 1 TiB);
// anything longer is a corrupt stream.
inline constexpr uint64_t kMaxFramePayload = uint64_t(1) << 40;

struct Frame {
  FrameType type = FrameType::kInit;
  std::string payload;
};

// Writes one frame (retrying short writes and EINTR, never raising
// SIGPIPE). False when the other end is gone.
bool write_frame(int fd, FrameType type, std::string_view payload);
// Reads one frame. False at end of stream, on an error, or on a frame
// longer than kMaxFramePayload.
bool read_frame(int fd, Frame* frame);

// Payload fields in order: fixed-width numbers and length-prefixed strings.
class FieldWriter {
 public:
  FieldWriter& u64(uint64_t v);
  FieldWriter& f64(double v);
  FieldWriter& str(std::string_view s);
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

class FieldReader {
 public:
  explicit FieldReader(std::string_view in) : in_(in) {}
  // Each returns false (and leaves *v alone) when the payload is too short.
  bool u64(uint64_t* v);
  bool f64(double* v);
  bool str(std::string* s);

 private:
  bool take(void* out, size_t n);
  std::string_view in_;
};

}  // namespace vpr::service
