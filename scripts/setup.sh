#!/usr/bin/env bash
# Installs the Debian packages binpick's build, tests, tools and benchmarks need, only when missing.
# Idempotent and quiet when everything is already there. Run as root (or with sudo available).
set -euo pipefail
pkgs=(cmake g++ make pkg-config ccache libeigen3-dev libflann-dev liblz4-dev libgtest-dev
      librapidcheck-dev libopencv-dev libstb-dev clang libclang-rt-14-dev libomp-14-dev)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "binpick setup: installing ${missing[*]}" >&2
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
