#!/usr/bin/env bash
# Determinism across processes: the same program with the same inputs, seed and thread count gives
# byte-identical output when run twice. Timing fields ("time*", "*_ms", "*_s") are removed first.
# Usage: test_determinism.sh <reliability_fingerprint> <binpick_sim or -> [<binpick_fuse> <data-dir>]
# The simulated picking test runs with --compute-time (a fixed processing time on the simulated clock;
# by default the measured time is added, so later cycles depend on the machine's load) and with driver
# faults; its per-cycle CSV is compared without the measured-time columns.
set -u
fp="$1"
simtool="${2:--}"
fuse="${3:-}"
data="${4:-}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
strip_timing() { sed -E 's/"[A-Za-z_]*(time|_ms|_s|seconds)[A-Za-z_]*": *[-0-9.eE+]+,? *//g'; }

"$fp" >"$tmp/a" || fail "fingerprint run 1"
"$fp" >"$tmp/b" || fail "fingerprint run 2"
cat "$tmp/a"
cmp -s "$tmp/a" "$tmp/b" || { diff "$tmp/a" "$tmp/b"; fail "fusion fingerprints differ between two processes"; }

if [ "$simtool" != "-" ]; then
  for run in 1 2; do
    "$simtool" --types circle_nut --runs 1 --parts 3 --strategies ours,A,B,C --max-failures 3 --jobs 2 \
      --fault-rate 0.5 --compute-time 60 --seed 2 --resolution 320x256 --csv "$tmp/sim$run.csv" --json 2>/dev/null | strip_timing >"$tmp/sim$run.json" \
      || fail "binpick_sim run $run"
    # Columns 18-20 are the measured fusion, estimation and planning times.
    cut -d, -f1-17,21- "$tmp/sim$run.csv" >"$tmp/sim$run.rows"
  done
  rows=$(($(wc -l <"$tmp/sim1.rows") - 1))
  [ "$rows" -ge 8 ] || fail "binpick_sim ran only $rows cycles"
  grep -q '"fired": [1-9]' "$tmp/sim1.json" || fail "binpick_sim injected no fault"
  # The summary's grip counts are the CSV's: a grip per cycle that picked or failed its grasp.
  tried_json=$(grep -o '"grips_tried": [0-9]*' "$tmp/sim1.json" | awk '{s += $2} END {print s + 0}')
  held_json=$(grep -o '"grips_held": [0-9]*' "$tmp/sim1.json" | awk '{s += $2} END {print s + 0}')
  tried_csv=$(awk -F, 'NR > 1 && ($5 == "picked" || $5 == "grasp_failed")' "$tmp/sim1.csv" | wc -l)
  held_csv=$(awk -F, 'NR > 1 && $5 == "picked"' "$tmp/sim1.csv" | wc -l)
  [ "$tried_json" -eq "$tried_csv" ] && [ "$tried_json" -gt 0 ] || fail "grips tried: summary $tried_json, CSV $tried_csv"
  [ "$held_json" -eq "$held_csv" ] || fail "grips held: summary $held_json, CSV $held_csv"
  echo "binpick_sim: $rows cycles, $tried_csv grips tried, $held_csv held"
  cmp -s "$tmp/sim1.rows" "$tmp/sim2.rows" || { diff "$tmp/sim1.rows" "$tmp/sim2.rows"; fail "binpick_sim cycles differ"; }
  cmp -s "$tmp/sim1.json" "$tmp/sim2.json" || { diff "$tmp/sim1.json" "$tmp/sim2.json"; fail "binpick_sim summaries differ"; }
fi

if [ -n "$fuse" ] && [ -n "$data" ] && [ -d "$data/redwood_rgbd" ]; then
  rw="$data/redwood_rgbd"
  for f in 0 1 2; do awk -v f=$f 'NR >= f*5+2 && NR <= f*5+5' "$rw/trajectory.log" > "$tmp/pose$f.txt"; done
  for run in 1 2; do
    "$fuse" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --threads 2 \
      --view "$rw/depth/00000.png" "$tmp/pose0.txt" --view "$rw/depth/00001.png" "$tmp/pose1.txt" \
      --view "$rw/depth/00002.png" "$tmp/pose2.txt" --out "$tmp/fused$run.png" --votes "$tmp/votes$run.png" \
      --accuracy 0.005 | strip_timing >"$tmp/fuse$run.json" || fail "binpick_fuse run $run"
  done
  cat "$tmp/fuse1.json"
  cmp -s "$tmp/fuse1.json" "$tmp/fuse2.json" || { diff "$tmp/fuse1.json" "$tmp/fuse2.json"; fail "binpick_fuse reports differ"; }
  cmp -s "$tmp/fused1.png" "$tmp/fused2.png" || fail "binpick_fuse fused depth differs"
  cmp -s "$tmp/votes1.png" "$tmp/votes2.png" || fail "binpick_fuse votes differ"
fi

echo "deterministic across processes"
