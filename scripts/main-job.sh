#!/usr/bin/env bash
# The README's first command: install, build, run the main job on the
# embedded defaults into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
./build/app/ttp run -o out
