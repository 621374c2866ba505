#!/usr/bin/env bash
# The main job: builds binpick and runs the picking test of the paper's Table III in the simulated cell
# (tools/binpick_sim: ours vs baselines A, B, C on the 5 part types) on defaults that finish in a few
# minutes on 2 cores. Writes to out/: picking_test.txt (tables), summary.json, cycles.csv (one row per
# cycle), fused_depth.png / fused_depth_mm.png / votes.png (a cycle's fusion), sensing_path.svg and
# timeline.svg (robot segments vs processing stages). Installs what it needs first.
#   --full        5 types x 20 runs x 20 parts at the sensor's full 1280 x 1024 (hours; binpick_sim --help)
#   --calibrate   first determine the sensing parameters in the cell (paper III.D.2, tools/binpick_calibrate)
#                 and use them instead of the paper's Table III values
# Other arguments are passed to binpick_sim (see binpick_sim --help).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j2 --target binpick_sim binpick_calibrate
mkdir -p out
calibrate=0
args=()
for a in "$@"; do
  if [ "$a" = "--calibrate" ]; then calibrate=1; else args+=("$a"); fi
done
if [ "$calibrate" = 1 ]; then
  ./build/tools/binpick_calibrate/binpick_calibrate --out out/sensing_parameters.txt | tee out/calibration.json
  args+=(--params out/sensing_parameters.txt)
fi
./build/tools/binpick_sim/binpick_sim --out out --csv out/cycles.csv --summary out/summary.json ${args[@]+"${args[@]}"} \
  | tee out/picking_test.txt
