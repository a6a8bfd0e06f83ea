#!/usr/bin/env bash
# Issue 16: tiledlight and Bevy side by side on the device machine (one GPU, Vulkan, no
# network), the same scene, lights and camera. Run from the repo root, in one call:
#   .device/tiledlight  the stripped tiledlight binary (as for scripts/device-bench.sh)
#   .device/bevy-peer.gz  the stripped peer binary, gzipped (peers/bevy/README.md builds
#                       it: 54 MiB stripped, 17 MiB gzipped, so that it travels with
#                       tiledlight within the 64 MiB carry limit); a plain
#                       .device/bevy-peer is used as it is
#   .gl/*.deb           the Vulkan loader packages (as for scripts/device-bench.sh)
# For each light count (COUNTS, default 1000 10000 100000) at WIDTHxHEIGHT (1920x1080),
# the courtyard with uniform random point lights, threshold 0.1 * sqrt(N / 1000) (so
# ~ the same lights a tile at every count: 0.1, 0.316, 1.0; 100,000 at threshold 1 is
# docs/PERFORMANCE.md's), one fixed exposure for every renderer (tiledlight's automatic
# exposure of that light set, read from a `render`):
#   1. tiledlight export -> peer/court-N.gltf (kept on the device, not in the tar: big);
#   2. Bevy renders that file: its defaults (4x MSAA, TonyMcMapface, no prepass) and
#      "matched" (MSAA off, ACES fitted, like tiledlight's frame), matched with a depth
#      prepass (as tiledlight's Forward+), and that with BEVY_CLUSTERS (65,536) clusters
#      instead of Bevy's 4,096, not resized; JSON + PNG;
#   3. tiledlight bench + render: Forward+ (default tiled gather; 2.5D light-centric)
#      and Tiled Deferred (tiled and 2.5D, light-centric: its best layouts in
#      docs/PERFORMANCE.md); JSON + PNG.
# Each count's JSON and images go into $OUT/peer-N.tar.gz (the device returns at most 8
# files of 16 MiB each), with $OUT/summary.txt (one line per run), $OUT/log.txt and
# $OUT/gpu.txt beside them.
# The report: for f in OUT/peer-*.tar.gz; do tar -xzf "$f" -C OUT; done; tiledlight peer-report OUT/peer
# BIN= / BEVY= pick other binaries; FRAMES (50), WARMUP (20), COUNTS, WIDTH, HEIGHT.
# DRY_RUN=1 prints the commands without running them (for checking here).
set -uo pipefail
out=${OUT:-peer-out}
mkdir -p "$out/peer"
d=$out/peer
work=${WORK:-$(mktemp -d)}
tl=${BIN:-./.device/tiledlight}
bevy=${BEVY:-./.device/bevy-peer}
W=${WIDTH:-1920}
H=${HEIGHT:-1080}
FRAMES=${FRAMES:-50}
WARMUP=${WARMUP:-20}
COUNTS=${COUNTS:-"1000 10000 100000"}
log=$out/log.txt
summary=$out/summary.txt
: > "$summary"

