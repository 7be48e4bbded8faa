// Status and StatusOr: the error channel for anything that comes from input
// data or the machine (STYLE.md "Errors"). Programmer errors use assert.
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <utility>

namespace vpr {

// Mirrors the gRPC codes the service will map these to (one switch in server/).
enum class StatusCode {
  kOk = 0,
  kInvalidArgument,    // malformed mesh, NaN, bad option, impossible target
  kNotFound,           // missing file
  kResourceExhausted,  // out of memory, size limit hit
  kUnavailable,        // renderer or device not available
  kInternal,           // a bug or an unexpected library failure
  kCancelled,
  kDeadlineExceeded,
};

const char* status_code_name(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return {}; }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "INVALID_ARGUMENT: face 12 references vertex 99 but the mesh has 40 vertices"
  std::string to_string() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status invalid_argument(std::string m) {
  return {StatusCode::kInvalidArgument, std::move(m)};
}
inline Status not_found(std::string m) {
  return {StatusCode::kNotFound, std::move(m)};
}
inline Status resource_exhausted(std::string m) {
  return {StatusCode::kResourceExhausted, std::move(m)};
}
inline Status unavailable(std::string m) {
  return {StatusCode::kUnavailable, std::move(m)};
}
inline Status internal_error(std::string m) {
  return {StatusCode::kInternal, std::move(m)};
}

template <class T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(Status status) : status_(std::move(status)) { assert(!status_.ok()); }  // NOLINT
  StatusOr(T value) : value_(std::move(value)) {}                                  // NOLINT

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  T& value() & {
    assert(ok());
    return *value_;
  }
  const T& value() const& {
    assert(ok());
    return *value_;
  }
  T&& value() && {
    assert(ok());
    return std::move(*value_);
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

 private:
  Status status_;
  std::optional<T> value_;
};

}  // namespace vpr

#define VPR_CONCAT_INNER(a, b) a##b
#define VPR_CONCAT(a, b) VPR_CONCAT_INNER(a, b)

#define VPR_RETURN_IF_ERROR(expr)              \
  do {                                         \
    ::vpr::Status vpr_status_ = (expr);        \
    if (!vpr_status_.ok()) return vpr_status_; \
  } while (0)

#define VPR_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                              \
  if (!tmp.ok()) return tmp.status();             \
  lhs = std::move(tmp).value()

#define VPR_ASSIGN_OR_RETURN(lhs, expr) VPR_ASSIGN_OR_RETURN_IMPL(VPR_CONCAT(vpr_statusor_, __LINE__), lhs, expr)
