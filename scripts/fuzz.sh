#!/usr/bin/env bash
# The fuzz stage: builds every libFuzzer target with clang
# (-fsanitize=fuzzer,address,undefined) into build-fuzz/ and runs each for
# FUZZ_SECONDS (default 25) on a copy of its seed corpus. Exits non-zero
# when a target finds a crash, leaving the input in build-fuzz/artifacts/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${FUZZ_SECONDS:-25}"
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
failed=()
for exe in build-fuzz/fuzz/fuzz_*; do
  [[ -x "$exe" && -f "$exe" ]] || continue
  name="${exe##*/fuzz_}"
  work="build-fuzz/corpus/$name"
  mkdir -p "$work"
  seeds="fuzz/corpus/$name"
  [[ -d "$seeds" ]] || seeds=""
  echo "fuzz $name: ${seconds} s"
  # New inputs go to the working corpus; the committed seeds stay as they are.
  # A fixed seed: the same run on every machine (same input, same output).
  if ! "$exe" -seed=1 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -max_len=65536 -print_final_stats=0 \
      -artifact_prefix="build-fuzz/artifacts/${name}-" \
      "$work" ${seeds:+"$seeds"} >"build-fuzz/$name.log" 2>&1; then
    failed+=("$name")
    tail -40 "build-fuzz/$name.log"
  fi
done
if ((${#failed[@]})); then
  echo "fuzz: crashes in ${failed[*]} (inputs in build-fuzz/artifacts/)"
  exit 1
fi
echo "fuzz: every target ran ${seconds} s without a crash"
