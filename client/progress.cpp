#include "progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

namespace vpr::cli {

namespace v1 = vpremesh::v1;

ProgressLine::ProgressLine(std::FILE* out, bool enabled)
    : out_(out), enabled_(enabled), terminal_(enabled && ::isatty(::fileno(out))) {}

ProgressLine::~ProgressLine() {
  finish();
}

void ProgressLine::update(const std::string& text) {
  if (!enabled_ || text.empty()) return;
  if (terminal_) {
    // A line wider than the terminal would wrap, and \r only returns to the last row.
    winsize size{};
    std::string shown = text;
    if (::ioctl(::fileno(out_), TIOCGWINSZ, &size) == 0 && size.ws_col > 1 && shown.size() >= size.ws_col)
      shown.resize(size.ws_col - 1);
    std::fprintf(out_, "\r%s\033[K", shown.c_str());
    pending_ = true;
  } else {
    std::fprintf(out_, "%s\n", text.c_str());
  }
  std::fflush(out_);
}

void ProgressLine::finish() {
  if (!pending_) return;
  std::fputc('\n', out_);
  std::fflush(out_);
  pending_ = false;
}

std::string ProgressLine::describe(const v1::JobEvent& e, int stages_seen) {
  const std::string job = "job " + e.job_id() + ": ";
  char buf[256];
  switch (e.event_case()) {
    case v1::JobEvent::kQueued:
      std::snprintf(buf, sizeof buf, "queued, %u job%s ahead", e.queued().position(),
                    e.queued().position() == 1 ? "" : "s");
      return job + buf;
    case v1::JobEvent::kStarted:
      std::snprintf(buf, sizeof buf, "started on %s (%s) after %.1f ms in the queue", e.started().worker().c_str(),
                    e.started().device().c_str(), e.started().queue_ms());
      return job + buf;
    case v1::JobEvent::kStage:
      std::snprintf(buf, sizeof buf, "stage %d %s done in %.1f ms (%s)", stages_seen, e.stage().name().c_str(),
                    e.stage().ms(), e.stage().device().c_str());
      return job + buf;
    case v1::JobEvent::kResult: {
      const v1::BytesChunk& c = e.result();
      const uint64_t received = c.offset() + c.data().size();
      std::snprintf(buf, sizeof buf, "receiving the result, %llu of %llu bytes", (unsigned long long)received,
                    (unsigned long long)c.total());
      return job + buf;
    }
    case v1::JobEvent::kCompleted:
      std::snprintf(buf, sizeof buf, "completed, %u vertices in %.1f ms", e.completed().output_vertices(),
                    e.completed().total_ms());
      return job + buf;
    case v1::JobEvent::kFailed:
      return job + "failed: " + e.failed().message();
    case v1::JobEvent::kCancelled:
      return job + "cancelled: " + e.cancelled().message();
    default:
      return "";
  }
}

}  // namespace vpr::cli
