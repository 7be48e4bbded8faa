# Every dependency is a Debian 12 package installed by scripts/install-deps.sh.
find_package(Threads REQUIRED)
find_package(TBB REQUIRED)
find_package(draco REQUIRED)
find_package(flann REQUIRED)
find_package(CGAL REQUIRED)
find_package(Eigen3 REQUIRED NO_MODULE)
find_package(spdlog REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(CLI11 REQUIRED)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)  # libjpeg62-turbo-dev: glTF base-color textures
find_package(PkgConfig REQUIRED)

if(VPR_EGL)
  pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
endif()
if(VPR_OSMESA)
  pkg_check_modules(OSMESA REQUIRED IMPORTED_TARGET osmesa)
endif()
if(NOT VPR_EGL AND NOT VPR_OSMESA)
  message(FATAL_ERROR "vpremesh needs at least one renderer: VPR_EGL or VPR_OSMESA")
endif()

# The service (proto/, server/). Debian 12 ships no CMake config for gRPC, so
# the libraries come from pkg-config and the code generators from PATH. The
# service is skipped (with a message) where they are missing.
pkg_check_modules(GRPCPP IMPORTED_TARGET grpc++)
pkg_check_modules(PROTOBUF IMPORTED_TARGET protobuf)
find_program(VPR_PROTOC protoc)
find_program(VPR_GRPC_CPP_PLUGIN grpc_cpp_plugin)
find_library(VPR_GRPCPP_REFLECTION grpc++_reflection)
# The Redis Streams job queue (server/redis_*, vpremesh-worker): hiredis 0.14.
pkg_check_modules(HIREDIS IMPORTED_TARGET hiredis)
# SHA-256 and constant-time comparison of bearer tokens (server/tenant_tokens.cpp).
find_package(OpenSSL REQUIRED COMPONENTS Crypto)

if(VPR_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
