#!/usr/bin/env bash
# Installs every Debian 12 package the project needs (run as root). Safe to
# run again: apt-get skips what is there.
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  libeigen3-dev libceres-dev libpcl-dev libcgal-dev libopenmesh-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev libspdlog-dev
  libtomlplusplus-dev libgtest-dev
  linuxcnc-uspace
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" \
    || missing+=("$p")
done
if ((${#missing[@]})); then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq "${missing[@]}" >/dev/null
fi
echo "dependencies: ${#packages[@]} packages present"
