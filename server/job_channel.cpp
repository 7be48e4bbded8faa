#include "server/job_channel.h"

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace vpr::service {
namespace {

bool write_all(int fd, const char* data, size_t n) {
  while (n > 0) {
    const ssize_t w = send(fd, data, n, MSG_NOSIGNAL);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    data += w;
    n -= size_t(w);
  }
  return true;
}

bool read_all(int fd, char* data, size_t n) {
  while (n > 0) {
    const ssize_t r = read(fd, data, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    data += r;
    n -= size_t(r);
  }
  return true;
}

}  // namespace

bool write_frame(int fd, FrameType type, std::string_view payload) {
  char header[9];
  header[0] = char(type);
  const uint64_t length = payload.size();
  std::memcpy(header + 1, &length, sizeof length);
  return write_all(fd, header, sizeof header) && write_all(fd, payload.data(), payload.size());
}

bool read_frame(int fd, Frame* frame) {
  char header[9];
  if (!read_all(fd, header, sizeof header)) return false;
  uint64_t length = 0;
  std::memcpy(&length, header + 1, sizeof length);
  if (length > kMaxFramePayload) return false;
  frame->type = FrameType(uint8_t(header[0]));
  frame->payload.resize(length);
  return read_all(fd, frame->payload.data(), length);
}

FieldWriter& FieldWriter::u64(uint64_t v) {
  out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  return *this;
}

FieldWriter& FieldWriter::f64(double v) {
  out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  return *this;
}

FieldWriter& FieldWriter::str(std::string_view s) {
  u64(s.size());
  out_.append(s);
  return *this;
}

bool FieldReader::take(void* out, size_t n) {
  if (in_.size() < n) return false;
  std::memcpy(out, in_.data(), n);
  in_.remove_prefix(n);
  return true;
}

bool FieldReader::u64(uint64_t* v) {
  return take(v, sizeof *v);
}

bool FieldReader::f64(double* v) {
  return take(v, sizeof *v);
}

bool FieldReader::str(std::string* s) {
  uint64_t n = 0;
  if (in_.size() < sizeof n) return false;
  std::memcpy(&n, in_.data(), sizeof n);
  if (in_.size() - sizeof n < n) return false;
  in_.remove_prefix(sizeof n);
  s->assign(in_.data(), n);
  in_.remove_prefix(n);
  return true;
}

}  // namespace vpr::service
