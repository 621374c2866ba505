#!/usr/bin/env bash
# The main job: builds binpick and runs the demo on its defaults. Installs what it needs first.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j2 --target binpick_demo
mkdir -p out
./build/examples/binpick_demo/binpick_demo --out out "$@"
