#!/usr/bin/env bash
# Runs the benchmark set recorded in docs/PERFORMANCE.md on the device machine (H100):
# staged by ../shared/tools/device-prep.sh (.gl loader packages, .device/tiledlight).
# Writes one JSON per configuration and a log under $OUT (or ./bench-out).
# Usage: scripts/device-bench.sh [quick]
set -uo pipefail
out=${OUT:-bench-out}
mkdir -p "$out"
if ls .gl/*.deb >/dev/null 2>&1; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
bin=./.device/tiledlight
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,memory.total --format=csv,noheader | tee "$out/gpu.txt"
frames=${FRAMES:-200}
run() { # name, args...
  local name=$1; shift
  echo "== $name: $*" | tee -a "$out/log.txt"
  timeout 300 "$bin" bench --width 1920 --height 1080 --frames "$frames" --warmup 30 --json "$out/$name.json" "$@" 2>&1 | tee -a "$out/log.txt" | grep -E "^(pass|depth|forward|brute|tonemap|total|CPU|error)"
}
run fp-1024 --lights 1024
run fp-4096 --lights 4096
run fp-16384 --lights 16384
run bf-1024 --lights 1024 --method brute-force --frames 50
if [ "${1:-}" != quick ]; then
  run fp-16384-aabb --lights 16384 --aabb
  run fp-16384-halfz --lights 16384 --half-z
  run fp-16384-t8 --lights 16384 --tile-size 8
  run fp-16384-t32 --lights 16384 --tile-size 32
  run fp-1024-grid --lights 1024 --grid-objects 280 --density medium
  run fp-65536 --lights 65536 --capacity 1024
fi
