#!/usr/bin/env bash
# Fuzzes each target for SECONDS (default 60) with libFuzzer + ASan/UBSan, one
# after the other, and exits 1 if any found a crash, a sanitizer report, a
# leak, a timeout or an out-of-memory (docs/fuzzing.md).
#   scripts/fuzz.sh [SECONDS] [TARGET...]   targets: obj ply off stl draco gltf pipeline (default: all)
# Builds in build/sanitize (the `sanitize` preset, shared with `make
# sanitize`). Seeds are generated into build/fuzz/seeds/TARGET; what a run
# learns stays in build/fuzz/corpus/TARGET for the next run; findings land in
# build/fuzz/findings/TARGET and each run's log in build/fuzz/logs/TARGET.log.
# FUZZ_FLAGS adds libFuzzer flags (e.g. -jobs=2 -workers=2).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(obj ply off stl draco gltf pipeline)
build=build/sanitize
work=build/fuzz

bash scripts/install-deps.sh sanitize
[ -f $build/build.ninja ] || cmake --preset sanitize >/dev/null
cmake --build $build -j"$(nproc)" --target fuzz_seeds "${targets[@]/%/_fuzzer}"
# shellcheck source=scripts/sanitizer-env.sh
source scripts/sanitizer-env.sh

# Seeds: pieces of the shared models and generated shapes in every format;
# the legacy Draco files and the inputs that once corrupted memory as they are.
seeds=$work/seeds
if [ ! -f $seeds/.done ] || [ tests/fuzz/fuzz_seeds.cpp -nt $seeds/.done ]; then
  rm -rf $seeds
  $build/tests/fuzz/fuzz_seeds $seeds ../shared/models ../shared/crashers/*.{obj,off}
  cp ../shared/drc/*.drc $seeds/draco/
  cp ../shared/crashers/*.obj $seeds/obj/
  cp ../shared/crashers/*.off $seeds/off/
  touch $seeds/.done
fi

failed=()
for t in "${targets[@]}"; do
  mkdir -p $work/corpus/$t $work/findings/$t $work/logs
  # The pipeline renders six views per input: give it time and more memory.
  limits=(-max_len=32768 -timeout=10 -rss_limit_mb=2048)
  [ "$t" = pipeline ] && limits=(-max_len=16384 -timeout=60 -rss_limit_mb=3072)
  dict=()
  [ -f tests/fuzz/$t.dict ] && dict=(-dict=tests/fuzz/$t.dict)
  inputs=($work/corpus/$t $seeds/$t)  # the first one is where new inputs go
  [ -d tests/fuzz/regressions/$t ] && inputs+=(tests/fuzz/regressions/$t)
  echo "fuzz: $t for ${seconds}s"
  set +e
  # shellcheck disable=SC2086
  $build/tests/fuzz/${t}_fuzzer "${inputs[@]}" \
    -max_total_time="$seconds" "${limits[@]}" "${dict[@]}" -print_final_stats=1 \
    -artifact_prefix=$work/findings/$t/ ${FUZZ_FLAGS:-} >$work/logs/$t.log 2>&1
  rc=$?
  set -e
  grep -E "^#[0-9]+[[:space:]]+DONE" $work/logs/$t.log | tr -s '\t ' ' ' || echo "(no summary: see $work/logs/$t.log)"
  if [ $rc -ne 0 ]; then
    failed+=("$t")
    echo "fuzz: $t FAILED (exit $rc); the report, from $work/logs/$t.log:"
    grep -E -A40 "^==[0-9]+==ERROR|runtime error|broken promise|ALARM|out-of-memory|Test unit written" \
      $work/logs/$t.log | head -80 || tail -40 $work/logs/$t.log
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]} (inputs in $work/findings/)"
  exit 1
fi
echo "fuzz: no findings"
