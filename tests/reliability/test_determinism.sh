#!/usr/bin/env bash
# Determinism across processes: the same program with the same inputs, seed and thread count gives
# byte-identical output when run twice. Timing fields ("time*", "*_ms", "*_s") are removed first.
# Usage: test_determinism.sh <reliability_fingerprint> [<binpick_fuse> <data-dir>]
# (The simulated picking test is not compared: the pipeline adds measured processing time to the
# simulated clock, so its cycles depend on the machine load by design.)
set -u
fp="$1"
fuse="${2:-}"
data="${3:-}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
strip_timing() { sed -E 's/"[A-Za-z_]*(time|_ms|_s|seconds)[A-Za-z_]*": *[-0-9.eE+]+,? *//g'; }

"$fp" >"$tmp/a" || fail "fingerprint run 1"
"$fp" >"$tmp/b" || fail "fingerprint run 2"
cat "$tmp/a"
cmp -s "$tmp/a" "$tmp/b" || { diff "$tmp/a" "$tmp/b"; fail "fusion fingerprints differ between two processes"; }

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
