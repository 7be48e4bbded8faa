#!/usr/bin/env bash
# Installs every Debian package vpremesh needs to build, test and run its demo
# (and, with the argument `sanitize`, to build the sanitizer and fuzzing tests).
# Idempotent: prints nothing and exits quickly when everything is present.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libdraco-dev libopenmesh-dev libflann-dev liblz4-dev libcgal-dev libgmp-dev libmpfr-dev
  libeigen3-dev libtbb-dev libspdlog-dev libfmt-dev libgtest-dev libgmock-dev
  libosmesa6-dev libegl-dev libegl1-mesa-dev libegl-mesa0 libgl1-mesa-dri libgl-dev
  libpng-dev libjpeg62-turbo-dev nlohmann-json3-dev libcli11-dev libmeshoptimizer-dev
  libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc
  python3-grpcio python3-protobuf python3-yaml python3-numpy
  python3-venv python3-pip python3-setuptools python3-wheel  # pip install ./client/python, offline
  redis-server libhiredis-dev libssl-dev openssl
  libgoogle-perftools-dev  # tcmalloc for the programs (cmake/Allocator.cmake)
)
# `install-deps.sh sanitize` (make sanitize, scripts/fuzz.sh): clang, its
# sanitizer and libFuzzer runtimes, and llvm-symbolizer for readable reports.
if [ "${1:-}" = sanitize ]; then
  packages+=(clang libclang-rt-14-dev llvm-14)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
