#!/usr/bin/env bash
# The sanitized build of scripts/test.sh, in build-san/: every library, the
# tests and the libFuzzer targets, built once with clang-14 and
# -fsanitize=address,undefined -fno-sanitize-recover=undefined; the
# libraries also carry libFuzzer's coverage instrumentation
# (-fsanitize=fuzzer-no-link), which the fuzz targets need and the tests'
# own code leaves out (tests/CMakeLists.txt); the end-to-end tests that the
# sanitizer stage does not run are not built. One build serves the
# sanitizer stage and the fuzz stage: on 2 cores a build of the whole tree
# is most of either stage's time.
#   scripts/sanitized-build.sh [target...]   (default: everything)
# -O2 with line tables: a report still names file and line; at -O1 Eigen's
# templates are not inlined and the tests ran about twice as long (measured
# with gcc's sanitizers). The tests' own code is built at -O1
# (tests/CMakeLists.txt). On 2 cores: the build about 12 min (a unity
# build: CMakeLists.txt), the sanitizer stage's tests about 11 min.
set -euo pipefail
cd "$(dirname "$0")/.."
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
export CCACHE_SLOPPINESS=pch_defines,time_macros
cmake -S . -B build-san -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
  -DCMAKE_CXX_COMPILER=clang++-14 -DTTP_BUILD_FUZZ=ON \
  -DTTP_BUILD_BENCH=OFF -DTTP_BUILD_END_TO_END_TESTS=OFF \
  "${launcher[@]}" >/dev/null
if (($#)); then
  for target in "$@"; do
    cmake --build build-san -j"$(nproc)" --target "$target"
  done
else
  cmake --build build-san -j"$(nproc)"
fi
