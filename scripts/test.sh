#!/usr/bin/env bash
# The README's second command: install, build, run every test; then the
# whole suite again under AddressSanitizer and UndefinedBehaviorSanitizer,
# then every fuzz target for a bounded time (docs/ARCHITECTURE.md, "CI").
#   TTP_TEST_STAGES  which stages to run (default "release sanitize fuzz")
#   FUZZ_SECONDS     seconds per fuzz target (default 15; 15 targets)
set -euo pipefail
cd "$(dirname "$0")/.."
stages="${TTP_TEST_STAGES:-release sanitize fuzz}"
jobs="$(nproc)"
stage_start=$SECONDS
stage_done() {
  echo "== stage $1: $((SECONDS - stage_start)) s"
  stage_start=$SECONDS
}
bash scripts/install-deps.sh

if [[ " $stages " == *" release "* ]]; then
  bash scripts/build.sh
  (cd build && ctest --output-on-failure -j"$jobs" --timeout 900)
  stage_done release
fi

# Sanitizer stage: every test built with clang-14 and
# -fsanitize=address,undefined (-fno-sanitize-recover=undefined: the first
# undefined behaviour fails the test), in the one sanitized build that also
# holds the fuzz targets (scripts/sanitized-build.sh). Left out: the tests
# that only drive external programs whose code is not ours and not
# instrumented (Rs274Test: the rs274 interpreter's canon output; BrowserTest
# and Pages/BrowserKinds: Chromium drawing the report; LinuxCncController:
# LinuxCNC's task, motion and HAL running the programs, about two minutes
# that would only repeat the release stage), and the two that run the
# finished ttp as a user does, many times over (Docs/: the commands of the
# README and docs/*.md as written; outside.: the outside generator's
# battery and cloud checks), 8-10 times slower here, about five minutes of the stage;
# everything of ttp that those paths run is covered by the other tests
# (the CLI tests run every command and measurement kind). The sanitized
# build does not build the executables of the last four
# (TTP_BUILD_END_TO_END_TESTS); the pattern also keeps them out of a
# build-san/ configured by hand.
if [[ " $stages " == *" sanitize "* ]]; then
  bash scripts/sanitized-build.sh
  (cd build-san &&
    ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --output-on-failure -j"$jobs" --timeout 1800 \
      -E '^(Rs274Test|BrowserTest|LinuxCncController)\.|^Pages/BrowserKinds\.|^Docs/|^outside\.')
  stage_done sanitize
fi

if [[ " $stages " == *" fuzz "* ]]; then
  bash scripts/fuzz.sh
  stage_done fuzz
fi