if [ "${DRY_RUN:-0}" != 1 ]; then
  if ls .gl/*.deb >/dev/null 2>&1; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
  fi
  if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  fi
  command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,memory.total --format=csv,noheader | tee "$d/gpu.txt"
  if [ ! -x "$bevy" ] && [ -f "$bevy.gz" ]; then
    gunzip -c "$bevy.gz" > "$work/bevy-peer" && chmod +x "$work/bevy-peer" && bevy=$work/bevy-peer
  fi
  for b in "$tl" "$bevy"; do [ -x "$b" ] || { echo "error: $b is missing or not executable" | tee -a "$log"; exit 1; }; done
fi

x() { # label timeout command... : runs (or prints) one command, logging it
  local label=$1 limit=$2; shift 2
  echo "== $label: $*" | tee -a "$log"
  if [ "${DRY_RUN:-0}" = 1 ]; then return 0; fi
  timeout "$limit" "$@" >> "$log" 2>&1
  local rc=$?
  [ $rc -ne 0 ] && echo "   FAILED ($label): exit $rc" | tee -a "$log" "$summary"
  return $rc
}

for n in $COUNTS; do
  t=$(awk -v n="$n" 'BEGIN { printf "%.4g", 0.1 * sqrt(n / 1000) }')
  scene="--lights $n --threshold $t --width $W --height $H"
  # tiledlight's automatic exposure of this light set, then fixed for every renderer.
  e=1
  if x "exposure-$n" 120 "$tl" render $scene --out "$d/tl-auto-$n.png"; then
    if [ "${DRY_RUN:-0}" != 1 ]; then
      found=$(grep -E '^exposure: ' "$log" | tail -1 | sed -E 's/^exposure: +([0-9.eE+-]+),.*/\1/')
      [ -n "$found" ] && e=$found
    fi
  fi
  echo "N=$n threshold=$t exposure=$e" | tee -a "$summary"
  gltf=$work/court-$n.gltf
  x "export-$n" 120 "$tl" export $scene --exposure "$e" --out "$gltf" || continue
  # Bevy: its defaults, then matched to tiledlight's frame (no MSAA, ACES).
  x "bevy-$n" 240 "$bevy" --gltf "$gltf" --width "$W" --height "$H" --frames "$FRAMES" --warmup "$WARMUP" \
    --out "$d" --name "bevy-$n"
  x "bevy-matched-$n" 240 "$bevy" --gltf "$gltf" --width "$W" --height "$H" --frames "$FRAMES" --warmup "$WARMUP" \
    --out "$d" --name "bevy-matched-$n" --msaa 1 --tonemapping aces
  # And matched with a depth prepass, as tiledlight's Forward+ has: Bevy's default draws
  # without one, so the courtyard's overdraw is shaded.
  x "bevy-prepass-$n" 240 "$bevy" --gltf "$gltf" --width "$W" --height "$H" --frames "$FRAMES" --warmup "$WARMUP" \
    --out "$d" --name "bevy-prepass-$n" --msaa 1 --tonemapping aces --depth-prepass
  # And that with 16x Bevy's default cluster count (65,536: ~28 px clusters at 1080p
  # instead of ~113 px) and the grid's dynamic resizing off (which otherwise coarsens the
  # grid past 16,384 cluster-light pairs): Bevy's knobs for many small lights.
  x "bevy-clusters-$n" 240 "$bevy" --gltf "$gltf" --width "$W" --height "$H" --frames "$FRAMES" --warmup "$WARMUP" \
    --out "$d" --name "bevy-clusters-$n" --msaa 1 --tonemapping aces --depth-prepass --clusters "${BEVY_CLUSTERS:-65536}" --fixed-clusters
  # A clustering resize between "measuring" and "measured" means measured frames missed
  # lights (bevy-peer's README).
  for b in "bevy-$n" "bevy-matched-$n" "bevy-prepass-$n" "bevy-clusters-$n"; do
    [ "${DRY_RUN:-0}" = 1 ] && continue
    awk -v run="== $b:" 'index($0, run) == 1 { on = 1; next } /^== / { on = 0 }
      on && /bevy-peer: measuring from/ { m = 1 } on && /bevy-peer: measured/ { m = 0 }
      on && m && /Resizing the view clustering/ { bad = 1 } END { exit !bad }' "$log" &&
      echo "  warning: $b: Bevy resized its cluster lists inside the measured frames (some missed lights)" | tee -a "$summary"
  done
  for b in "bevy-$n" "bevy-matched-$n" "bevy-prepass-$n" "bevy-clusters-$n"; do
    [ -f "$d/$b.json" ] && echo "  $b: $(grep -E '"(gpu_frame_ms_median|gpu_sum_of_top_level_pass_medians_ms|cpu_frame_ms_median)"' "$d/$b.json" | tr -d ' \n')" | tee -a "$summary"
  done
  # tiledlight: Forward+ and Tiled Deferred, each in its default and best layouts.
  for cfg in "fp:--method forward-plus" "fp-2.5d:--method forward-plus --assign scatter --grid 2.5d" \
    "td:--method deferred --assign scatter" "td-2.5d:--method deferred --assign scatter --grid 2.5d"; do
    name=tl-${cfg%%:*}-$n
    flags=${cfg#*:}
    x "$name" 240 "$tl" bench $scene --exposure "$e" $flags --frames "$FRAMES" --warmup "$WARMUP" --json "$d/$name.json"
    x "$name-png" 120 "$tl" render $scene --exposure "$e" $flags --out "$d/$name.png"
    [ -f "$d/$name.json" ] && echo "  $name: $(grep -E '"total_gpu_median_ms"' "$d/$name.json" | tr -d ' \n')" | tee -a "$summary"
  done
  # One archive per count: the device returns files of at most 16 MiB, and a count's
  # seven 1080p PNGs take 10-15 MiB.
  if [ "${DRY_RUN:-0}" != 1 ]; then
    rm -f "$d/tl-auto-$n.png"
    tar -czf "$out/peer-$n.tar.gz" -C "$out" $(cd "$out" && ls -d peer/*-"$n".* 2>/dev/null) && rm -f "$d"/*-"$n".*
  fi
done

if [ "${DRY_RUN:-0}" != 1 ]; then
  cp "$d/gpu.txt" "$out/" 2>/dev/null
  rm -rf "$d"
  ls -l "$out"
fi
