#!/usr/bin/env bash
# Runs binpick_fuse on the real Redwood frames (when the data folder exists) and on bad input.
set -u
bin="$1"
data="${2:-}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# Bad input: clear message, non-zero exit, never a crash (exit code >= 128 would be a signal).
expect_error() {
  "$@" >"$tmp/out" 2>"$tmp/err"
  rc=$?
  [ $rc -ne 0 ] && [ $rc -lt 128 ] || fail "expected a clean error from: $* (rc=$rc)"
  [ -s "$tmp/err" ] || fail "no message for: $*"
}
expect_error "$bin"
expect_error "$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --view "$tmp/missing.png" "$tmp/missing.txt" --out "$tmp/o.png"
printf 'not a png' > "$tmp/bad.png"
printf '1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n' > "$tmp/I.txt"
expect_error "$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --view "$tmp/bad.png" "$tmp/I.txt" --out "$tmp/o.png"
expect_error "$bin" --intrinsics 0,525,319.5,239.5,640,480 --depth-scale 1000 --view "$tmp/bad.png" "$tmp/I.txt" --out "$tmp/o.png"
printf '1 0 0 0\n0 1 0 0\n0 0 1 0\n' > "$tmp/short.txt"

if [ -n "$data" ] && [ -d "$data/redwood_rgbd" ]; then
  rw="$data/redwood_rgbd"
  # trajectory.log: a line "i j k" then 4 matrix rows, per frame.
  for f in 0 1 2; do
    awk -v f=$f 'NR >= f*5+2 && NR <= f*5+5' "$rw/trajectory.log" > "$tmp/pose$f.txt"
  done
  expect_error "$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --view "$rw/depth/00000.png" "$tmp/short.txt" --out "$tmp/o.png"
  expect_error "$bin" --intrinsics 525,525,319.5,239.5,320,240 --depth-scale 1000 --view "$rw/depth/00000.png" "$tmp/pose0.txt" --out "$tmp/o.png"
  out=$("$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 \
        --view "$rw/depth/00000.png" "$tmp/pose0.txt" --view "$rw/depth/00001.png" "$tmp/pose1.txt" \
        --view "$rw/depth/00002.png" "$tmp/pose2.txt" --out "$tmp/fused.png" --votes "$tmp/votes.png" --accuracy 0.005) \
    || fail "fusion of the Redwood frames failed"
  echo "$out"
  echo "$out" | grep -q '"valid_pixels_fused": [1-9]' || fail "no valid fused pixels"
  echo "$out" | grep -q '"icp_status"' || fail "no per-view registration report"
  off=$("$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --register off \
        --view "$rw/depth/00000.png" "$tmp/pose0.txt" --view "$rw/depth/00001.png" "$tmp/pose1.txt" \
        --out "$tmp/fused_off.png" --accuracy 0.005) || fail "fusion without registration failed"
  echo "$off" | grep -q '"icp_status"' && fail "--register off still registered"
  expect_error "$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --register maybe \
        --view "$rw/depth/00000.png" "$tmp/pose0.txt" --out "$tmp/o.png"
  [ -s "$tmp/fused.png" ] && [ -s "$tmp/votes.png" ] || fail "outputs not written"
  # Fusing into frame 0's pose from frames 1 and 2 only (a virtual view) must also work.
  "$bin" --intrinsics 525,525,319.5,239.5,640,480 --depth-scale 1000 --target-pose "$tmp/pose0.txt" \
        --view "$rw/depth/00001.png" "$tmp/pose1.txt" --view "$rw/depth/00002.png" "$tmp/pose2.txt" \
        --out "$tmp/virtual.png" --accuracy 0.005 | grep -q '"target"' || fail "virtual target fusion failed"
fi
echo OK
