#!/usr/bin/env bash
# Configures and builds into build/ (Release).
set -euo pipefail
cd "$(dirname "$0")/.."
# The tests use a precompiled header (tests/CMakeLists.txt): ccache, when it
# is the launcher (e.g. CMAKE_CXX_COMPILER_LAUNCHER), caches them only so.
export CCACHE_SLOPPINESS=pch_defines,time_macros
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
