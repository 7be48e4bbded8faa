#!/usr/bin/env bash
# `make sanitize`: builds the tests that tests/CMakeLists.txt names in
# VPR_SANITIZE_TESTS, and the fuzzers, with AddressSanitizer + UBSan (the
# `sanitize` preset, build/sanitize), then runs them with the options of
# scripts/sanitizer-env.sh. A sanitizer report, a leak or a failed test makes
# it exit non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh sanitize
cmake --preset sanitize >/dev/null
cmake --build build/sanitize -j"$(nproc)" --target sanitize_tests
# shellcheck source=scripts/sanitizer-env.sh
source scripts/sanitizer-env.sh
cd build/sanitize
ctest --output-on-failure -j"$(nproc)" --timeout 1800 -L sanitize
