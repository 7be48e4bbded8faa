#include "server/authenticator.h"

#include <spdlog/spdlog.h>
#include <sys/stat.h>

namespace vpr::service {

std::string address_without_port(const std::string& peer) {
  if (peer.rfind("ipv4:", 0) != 0 && peer.rfind("ipv6:", 0) != 0) return peer;
  const size_t colon = peer.rfind(':');
  return colon <= 4 ? peer : peer.substr(0, colon);
}

Authenticator::FileStamp Authenticator::stamp() const {
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) return {};
  return {int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec, int64_t(st.st_size)};
}

bool Authenticator::changed_on_disk() const {
  return enabled() && !(stamp() == loaded_);
}

Status Authenticator::reload() {
  if (!enabled()) return Status::Ok();
  loaded_ = stamp();
  auto loaded = TenantTokens::load(path_);
  if (!loaded.ok()) return loaded.status();
  auto tokens = std::make_shared<const TenantTokens>(std::move(*loaded));
  spdlog::info("--auth-tokens {}: {} tenant(s), {} token(s)", path_, tokens->tenants(), tokens->tokens());
  std::lock_guard<std::mutex> lock(mu_);
  tokens_ = std::move(tokens);
  return Status::Ok();
}

grpc::Status Authenticator::identify(const grpc::ServerContextBase& context, Caller* caller) const {
  if (!enabled()) {
    *caller = Caller{"", address_without_port(context.peer()), 0};
    return grpc::Status::OK;
  }
  const auto& metadata = context.client_metadata();
  auto it = metadata.find("authorization");
  if (it == metadata.end())
    return {grpc::StatusCode::UNAUTHENTICATED,
            "this server requires a bearer token (metadata 'authorization: Bearer TOKEN'; vpremesh reads it from "
            "--token-file or $VPREMESH_TOKEN)"};
  const std::string_view value(it->second.data(), it->second.size());
  const std::string_view scheme = "Bearer ";
  if (value.substr(0, scheme.size()) != scheme)
    return {grpc::StatusCode::UNAUTHENTICATED, "the authorization metadata must be 'Bearer TOKEN'"};
  std::shared_ptr<const TenantTokens> tokens;
  {
    std::lock_guard<std::mutex> lock(mu_);
    tokens = tokens_;
  }
  auto tenant = tokens ? tokens->find(value.substr(scheme.size())) : std::nullopt;
  if (!tenant) {
    spdlog::info("refused a call from {}: unknown bearer token", address_without_port(context.peer()));
    return {grpc::StatusCode::UNAUTHENTICATED, "unknown or revoked bearer token"};
  }
  *caller = Caller{tenant->name, tenant->name, tenant->max_jobs};
  return grpc::Status::OK;
}

}  // namespace vpr::service
