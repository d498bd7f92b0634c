#!/usr/bin/env bash
# The fuzz stage: builds every libFuzzer target
# (-fsanitize=fuzzer,address,undefined) in the sanitized build, build-san/
# (scripts/sanitized-build.sh; nothing to do when the sanitizer stage has
# built it), and runs each for FUZZ_SECONDS (default 15) on a copy of its
# seed corpus, as many targets at a time as there are cores. Exits non-zero
# when a target finds a crash, leaving the input in build-san/artifacts/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${FUZZ_SECONDS:-15}"
bash scripts/sanitized-build.sh fuzz_all
mkdir -p build-san/artifacts
rm -f build-san/*.failed
# One target per core at a time (libFuzzer runs one process per target).
run_target() {
  local exe="$1" name="${1##*/fuzz_}"
  local work="build-san/corpus/$name" seeds="fuzz/corpus/$name"
  mkdir -p "$work"
  [[ -d "$seeds" ]] || seeds=""
  echo "fuzz $name: ${seconds} s"
  # New inputs go to the working corpus; the committed seeds stay as they are.
  # A fixed seed: the same run on every machine (same input, same output).
  if ! "$exe" -seed=1 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -max_len=65536 -print_final_stats=0 \
      -artifact_prefix="build-san/artifacts/${name}-" \
      "$work" ${seeds:+"$seeds"} >"build-san/$name.log" 2>&1; then
    touch "build-san/$name.failed"
  fi
}
slots="$(nproc)"
for exe in build-san/fuzz/fuzz_*; do
  [[ -x "$exe" && -f "$exe" ]] || continue
  while (($(jobs -rp | wc -l) >= slots)); do wait -n || true; done
  run_target "$exe" &
done
wait
failed=()
for f in build-san/*.failed; do
  [[ -e "$f" ]] || continue
  name="$(basename "$f" .failed)"
  failed+=("$name")
  echo "== fuzz $name failed:"
  tail -40 "build-san/$name.log"
done
if ((${#failed[@]})); then
  echo "fuzz: crashes in ${failed[*]} (inputs in build-san/artifacts/)"
  exit 1
fi
echo "fuzz: every target ran ${seconds} s without a crash"
