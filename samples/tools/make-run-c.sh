#!/bin/bash
# Makes samples/run-c with the project's own generators and fixed seeds
# (samples/README.md). Run from the repository root after a build:
#   bash samples/tools/make-run-c.sh build
set -euo pipefail
build=${1:-build}
ttp="$build/app/ttp"
out=samples/run-c
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rm -rf "$out"
# The run: TALC log, the piece as a CMM cloud, the truth.
"$ttp" twin --effect tool_wear --size 20 --seed 11 --points 8000 -o "$out"
# The same run's per-feature results (nearly noise-free: the point noise
# only sets the fit noise of these results), from which the other instruments'
# files are simulated.
"$ttp" twin --effect tool_wear --size 20 --seed 11 --points 8000 \
  --point-noise-um 0.02 --measurement json -o "$tmp/json"
"$build/samples/tools/make_samples" "$tmp/json/measured.json" "$out/talc.csv" "$out" 11
# A thermal test log: the first 2 h of the public FL thermal data, one row
# a minute (thermal-log.md).
awk -F, '/^#/ || /^t_s/ {print; next} $1 < 7200 && $1 % 60 == 0 {print}' \
  reference/fl-thermal/train.csv > samples/thermal-log.csv
