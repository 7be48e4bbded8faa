// A live progress line for jobs followed from the terminal. On a terminal the
// line is rewritten in place (carriage return, clear to end of line); when the
// stream is a pipe or a file each update is a plain line of its own, so logs
// read top to bottom.
#pragma once

#include <cstdio>
#include <string>

#include "vpremesh/v1/remesh.pb.h"

namespace vpr::cli {

class ProgressLine {
 public:
  // out: where the line goes (stderr, so that stdout keeps the table or JSON).
  // enabled = false prints nothing (--json). Terminal detection uses isatty.
  ProgressLine(std::FILE* out, bool enabled);
  ~ProgressLine();  // ends a pending terminal line
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // Shows `text` (one line) in place of the previous one.
  void update(const std::string& text);
  // Ends the current line (terminal) so that later output starts on its own.
  void finish();

  // The line shown for an event: queued, started, each stage, the result
  // download, the end; "" for events without a line of their own (field and
  // debug chunks). stages_seen counts stage events so far, this one included.
  static std::string describe(const vpremesh::v1::JobEvent& event, int stages_seen);

  bool terminal() const { return terminal_; }

 private:
  std::FILE* out_;
  bool enabled_;
  bool terminal_;
  bool pending_ = false;  // a terminal line without its newline yet
};

}  // namespace vpr::cli
