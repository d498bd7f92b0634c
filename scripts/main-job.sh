#!/usr/bin/env bash
# The README's first command: install, build, put `ttp` on PATH (a link
# /usr/local/bin/ttp -> build/app/ttp), run the main job on the embedded
# defaults into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
ln -sf "$PWD/build/app/ttp" /usr/local/bin/ttp
echo "ttp is $PWD/build/app/ttp, linked as /usr/local/bin/ttp"
ttp run -o out
