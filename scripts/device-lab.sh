#!/usr/bin/env bash
# Runs the measurement lab recorded in docs/PERFORMANCE.md (Figure 9) and docs/ACCURACY.md
# on the device machine (H100), staged like scripts/device-bench.sh (.gl loader packages,
# .device/tiledlight = the release binary). Writes CSVs, charts, FLIP heat maps and a log
# under $OUT and packs them into $OUT/lab.tar.gz; copy them to docs/results/<gpu>-<commit>/.
#
# Time on an H100 (1920x1080): the Figure 9 sweep is 26 points x 40 frames, at most
# ~150 ms a frame (Forward+ at 16,384 lights): ~1 minute; the accuracy sweep is 39
# settings x 15 frames (the lowest thresholds list every light, ~160 ms a frame) plus the
# CPU statistics (threaded, ~1-3 s a setting): 2-3 minutes. Each step has a timeout, and
# both resume from their CSV if rerun with the same $OUT.
# The shadow step (shadow-accuracy: 13 shadow configurations at 960x540 against a CPU ray
# cast of 12 + 12 casters, on every core) runs at its own resolution.
# Usage: scripts/device-lab.sh [figure9] [accuracy] [deferred] [msaa] [shadows] [blended] [layouts] [layouts-surface] [blended-vs-sorted] [vpl] [budget] [tune] [tune-views]
# (default: the first five)
set -uo pipefail
out=${OUT:-lab-out}
mkdir -p "$out"
. "$(dirname "$0")/device-env.sh"
bin=./.device/tiledlight
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,memory.total --format=csv,noheader | tee "$out/gpu.txt"
"$bin" --version | tee -a "$out/log.txt"
step() { # seconds name args...
  local limit=$1 name=$2; shift 2
  echo "== $name: $*" | tee -a "$out/log.txt"
  local t0=$SECONDS
  # shellcheck disable=SC2086 # RES holds two flags and their values.
  timeout "$limit" "$bin" "$@" ${RES:---width 1920 --height 1080} 2>&1 | tee -a "$out/log.txt" | grep -vE "^(threshold|lights)=" 
  echo "== $name: exit ${PIPESTATUS[0]}, $((SECONDS - t0)) s" | tee -a "$out/log.txt"
}
steps=${*:-figure9 accuracy deferred msaa shadows}
for s in $steps; do
  case $s in
  figure9)
    step 150 figure9 sweep --preset figure9 --frames 30 --warmup 10 --out "$out/figure9.csv"
    ;;
  blended)
    # Issue 12: the cost and the image error (against brute force with the sorted blended
    # layer) of 0/10/50/280 glass objects, sorted and weighted blended OIT, Forward+.
    step 300 blended accuracy --grid-objects 280 --density medium --axis threshold=0.05 --axis culling=planes \
      --axis transparent-objects=0,10,50,280 --axis blend-mode=sorted,wboit --frames 15 --out "$out/blended.csv"
    ;;
  layouts)
    # Issue 13: every light-grid layout's culling statistics (false positives, wasted
    # evaluations per pixel, longest list), time and error on one chart: Tiled Deferred,
    # 16,384 lights (the CPU twin scores each point's lists), two radius dials.
    step 400 layouts accuracy --lights 16384 --method deferred --axis threshold=0.05,0.2 \
      --axis grid=tiled,half-z,2.5d,clustered --axis assign=scatter --axis culling=planes \
      --frames 15 --out "$out/layouts.csv"
    ;;
  layouts-surface)
    # The same on lights that sit on the surfaces (16,384, 8 reaching a surface point):
    # small lights, where depth bins and clusters have gaps to find.
    step 400 layouts-surface accuracy --lights 16384 --lights-on-surfaces --method deferred \
      --axis grid=tiled,half-z,2.5d,clustered --axis assign=scatter --axis culling=planes \
      --axis threshold=0.1 --frames 15 --out "$out/layouts-surface.csv"
    ;;
  blended-vs-sorted)
    # Issue 12: what dropping the sort alone costs. Weighted blended OIT against the sorted
    # frame of the same settings (columns sorted_ms, vs_sorted_flip_mean/p99), on glass that
    # overlaps heavily (up to all 280 grid spheres, down the rows), Forward+. The reference
    # has the same cutoff, so flip_mean of a sorted point is ~0 and that of a WBOIT point
    # repeats vs_sorted_flip_mean (a cross-check). 6 points + 3 references.
    step 300 blended-vs-sorted accuracy --grid-objects 280 --density medium --reference cutoff \
      --axis threshold=0.05 --axis culling=planes --axis transparent-objects=50,140,280 \
      --axis blend-mode=sorted,wboit --frames 15 --out "$out/blended-vs-sorted.csv"
    ;;
  budget)
    # Issue 44: the error budget against the traced truth for every method (method is a
    # dial), on the courtyard and the Figure 9 scene: 1,024 point + 256 spot lights at the
    # cutoff's best threshold (0.0015), base Forward+ with 16 point casters brightest-first;
    # each row's worst pixel is explained (worst_* columns). BUDGET_SCENES picks the scenes.
    for sc in ${BUDGET_SCENES:-court f9}; do
      extra=""
      [ "$sc" = f9 ] && extra="--grid-objects 280 --density medium"
      # shellcheck disable=SC2086 # extra holds flags.
      step 580 "budget-$sc" accuracy --lights 1024 --spot-lights 256 --threshold 0.0015 --shadow-point-lights 16 \
        $extra --reference traced --budget --axis method=forward-plus,deferred,visibility \
        --axis shadow-point-lights=16,0,64 --axis threshold=0.0015,0.003,0.0006 --frames 5 --warmup 3 \
        --reference-frames 3 --out "$out/budget-$sc.csv" --diff-dir "$out/budget-$sc-flip"
    done
    ;;
  tune)
    # Issue 44: the tuner's answer for FLIP 0.15 against the truth, default dials, on the
    # courtyard and the Figure 9 scene (TUNE_SCENES picks them).
    for sc in ${TUNE_SCENES:-court f9}; do
      extra=""
      [ "$sc" = f9 ] && extra="--grid-objects 280 --density medium"
      # shellcheck disable=SC2086 # extra holds flags.
      step 590 "tune-$sc" tune --lights 1024 --spot-lights 256 $extra --target-flip 0.15 --frames 5 --warmup 3 \
        --reference-frames 2 --out "$out/tune-$sc.csv"
    done
    ;;
  tune-views)
    # The tuner from two views of the courtyard at once (assets/cameras): the budget must
    # hold from each; the compute methods, the threshold and the casters as dials.
    step 590 tune-views tune --lights 1024 --spot-lights 256 --target-flip 0.15 --frames 5 --warmup 3 \
      --reference-frames 2 --dial method=deferred,visibility --dial threshold=0.0015,0.003 \
      --dial shadow-point-lights=64,256,512 --dial casters-by=contribution,brightness \
      --bookmarks assets/cameras/courtyard-along.txt,assets/cameras/courtyard-above.txt --out "$out/tune-views.csv"
    ;;
  vpl)
    # Issue 15: the VPLs' error against the every-texel one-bounce reference (brute force,
    # physical shading, every RSM texel a VPL, no thresholds, no cap, the same cutoff so
    # that the lights' cutoff does not swamp it) over block size and shading model: the
    # courtyard lit by 64 spot lights alone, 12 of them casting shadows and RSMs of 32x32,
    # Tiled Deferred (its 8-bit albedo is the floor of the error: block 1 physical).
    step 400 vpl accuracy --lights 0 --spot-lights 64 --shadow-spot-lights 12 --method deferred --vpl \
      --reference cutoff --axis threshold=0.05 --axis culling=planes --axis vpl-block=1,2,4,8,16 \
      --axis vpl-shading=sample,physical --frames 10 --warmup 4 --reference-frames 3 --out "$out/vpl.csv"
    ;;
  accuracy)
    # Forward+: its image is the brute force's with the same cutoff, so the error is the
    # cutoff's alone and the culling tests change only the time.
    step 300 accuracy accuracy --frames 10 --warmup 3 --reference-frames 3 --out "$out/accuracy.csv"
    ;;
  deferred)
    # Tiled Deferred over the same thresholds (one culling test): its 8-bit albedo adds a
    # floor of error of its own (tests/tests/deferred.rs: FLIP mean ~0.01 on the courtyard).
    step 120 accuracy-deferred accuracy --method deferred --axis culling=aabb --frames 10 --warmup 3 \
      --reference-frames 3 --out "$out/accuracy-deferred.csv"
    ;;
  msaa)
    # The MSAA edge test's dial: Tiled Deferred 4x over edge thresholds against brute force
    # 4x with the same cutoff (so the cutoff's error does not swamp the edge test's), and
    # Forward+ 4x and Tiled Deferred 1x for scale.
    step 150 accuracy-msaa accuracy --method deferred --msaa 4 --axis threshold=0.1 --axis culling=aabb \
      --axis edge-distance=0.0005,0.002,0.01,0.05,1000 --reference cutoff --frames 10 --warmup 3 \
      --reference-frames 3 --out "$out/accuracy-msaa.csv"
    ;;
  shadows)
    # The shadow maps' own error against a ray cast (docs/ACCURACY.md), with the atlas
    # and shading times of moving lights.
    RES="--width 960 --height 540" step 600 shadow-accuracy shadow-accuracy --frames 10 --warmup 3 \
      --out "$out/shadow-accuracy.json"
    ;;
  *) echo "unknown step $s (figure9, accuracy, deferred, msaa, shadows, blended, layouts, layouts-surface, blended-vs-sorted, vpl, budget, tune, tune-views)" >&2; exit 2 ;;
  esac
done
tar -czf "$out/lab.tar.gz" -C "$out" --exclude lab.tar.gz . && ls -la "$out"
