#!/usr/bin/env bash
# The fuzz stage: builds every libFuzzer target with clang
# (-fsanitize=fuzzer,address,undefined) into build-fuzz/ and runs each for
# FUZZ_SECONDS (default 15) on a copy of its seed corpus, as many targets
# at a time as there are cores. Exits non-zero
# when a target finds a crash, leaving the input in build-fuzz/artifacts/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${FUZZ_SECONDS:-15}"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# -O1 with line tables: libFuzzer's advice; a crash still names file and
# line, and the build is far quicker than with full debug information.
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
  -DCMAKE_CXX_COMPILER=clang++-14 -DTTP_BUILD_FUZZ=ON \
  -DTTP_BUILD_TESTS=OFF -DTTP_BUILD_BENCH=OFF "${launcher[@]}" >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_all
mkdir -p build-fuzz/artifacts
rm -f build-fuzz/*.failed
# One target per core at a time (libFuzzer runs one process per target).
run_target() {
  local exe="$1" name="${1##*/fuzz_}"
  local work="build-fuzz/corpus/$name" seeds="fuzz/corpus/$name"
  mkdir -p "$work"
  [[ -d "$seeds" ]] || seeds=""
  echo "fuzz $name: ${seconds} s"
  # New inputs go to the working corpus; the committed seeds stay as they are.
  # A fixed seed: the same run on every machine (same input, same output).
  if ! "$exe" -seed=1 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -max_len=65536 -print_final_stats=0 \
      -artifact_prefix="build-fuzz/artifacts/${name}-" \
      "$work" ${seeds:+"$seeds"} >"build-fuzz/$name.log" 2>&1; then
    touch "build-fuzz/$name.failed"
  fi
}
slots="$(nproc)"
for exe in build-fuzz/fuzz/fuzz_*; do
  [[ -x "$exe" && -f "$exe" ]] || continue
  while (($(jobs -rp | wc -l) >= slots)); do wait -n || true; done
  run_target "$exe" &
done
wait
failed=()
for f in build-fuzz/*.failed; do
  [[ -e "$f" ]] || continue
  name="$(basename "$f" .failed)"
  failed+=("$name")
  echo "== fuzz $name failed:"
  tail -40 "build-fuzz/$name.log"
done
if ((${#failed[@]})); then
  echo "fuzz: crashes in ${failed[*]} (inputs in build-fuzz/artifacts/)"
  exit 1
fi
echo "fuzz: every target ran ${seconds} s without a crash"
