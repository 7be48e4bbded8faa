# Sourced by scripts/sanitize.sh and scripts/fuzz.sh (and by hand, before
# running a binary of build/sanitize): how AddressSanitizer, UBSan and
# LeakSanitizer report. Every report ends the process with a non-zero status
# (UBSan too: the code is built with -fno-sanitize-recover), so the test or
# fuzzer that hit it fails. Leaks are reported; tests/sanitize/lsan.supp may
# silence a third-party library's, never ours.
_vpr_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
_vpr_symbolizer=$(command -v llvm-symbolizer || command -v llvm-symbolizer-14 || echo /usr/lib/llvm-14/bin/llvm-symbolizer)
export ASAN_SYMBOLIZER_PATH=$_vpr_symbolizer
export ASAN_OPTIONS=halt_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=0
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export LSAN_OPTIONS=suppressions=$_vpr_root/tests/sanitize/lsan.supp:print_suppressions=0
unset _vpr_root _vpr_symbolizer
