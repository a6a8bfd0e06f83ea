#!/usr/bin/env bash
# The light-grid issue's measurements on the device machine (issue 10), with the binaries
# staged as .device/tiledlight-before and .device/tiledlight-after (stripped release builds)
# and the loader packages in .gl (../shared/tools/device-prep.sh --no-build).
# Usage: scripts/device-grid-ab.sh ab ROUND | extras
# ab: the `grid` set of device-bench.sh with both binaries, before then after.
# extras: memory and images at 1080p with 1,024 lights (both binaries, both methods),
#   65,536 lights (both methods, after), a 16384x16384 frame with 16 lights (both binaries).
set -uo pipefail
out=${OUT:-grid-ab-out}
mkdir -p "$out"
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
case ${1:-ab} in
ab)
  r=${2:-1}
  for b in before after; do
    BIN=.device/tiledlight-$b PREFIX=$b$r- OUT="$out" bash scripts/device-bench.sh grid
  done
  ;;
extras)
  for b in before after; do
    for m in forward-plus deferred; do
      timeout 120 .device/tiledlight-$b render --width 1920 --height 1080 --lights 1024 --method $m \
        --out "$out/$b-$m-1024.png" > "$out/$b-$m-1024.txt" 2>&1
    done
    timeout 300 .device/tiledlight-$b bench --width 16384 --height 16384 --lights 16 --frames 3 --warmup 1 \
      > "$out/$b-16k.txt" 2>&1; echo "exit $?" >> "$out/$b-16k.txt"
  done
  for m in forward-plus deferred; do
    timeout 300 .device/tiledlight-after render --width 1920 --height 1080 --lights 65536 --method $m \
      --out "$out/after-$m-65536.png" > "$out/after-$m-65536.txt" 2>&1; echo "exit $?" >> "$out/after-$m-65536.txt"
  done
  ;;
esac
