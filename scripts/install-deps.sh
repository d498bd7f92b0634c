#!/usr/bin/env bash
# Installs every Debian 12 package the project needs (run as root). Safe to
# run again: apt-get skips what is there.
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  libeigen3-dev libceres-dev libpcl-dev libcgal-dev libopenmesh-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev
  libtomlplusplus-dev libgtest-dev
  linuxcnc-uspace
  slurm-wlm munge parallel
  chromium chromium-driver
  python3 python3-jsonschema
  clang-14 libclang-rt-14-dev ccache
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" \
    || missing+=("$p")
done
# npm ships with the image's Node.js; Debian's own npm only where it is absent.
command -v npm >/dev/null || missing+=(nodejs npm)
if ((${#missing[@]})); then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq "${missing[@]}" >/dev/null
fi
# The report's plotting library (uPlot) comes from the npm registry, pinned by
# report/web/package-lock.json, and is embedded into the binary at build time.
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ -f "$root/report/web/package-lock.json" &&
      ! -f "$root/report/web/node_modules/uplot/dist/uPlot.iife.min.js" ]]; then
  (cd "$root/report/web" && npm ci --no-audit --no-fund --silent)
fi
echo "dependencies: ${#packages[@]} Debian packages present, npm modules installed"
