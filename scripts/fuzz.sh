#!/usr/bin/env bash
# Fuzzes the mesh parsers with libFuzzer + ASan/UBSan for SECONDS (default 60).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
bash scripts/install-deps.sh
command -v clang++ >/dev/null || apt-get install -y -qq clang >/dev/null
flags="-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer"  # coverage for the libraries too
cmake -S . -B build/fuzz -G Ninja -DVPR_FUZZ=ON -DVPR_CUDA=OFF -DVPR_BUILD_TESTS=ON \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" >/dev/null
cmake --build build/fuzz --target mesh_parse_fuzzer -j"$(nproc)"
mkdir -p build/fuzz/corpus
build/fuzz/tests/mesh_parse_fuzzer build/fuzz/corpus -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536
