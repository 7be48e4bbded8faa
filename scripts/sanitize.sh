#!/usr/bin/env bash
# `make sanitize`: builds everything with AddressSanitizer + UBSan (the
# `sanitize` preset, build/sanitize) and runs every CPU test (labels cpu and
# sanitize: the latter adds every shared model at two targets and the
# fuzzers' regression inputs) with the options of scripts/sanitizer-env.sh.
# A sanitizer report, a leak or a failed test makes it exit non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh sanitize
cmake --preset sanitize >/dev/null
cmake --build build/sanitize -j"$(nproc)"
# shellcheck source=scripts/sanitizer-env.sh
source scripts/sanitizer-env.sh
# Left out, because what they check changes meaning under ASan, not because
# of a report (docs/fuzzing.md):
# - a job killed with SIGSEGV: ASan's handler turns the signal into a report
#   and exit status 1, so "died of SIGSEGV" cannot be seen;
# - a 1 s CPU limit that a small job must stay under, and a drain whose job
#   must end within 30 s: ASan makes the jobs 2-4 times slower.
skip='KilledJobProcessFailsOnlyItsJob/SIGSEGV|JobProcessLimitsTest\.CpuTimeLimitEndsTheJob|ServiceTest\.SigtermDrains'
cd build/sanitize
ctest --output-on-failure -j"$(nproc)" --timeout 1800 -L '^(cpu|sanitize)$' -E "$skip"
