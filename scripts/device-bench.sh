#!/usr/bin/env bash
# Runs the benchmark set recorded in docs/PERFORMANCE.md on the device machine (H100):
# staged by ../shared/tools/device-prep.sh (.gl loader packages, .device/tiledlight,
# stripped to travel). Writes one JSON per configuration and a log under $OUT.
# Usage: scripts/device-bench.sh [SET...]   sets: core cull scale methods msaa grid shadows blended million assign gbuffer order summary emission vpl reshape visibility raster raster-short traced stochastic denoise reuse temporal near light-tree million-truth error-time casters casters-curve ranking materials surface-edges stage-lights raster-tiles lists-49 big-scene
# (default: core cull scale methods msaa). BIN=path picks another binary (A/B runs: stage the old one beside it);
# PREFIX= is prepended to every result name.
set -uo pipefail
out=${OUT:-bench-out}
mkdir -p "$out"
. "$(dirname "$0")/device-env.sh"
bin=${BIN:-./.device/tiledlight}
prefix=${PREFIX:-}
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,memory.total --format=csv,noheader | tee "$out/gpu.txt"
run() { # name frames args...
  local name=$prefix$1 frames=$2; shift 2
  echo "== $name: $*" | tee -a "$out/log.txt"
  timeout 300 "$bin" bench --width 1920 --height 1080 --frames "$frames" --warmup 20 --json "$out/$name.json" "$@" 2>&1 \
    | tee -a "$out/log.txt" | grep -E "^(depth|forward|brute|deferred|visibility|stochastic|cull|tonemap|shadow|blended|total|error|MSAA|light grid)"
}
# The traced reference: seconds a frame, so 1 warm-up frame and 2 timed ones.
run_traced() { # name args...
  local name=$prefix$1; shift
  echo "== $name: $*" | tee -a "$out/log.txt"
  timeout 500 "$bin" bench --width 1920 --height 1080 --frames 2 --warmup 1 --json "$out/$name.json" "$@" 2>&1 \
    | tee -a "$out/log.txt" | grep -E "^(visibility|traced|tonemap|total|error|rays)"
}
# The stochastic method's error against the traced truth after 8 frames of a still camera
# (the 8 measured frames: the history restarts after the warm-up) per dial, on the Figure 9 scene (4,096 lights) at the default
# threshold and the budget's 0.0015 and on the courtyard (1,024) at the default; the lab's
# default axes fixed to one value each. Each run's CSV and printout: $out/PREFIX-SCENE-tT.*
run_stochastic_accuracy() { # prefix axes...
  local prefix=$1 run scene t extra; shift
  for run in f9:0.1 f9:0.0015 court:0.1; do
    scene=${run%%:*} t=${run#*:}
    extra=(--lights 1024)
    [ "$scene" = f9 ] && extra=(--lights 4096 --grid-objects 280 --density medium)
    echo "== $prefix-$scene-t$t" | tee -a "$out/log.txt"
    timeout 200 "$bin" accuracy --width 1920 --height 1080 "${extra[@]}" --reference traced --frames 8 \
      --warmup 1 --reference-frames 1 --axis threshold="$t" --axis culling=planes --axis method=stochastic \
      "$@" --out "/tmp/$prefix-$scene-$t/acc.csv" >"$out/$prefix-$scene-t$t.txt" 2>&1
    echo "exit $?" >>"$out/$prefix-$scene-t$t.txt"
    cp "/tmp/$prefix-$scene-$t/acc.csv" "$out/$prefix-$scene-t$t.csv" 2>/dev/null
  done
}

# An error budget against the traced truth (issue 30) on both scenes, 1,024 point + 256
# spot lights, threshold 0.0015, Forward+: each scene's CSV, chart and printout under
# $out/<scene>-NAME.*; its heat maps stay in /tmp.
run_budget() { # name warmup axes...
  local name=$1 warmup=$2; shift 2
  local scene extra
  for scene in court f9; do
    extra=()
    [ "$scene" = f9 ] && extra=(--grid-objects 280 --density medium)
    echo "== $name-$scene" | tee -a "$out/log.txt"
    timeout 280 "$bin" accuracy --width 1920 --height 1080 --lights 1024 --spot-lights 256 "${extra[@]}" \
      --threshold 0.0015 --reference traced --budget --frames 3 --warmup "$warmup" --reference-frames 1 \
      "$@" --out "/tmp/$name-$scene/$name.csv" >"$out/$scene-$name.txt" 2>&1
    echo "exit $?" >>"$out/$scene-$name.txt"
    cp "/tmp/$name-$scene/$name.csv" "$out/$scene-$name.csv" 2>/dev/null
    cp "/tmp/$name-$scene/$name.png" "$out/$scene-$name.png" 2>/dev/null
  done
}
sets=${*:-core cull scale methods msaa}
for set in $sets; do
  case $set in
  core)
    for n in 1024 4096 16384; do run "fp-$n" 100 --lights $n; done
    run bf-1024 20 --lights 1024 --method brute-force
    ;;
  cull)
    for n in 1024 4096 16384; do run "flat-$n" 100 --lights $n --flat-cull; done
    run fp-16384-aabb 100 --lights 16384 --aabb
    run fp-16384-halfz 100 --lights 16384 --half-z
    run fp-16384-t8 100 --lights 16384 --tile-size 8
    run fp-16384-t32 100 --lights 16384 --tile-size 32
    ;;
  methods)
    # Forward+ vs Tiled Deferred, the sample's comparison: ~750k triangles, 4 G-buffer targets.
    for n in 256 1024 4096 16384; do
      run "cmp-fp-$n" 50 --lights $n --grid-objects 280 --density medium
      run "cmp-td-$n" 50 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4
    done
    for rts in 2 3 5; do run "td-rts$rts" 50 --lights 1024 --grid-objects 280 --density medium --method deferred --gbuffer-rts $rts; done
    ;;
  msaa)
    # The methods comparison again with 4x MSAA (and 2x/8x at 1024 lights: the H100 has them).
    for n in 256 1024 4096 16384; do
      run "msaa4-fp-$n" 30 --lights $n --grid-objects 280 --density medium --msaa 4
      run "msaa4-td-$n" 30 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4 --msaa 4
    done
    for s in 2 8; do
      run "msaa$s-fp-1024" 30 --lights 1024 --grid-objects 280 --density medium --msaa $s
      run "msaa$s-td-1024" 30 --lights 1024 --grid-objects 280 --density medium --method deferred --gbuffer-rts 4 --msaa $s
    done
    ;;
  scale)
    run fp-1024-grid280 100 --lights 1024 --grid-objects 280 --density medium
    run fp-65536 30 --lights 65536 --capacity 2048
    ;;
  shadows)
    # Issue 11: the courtyard at 1080p, 1024 point + 1024 spot lights, both methods; no
    # casters, then 12+12 (TiledLighting11) and 64+64 casters at 256 and 1024 px tiles with
    # 1/3/5 PCF, lights still (the atlas drawn once, in the warm-up) and moving (every
    # caster redrawn every frame).
    common="--lights 1024 --spot-lights 1024"
    for m in forward-plus deferred; do
      run "sh-$m-none" 30 $common --method $m
      for c in 12 64; do
        for size in 256 1024; do
          for f in 1 3 5; do
            sh="--shadow-point-lights $c --shadow-spot-lights $c --shadow-size $size --shadow-filter $f"
            run "sh-$m-$c-$size-f$f" 30 $common --method $m $sh
            run "sh-$m-$c-$size-f$f-move" 30 $common --method $m $sh --move-lights
          done
        done
      done
    done
    ;;
  blended)
    # Issue 12: the Figure 9 scene (280 medium grid objects), 1,024 lights, both methods; 0,
    # 10, 50 and 280 of the grid objects blended glass, sorted and weighted blended OIT.
    for m in forward-plus deferred; do
      run "bl-$m-0" 30 --lights 1024 --grid-objects 280 --density medium --method $m
      for t in 10 50 280; do
        for mode in sorted wboit; do
          run "bl-$m-$t-$mode" 30 --lights 1024 --grid-objects 280 --density medium --method $m \
            --transparent-objects $t --blend-mode $mode
        done
      done
    done
    ;;
  reshape)
    # Issue 27's before/after (A/B with BIN= and PREFIX=): the Figure 9 scene (280 medium grid
    # objects; 4 G-buffer targets) at 1,024, 4,096 and 16,384 lights, both methods, and the
    # million-light preset, both methods, gathered and assigned light-centrically.
    for n in 1024 4096 16384; do
      run "f9-fp-$n" 50 --lights $n --grid-objects 280 --density medium
      run "f9-td-$n" 50 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4
    done
    for m in forward-plus deferred; do
      run "mp-$m-gather" 10 --light-preset million --method $m
      run "mp-$m-tiled" 10 --light-preset million --method $m --assign scatter
    done
    ;;
  visibility)
    # Issue 28: the three methods side by side. The Figure 9 scene (280 medium grid objects;
    # Tiled Deferred with 4 G-buffer targets) at 1,024 / 4,096 / 16,384 lights, the courtyard
    # at 1,024, the million preset (gathered and assigned), and 4x MSAA on the Figure 9 scene.
    for n in 1024 4096 16384; do
      run "v-f9-fp-$n" 50 --lights $n --grid-objects 280 --density medium
      run "v-f9-td-$n" 50 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4
      run "v-f9-vb-$n" 50 --lights $n --grid-objects 280 --density medium --method visibility
    done
    for m in forward-plus deferred visibility; do
      run "v-court-$m" 50 --lights 1024 --method $m
      run "v-mp-$m-gather" 10 --light-preset million --method $m
      run "v-mp-$m-scatter" 10 --light-preset million --method $m --assign scatter
    done
    for n in 1024 4096; do
      run "v-msaa4-fp-$n" 30 --lights $n --grid-objects 280 --density medium --msaa 4
      run "v-msaa4-td-$n" 30 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4 --msaa 4
      run "v-msaa4-vb-$n" 30 --lights $n --grid-objects 280 --density medium --method visibility --msaa 4
    done
    ;;
  raster)
    # Issue 29: the visibility buffer's hardware and compute rasters. The Figure 9 scene
    # (280 medium grid objects) at 1,024 / 4,096 / 16,384 lights with all three methods; the
    # compute raster's large-triangle split at 4,096; the courtyard; 17 / 70 / 280 grid
    # objects (1 : 4 : 16) to see raster time against triangles; the million preset.
    for n in 1024 4096 16384; do
      run "r-f9-fp-$n" 50 --lights $n --grid-objects 280 --density medium
      run "r-f9-td-$n" 50 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4
      run "r-f9-hw-$n" 50 --lights $n --grid-objects 280 --density medium --method visibility --raster hardware
      run "r-f9-cs-$n" 50 --lights $n --grid-objects 280 --density medium --method visibility --raster compute
    done
    for large in compute hardware; do
      for px in 8 16 32 64 100000; do
        run "r-f9-cs-4096-$large-l$px" 50 --lights 4096 --grid-objects 280 --density medium --method visibility \
          --raster compute --raster-large $large --raster-large-px $px
      done
    done
    for r in hardware compute; do
      run "r-court-$r" 50 --lights 1024 --method visibility --raster $r
      for g in 17 70 280; do
        run "r-g$g-$r" 50 --lights 1024 --grid-objects $g --density medium --method visibility --raster $r
      done
      run "r-mp-$r-gather" 10 --light-preset million --method visibility --raster $r
      run "r-mp-$r-scatter" 10 --light-preset million --method visibility --raster $r --assign scatter
    done
    run "r-court-fp" 50 --lights 1024
    run "r-court-td" 50 --lights 1024 --method deferred
    run "r-mp-td-scatter" 10 --light-preset million --method deferred --assign scatter
    ;;
  traced)
    # Issue 30: the traced reference, courtyard and Figure 9 scene, 1,024 and 16,384 lights.
    run_traced tr-court-1024 --lights 1024 --method traced-reference
    run_traced tr-f9-1024 --lights 1024 --grid-objects 280 --density medium --method traced-reference
    run_traced tr-court-16384 --lights 16384 --method traced-reference
    run_traced tr-f9-16384 --lights 16384 --grid-objects 280 --density medium --method traced-reference
    ;;
  raster-short)
    # Issue 29, the compute raster only: the Figure 9 scene at three light counts, its
    # large-triangle split, the courtyard and grid scaling, the million preset assigned.
    for n in 1024 4096 16384; do
      run "rs-f9-cs-$n" 50 --lights $n --grid-objects 280 --density medium --method visibility --raster compute
    done
    for px in 16 64; do
      run "rs-f9-cs-4096-l$px" 50 --lights 4096 --grid-objects 280 --density medium --method visibility \
        --raster compute --raster-large-px $px
    done
    run "rs-court-cs" 50 --lights 1024 --method visibility --raster compute
    for g in 17 70; do
      run "rs-g$g-cs" 50 --lights 1024 --grid-objects $g --density medium --method visibility --raster compute
    done
    run "rs-mp-cs-scatter" 10 --light-preset million --method visibility --raster compute --assign scatter
    ;;
  stochastic)
    # Issue 48: the stochastic method's frame time (Figure 9 scene at 4,096 lights, the
    # courtyard at 1,024, the million preset) at the default threshold and at the budget's
    # 0.0015 (longer lists: more near lights, fewer far), then its error against the traced
    # truth after 8 frames of a still camera and of one frame alone (accumulate 0), beside
    # the visibility buffer's, on the Figure 9 scene at 4,096 lights.
    for t in 0.1 0.0015; do
      run "sto-f9-4096-t$t" 50 --lights 4096 --grid-objects 280 --density medium --method stochastic --threshold $t
      run "sto-court-1024-t$t" 50 --lights 1024 --method stochastic --threshold $t
    done
    run "sto-mp" 10 --light-preset million --method stochastic --assign scatter
    for t in 0.1 0.0015; do
      echo "== sto-acc-f9-t$t" | tee -a "$out/log.txt"
      # The compared image is the 8th measured frame (the history restarts after the
      # warm-up): 7 frames before it in the history, unless the grid grew.
      timeout 280 "$bin" accuracy --width 1920 --height 1080 --lights 4096 --grid-objects 280 --density medium \
        --reference traced --frames 8 --warmup 1 --reference-frames 1 --axis threshold=$t --axis culling=planes \
        --axis method=stochastic,visibility --axis accumulate=64,0 \
        --out "/tmp/sto-acc-$t/acc.csv" >"$out/sto-acc-f9-t$t.txt" 2>&1
      echo "exit $?" >>"$out/sto-acc-f9-t$t.txt"
      cp "/tmp/sto-acc-$t/acc.csv" "$out/sto-acc-f9-t$t.csv" 2>/dev/null
    done
    ;;
  denoise)
    # Issue 48's denoiser: the stochastic method's frame time without it and with 4
    # iterations (Figure 9 scene at 4,096 lights, the courtyard at 1,024), then its error
    # against the traced truth per iteration count after 8 frames of a still camera and of
    # one frame alone (accumulate 0), on both scenes.
    for d in 0 4; do
      run "den-f9-4096-d$d" 50 --lights 4096 --grid-objects 280 --density medium --method stochastic --denoise $d
      run "den-court-1024-d$d" 50 --lights 1024 --method stochastic --denoise $d
    done
    run_stochastic_accuracy den-acc --axis denoise=0,2,4 --axis accumulate=64,0
    ;;
  near)
    # Issue 48's near field: the near candidates stratified over the pixel's list, 4 (the
    # default), 16, 64 and every light of the list (4096 is more than any list here), frame
    # time on the Figure 9 scene (4,096 lights) and the courtyard (1,024), then the error
    # after 8 frames, denoised and raw, on both scenes (run_stochastic_accuracy: $out/near-acc-*).
    # Then 2 and 4 shadow rays a pixel (--rays) with every near light.
    for c in 4 16 64 4096; do
      run "near-f9-4096-c$c" 50 --lights 4096 --grid-objects 280 --density medium --method stochastic --candidates $c
      run "near-court-1024-c$c" 50 --lights 1024 --method stochastic --candidates $c
    done
    for k in 2 4; do
      run "near-f9-4096-all-k$k" 50 --lights 4096 --grid-objects 280 --density medium --method stochastic --candidates 4096 --rays $k
      run "near-court-1024-all-k$k" 50 --lights 1024 --method stochastic --candidates 4096 --rays $k
    done
    run_stochastic_accuracy near-acc --axis candidates=4,16,4096 --axis rays=1,2,4 --axis denoise=4,0
    ;;
  light-tree)
    # Issue 48 item 1: the far candidates from the light tree against uniform draws: frame
    # time on the Figure 9 scene (4,096 lights) and the million preset (must hold: 8 ms),
    # then the error after 8 frames on the Figure 9 scene at the default threshold and the
    # budget's 0.0015. Printouts and CSVs: $out/lt-*.
    for t in off on; do
      flag=()
      [ "$t" = on ] && flag=(--light-tree)
      run "lt-f9-4096-$t" 30 --lights 4096 --grid-objects 280 --density medium --method stochastic "${flag[@]}"
      run "lt-mp-$t" 10 --light-preset million --method stochastic --assign scatter "${flag[@]}"
    done
    echo "== lt-acc-f9" | tee -a "$out/log.txt"
    timeout 200 "$bin" accuracy --width 1920 --height 1080 --lights 4096 --grid-objects 280 --density medium \
      --reference traced --frames 8 --warmup 1 --reference-frames 1 --axis method=stochastic --axis culling=planes \
      --axis threshold=0.1,0.0015 --axis light-tree=off,on --axis denoise=4,0 --out /tmp/lt-acc/acc.csv >"$out/lt-acc-f9.txt" 2>&1
    echo "exit $?" >>"$out/lt-acc-f9.txt"
    cp /tmp/lt-acc/acc.csv "$out/lt-acc-f9.csv" 2>/dev/null
    ;;
  million-truth)
    # Issue 48: the million preset's error with every light shadowed, against the traced
    # truth (10^12 shadow rays at 1080p: minutes), at the preset's threshold 0.1 (lights on
    # surfaces take their intensity from the threshold, so each threshold is another truth:
    # the lab's default axis of 13 would render 13). The stochastic method with uniform far
    # candidates and with the light tree, 4 and 16 far candidates (the tree's descent costs
    # 20 dependent reads a candidate here: at 640x360 3.8 ms against uniform draws' 1.1),
    # 8 frames of a still camera, the denoiser on and off, at MT_SIZE (WIDTHxHEIGHT,
    # default 960x540). The truth's time does not scale with the pixels at small sizes
    # (H100, 4e14d2c: 79 s at 192x108, 112 s at 640x360: a small image leaves the GPU idle),
    # so no probe: 960x540 is about 250 s there, 1080p about 1,000 s (more than a call may
    # take). The truth is kept in $out/refcache (--reference-cache), packed at the end into
    # 15 MiB parts ($MT_PARTS/refcache.tar.xz.part-*, default $out: the device tool returns
    # files of 16 MiB at most). Put the parts in
    # .device/ for the next call (they count towards the 64 MiB that travel): it unpacks
    # them and reads the truth instead of tracing it again.
    size=${MT_SIZE:-960x540}
    mkdir -p "$out/refcache"
    if ls .device/refcache.tar.xz.part-* >/dev/null 2>&1; then
      cat .device/refcache.tar.xz.part-* | xz -dc | tar -C "$out" -xf -
    fi
    echo "== mt-acc-$size" | tee -a "$out/log.txt"
    timeout "${MT_TIMEOUT:-560}" "$bin" accuracy --width "${size%x*}" --height "${size#*x}" --light-preset million \
      --assign scatter --reference traced --reference-cache "$out/refcache" --frames 8 --warmup 1 \
      --reference-frames 1 --axis threshold=0.1 --axis method=stochastic --axis culling=planes \
      --axis light-tree=off,on --axis far-candidates=4,16 --axis denoise=4,0 --out "/tmp/mt-acc/acc.csv" \
      >"$out/mt-acc-$size.txt" 2>&1
    echo "exit $?" >>"$out/mt-acc-$size.txt"
    cp /tmp/mt-acc/acc.csv "$out/mt-acc-$size.csv" 2>/dev/null
    if ls "$out"/refcache/*.bin >/dev/null 2>&1; then
      tar -C "$out" -cf - refcache | xz -T0 -6 | split -b 15m - "${MT_PARTS:-$out}/refcache.tar.xz.part-"
    fi
    rm -rf "$out/refcache"
    ;;
  temporal)
    # Issue 48's temporal reuse: the stochastic method after 8 frames of a still camera
    # (denoiser on and off) on both scenes, then with the camera orbiting 1 degree a frame
    # through the 8 measured frames, without and with temporal reuse (Figure 9 scene). Each
    # run's CSV and printout: $out/tr-SCENE-MOTION.*
    for run in f9:0 court:0 f9:1; do
      scene=${run%%:*} orbit=${run#*:}
      extra=(--lights 1024)
      [ "$scene" = f9 ] && extra=(--lights 4096 --grid-objects 280 --density medium)
      axes=(--axis temporal=20 --axis accumulate=64)
      [ "$orbit" != 0 ] && axes=(--axis temporal=0,20)
      echo "== tr-$scene-o$orbit" | tee -a "$out/log.txt"
      timeout 200 "$bin" accuracy --width 1920 --height 1080 "${extra[@]}" --reference traced --frames 8 --warmup 1 \
        --reference-frames 1 --axis method=stochastic --axis threshold=0.1 --axis culling=planes "${axes[@]}" \
        --axis denoise=4,0 --camera-orbit "$orbit" --out "/tmp/tr-$scene-$orbit/acc.csv" >"$out/tr-$scene-o$orbit.txt" 2>&1
      echo "exit $?" >>"$out/tr-$scene-o$orbit.txt"
      cp "/tmp/tr-$scene-$orbit/acc.csv" "$out/tr-$scene-o$orbit.csv" 2>/dev/null
    done
    ;;
  reuse)
    # Issue 48's spatial reuse: the stochastic method's frame time without it and with 4
    # neighbours (the denoiser on, its default), then its error against the traced truth
    # after 8 frames of a still camera and of one frame alone (accumulate 0), with the
    # denoiser off and on, on the Figure 9 scene (default threshold and the budget's 0.0015)
    # and the courtyard.
    for r in 0 4; do
      run "reuse-f9-4096-r$r" 50 --lights 4096 --grid-objects 280 --density medium --method stochastic --reuse $r
      run "reuse-court-1024-r$r" 50 --lights 1024 --method stochastic --reuse $r
    done
    run_stochastic_accuracy reuse-acc --axis reuse=0,4 --axis denoise=0,4 --axis accumulate=64,0
    ;;
  error-time)
    # Issue 48's error-against-time chart: every shading method beside the stochastic
    # method's dials on one Pareto chart per scene, against the traced truth after 8 frames
    # of a still camera (the lab leaves out the points that give a method a dial it does not
    # read). The tiled methods at the default threshold, 0.01 and the budget's 0.0015; the
    # stochastic method with and without the denoiser and its history, with 4 near
    # candidates and every list light, 1 and 4 rays. Each scene's CSV, chart and printout:
    # $out/et-SCENE.*
    for scene in f9 court; do
      extra=(--lights 1024)
      [ "$scene" = f9 ] && extra=(--lights 4096 --grid-objects 280 --density medium)
      echo "== et-$scene" | tee -a "$out/log.txt"
      timeout 280 "$bin" accuracy --width 1920 --height 1080 "${extra[@]}" --reference traced --frames 8 \
        --warmup 1 --reference-frames 1 --axis method=visibility,deferred,forward-plus,stochastic \
        --axis threshold=0.1,0.01,0.0015 --axis culling=planes --axis denoise=4,0 --axis accumulate=64,0 \
        --axis candidates=4,4096 --axis rays=1,4 --out "/tmp/et-$scene/et.csv" >"$out/et-$scene.txt" 2>&1
      echo "exit $?" >>"$out/et-$scene.txt"
      cp "/tmp/et-$scene/et.csv" "$out/et-$scene.csv" 2>/dev/null
      cp "/tmp/et-$scene/et.png" "$out/et-$scene.png" 2>/dev/null
    done
    ;;
  casters)
    # Issue 30: the error budget against the traced truth at its best cutoff (threshold
    # 0.0015), with casters chosen brightest-first and by contribution, spot casters, MSAA
    # and VPLs (1 warm-up frame: the runs recorded in docs/ACCURACY.md).
    run_budget budget 1 --axis shadow-point-lights=16,0,64,256 --axis shadow-spot-lights=0,16,64 \
      --axis casters-by=brightness,contribution --axis msaa=1,4 --axis vpl=off,on
    ;;
  casters-curve)
    # Issue 30: point casters by brightness and by contribution, 0 to 512, at the same
    # base (3 warm-up frames: the light grid has grown before frames are measured).
    run_budget curve 3 --axis shadow-point-lights=16,0,4,64,256,512 --axis casters-by=brightness,contribution
    ;;
  ranking)
    # Issue 30: what ranking the casters by contribution costs (the shadows line).
    for n in 1024 16384; do
      for extra in "" "--grid-objects 280 --density medium"; do
        echo "== ranking $n $extra" | tee -a "$out/log.txt"
        # shellcheck disable=SC2086
        timeout 120 "$bin" render --width 1920 --height 1080 --lights $n --shadow-point-lights 64 \
          --casters-by contribution $extra --out /tmp/ranking.png 2>&1 | tee -a "$out/log.txt" | grep -E "^(shadows|error)"
      done
    done
    ;;
  million)
    # Issue 13: a million lights on the courtyard (threshold 10: ~115 lights a tile), both
    # methods: tile-centric gather (two-level, the old way), then light-centric assignment
    # into every layout; 100,000 lights at threshold 1 (the same lights a tile).
    for m in forward-plus deferred; do
      run "m-$m-gather" 10 --lights 1000000 --threshold 10 --method $m
      for g in tiled half-z 2.5d clustered; do
        run "m-$m-$g" 10 --lights 1000000 --threshold 10 --method $m --assign scatter --grid $g
      done
      # Tiled Deferred's tile kernel has no 2.5D variant: it assigns 2.5D lists light-centrically.
      [ $m = forward-plus ] && run "m-$m-2.5d-gather" 10 --lights 1000000 --threshold 10 --method $m --grid 2.5d
      for ct in 16 32; do
        run "m-$m-clustered-t$ct" 10 --lights 1000000 --threshold 10 --method $m --grid clustered --cluster-tile $ct
        run "m-$m-clustered-t$ct-geo" 10 --lights 1000000 --threshold 10 --method $m --grid clustered \
          --cluster-tile $ct --cluster-geometry-only
      done
      # The preset: a million lights on the courtyard's surfaces (~100 a tile).
      run "mp-$m-gather" 10 --light-preset million --method $m
      for g in tiled 2.5d; do run "mp-$m-$g" 10 --light-preset million --method $m --assign scatter --grid $g; done
      run "mp-$m-clustered-t32" 10 --light-preset million --method $m --grid clustered --cluster-tile 32
      run "m100k-$m-gather" 20 --lights 100000 --threshold 1 --method $m
      run "m100k-$m-scatter" 20 --lights 100000 --threshold 1 --method $m --assign scatter
      run "m1k-$m-scatter" 50 --lights 1024 --method $m --assign scatter
    done
    ;;
  assign)
    # Light-centric assignment alone (issue 13's targets), Tiled Deferred: a million lights
    # uniform and preset, 100,000 and 1,024 lights. A/B runs: BIN= and PREFIX=.
    m=deferred
    for g in tiled 2.5d; do
      run "m-$m-$g" 10 --lights 1000000 --threshold 10 --method $m --assign scatter --grid $g
    done
    run "mp-$m-tiled" 10 --light-preset million --method $m --assign scatter
    run "m100k-$m-scatter" 20 --lights 100000 --threshold 1 --method $m --assign scatter
    run "m1k-$m-scatter" 50 --lights 1024 --method $m --assign scatter
    ;;
  vpl)
    # Issue 15: VPLs on the courtyard with 64 spot lights (12 and 64 casting shadows and
    # reflective shadow maps of 32x32 a face), both methods, lights moving (the RSM and
    # generation passes run only after casters move): without VPLs, then at most 3,072 /
    # 12,288 VPLs (12 casters, blocks 2 and 1) and 65,535 (64 casters, block 1: the cap);
    # blocks that see no lit surface make no VPL (bench's vpls_kept: about 1/5 of the
    # candidates here), so 64 casters with 64x64 RSMs (262,144 candidates) reach the cap.
    for m in forward-plus deferred; do
      run "vpl-$m-off" 20 --spot-lights 64 --shadow-spot-lights 12 --method $m --move-lights
      run "vpl-$m-12-b2" 20 --spot-lights 64 --shadow-spot-lights 12 --method $m --move-lights --vpl
      run "vpl-$m-12-b1" 20 --spot-lights 64 --shadow-spot-lights 12 --method $m --move-lights --vpl --vpl-block 1
      run "vpl-$m-64-off" 20 --spot-lights 64 --shadow-spot-lights 64 --method $m --move-lights
      run "vpl-$m-64-b1" 20 --spot-lights 64 --shadow-spot-lights 64 --method $m --move-lights --vpl --vpl-block 1
      run "vpl-$m-64-b1-rsm64" 20 --spot-lights 64 --shadow-spot-lights 64 --method $m --move-lights --vpl --vpl-block 1 \
        --vpl-rsm-size 64
    done
    ;;
  gbuffer)
    # Issue 31: the packed G-buffer (one Rgba16Uint target, emission in Rg11b10Ufloat).
    # Tiled Deferred on the Figure 9 scene at 4,096 lights with the stress knob at 2 to 5
    # (0 to 3 extra targets), with emission at 4; the courtyard at 1,024 lights with and
    # without emission, and at 4x MSAA. Compare with docs/PERFORMANCE.md's 294cf49 figures.
    for rts in 2 3 4 5; do
      run "gb-fig9-4096-rts$rts" 50 --lights 4096 --grid-objects 280 --density medium --method deferred --gbuffer-rts $rts
    done
    run gb-fig9-4096-rts4-em 50 --lights 4096 --grid-objects 280 --density medium --method deferred --gbuffer-rts 4 --emissive
    run gb-court-1024 50 --lights 1024 --method deferred
    run gb-court-1024-em 50 --lights 1024 --method deferred --emissive
    run gb-court-msaa4 30 --lights 1024 --method deferred --msaa 4
    run gb-court-msaa4-em 30 --lights 1024 --method deferred --msaa 4 --emissive
    # The compute tonemap (and the diffuse change) in Forward+ too.
    run gb-fp-1024 50 --lights 1024
    ;;
  summary)
    # docs/PERFORMANCE.md's summary (scripts/perf-summary.py): every method on the standard
    # scenes at the current commit. The Figure 9 scene (courtyard + 280 medium grid
    # objects) at 1,024 / 4,096 / 16,384 lights, the courtyard at 1,024, 4x MSAA at 4,096,
    # the million-light preset assigned light-centrically; default settings otherwise
    # (Tiled Deferred's G-buffer without stress targets). 100 frames a run (issue 49's
    # protocol). REP=N names the runs as repeat N (sum-...-rN; perf-summary.py keeps each
    # run's median repeat): issue 49's three interleaved repeats are three calls, REP=1,
    # 2 and 3, each within one device call's 10 minutes. SWEEP=1 adds the Figure 9 sweep
    # (its crossover chart), 20 frames a point.
    r=${REP:+-r$REP}
    for m in forward-plus deferred visibility; do
      for n in 1024 4096 16384; do run "sum-f9-$m-$n$r" 100 --lights $n --grid-objects 280 --density medium --method $m; done
      run "sum-court-$m-1024$r" 100 --lights 1024 --method $m
      run "sum-mp-$m$r" 100 --light-preset million --method $m --assign scatter
    done
    for m in forward-plus deferred visibility; do
      run "sum-msaa4-$m-4096$r" 100 --lights 4096 --grid-objects 280 --density medium --method $m --msaa 4
    done
    for m in forward-plus deferred visibility; do
      run "sum-mat144-$m-1024$r" 100 --scene materials --materials 144 --lights 1024 --method $m
    done
    if [ "${SWEEP:-0}" = 1 ]; then
      timeout 400 "$bin" sweep --preset figure9 --frames 20 --warmup 5 --width 1920 --height 1080 \
        --out "$out/figure9.csv" >>"$out/log.txt" 2>&1
    fi
    ;;
  materials)
    # Issue 46: what the number of textured materials costs each method. The materials
    # scene (576 boxes, the same coverage at every count), 1,024 lights, 1080p.
    for n in 2 16 64 144 512; do
      for m in forward-plus deferred visibility; do
        run "mat-$n-$m" 30 --scene materials --materials $n --lights 1024 --method $m
      done
    done
    ;;
  big-scene)
    # Issue 46 item 4: ten million triangles, every method at 1080p with 1,024 lights on its
    # surfaces. The file is the one crates/app/tests/big_scene.rs writes (a 32,768-triangle
    # plate instanced 320 times): run that test here, then copy
    # target/tmp/cli/big-scene/plates.{gltf,bin} to .device/ before staging.
    for m in forward-plus deferred brute-force; do run "big-$m" 10 --scene .device/plates.gltf --lights 1024 --method $m; done
    for r in hardware compute; do
      run "big-visibility-$r" 10 --scene .device/plates.gltf --lights 1024 --method visibility --raster $r
    done
    run_traced big-traced --scene .device/plates.gltf --lights 1024 --method traced-reference
    ;;
  raster-tiles)
    # Issue 49 item 4: the compute raster's large triangles split into 16 px tiles against
    # the binary before (OLD=path, staged beside), three interleaved repeats of 100 frames
    # (the million preset 30): the Figure 9 scene at 4,096 lights, the courtyard at 1,024,
    # the million preset assigned; then the large-triangle threshold (8 / 16 / 32 / 64 px)
    # with the tiles on the Figure 9 scene.
    new_bin=$bin
    for rep in 1 2 3; do
      for v in old new; do
        bin=$new_bin
        [ "$v" = old ] && bin=${OLD:?OLD names the binary before}
        run "rt-f9-$v-$rep" 100 --lights 4096 --grid-objects 280 --density medium --method visibility
        run "rt-court-$v-$rep" 100 --lights 1024 --method visibility
        run "rt-mp-$v-$rep" 30 --light-preset million --method visibility --assign scatter
      done
    done
    bin=$new_bin
    for px in 8 16 32 64; do
      run "rt-f9-l$px" 100 --lights 4096 --grid-objects 280 --density medium --method visibility --raster-large-px $px
    done
    ;;
  lists-49)
    # Issue 49 item 3: the 2.5D depth mask and 8 px tiles for the compute-shaded methods
    # (Tiled Deferred and the visibility buffer) against today's 16 px tiled lists, 100
    # frames (the million preset 30): the Figure 9 scene at 4,096 and 16,384 lights, the
    # courtyard at 1,024, the million preset assigned. One repeat a call (REP=N, default 1;
    # a call each for two interleaved repeats).
    for rep in ${REP:-1}; do
      for lists in tiled:16 2.5d:16 tiled:8 2.5d:8; do
        g=${lists%%:*} t=${lists#*:}
        for m in deferred visibility; do
          for n in 4096 16384; do
            run "l49-f9-$n-$m-$g-$t-$rep" 100 --lights $n --grid-objects 280 --density medium --method $m --grid $g --tile-size $t
          done
          run "l49-court-$m-$g-$t-$rep" 100 --lights 1024 --method $m --grid $g --tile-size $t
          run "l49-mp-$m-$g-$t-$rep" 30 --light-preset million --method $m --assign scatter --grid $g --tile-size $t
        done
      done
    done
    ;;
  stage-lights)
    # Issue 49 item 2 (and issue 45's setting added in three files): the visibility
    # buffer's shading with its tile list staged in workgroup memory (the default) and
    # without (--no-stage-lights), STAGE_REPEATS interleaved repeats (default 1; 3 for a
    # recorded A/B): the Figure 9 scene at 4,096 and 16,384 lights, 100 frames; the million
    # preset (assigned, tile lists), 30 frames; the courtyard at 1,024.
    for rep in $(seq 1 "${STAGE_REPEATS:-1}"); do
      for st in off on; do
        flag=()
        [ "$st" = off ] && flag=(--no-stage-lights)
        for n in 4096 16384; do
          run "st-f9-$n-$st-$rep" 100 --lights $n --grid-objects 280 --density medium --method visibility "${flag[@]}"
        done
        run "st-mp-$st-$rep" 30 --light-preset million --method visibility --assign scatter "${flag[@]}"
        run "st-court-$st-$rep" 100 --lights 1024 --method visibility "${flag[@]}"
      done
    done
    ;;
  surface-edges)
    # Issue 46 item 3: the visibility buffer's MSAA edge test by surface (default) and by
    # triangle ID alone, against Tiled Deferred, on the Figure 9 scene at 4,096 lights, 4x.
    run se-f9-vb-surface 50 --lights 4096 --grid-objects 280 --density medium --method visibility --msaa 4
    run se-f9-vb-ids 50 --lights 4096 --grid-objects 280 --density medium --method visibility --msaa 4 --no-surface-edges
    run se-f9-td 50 --lights 4096 --grid-objects 280 --density medium --method deferred --msaa 4
    ;;
  order)
    # Issue 31: the depth pre-pass and the G-buffer drawn nearest first against the
    # instance buffer's order (--draw-order). Tiled Deferred on the Figure 9 scene at 4,096
    # lights with the stress knob at 2 and 4, with emission; the courtyard with and without
    # emission and at 4x MSAA; Forward+ (its pre-pass) on both scenes.
    for o in submission front-to-back; do
      for rts in 2 4; do
        run "do-$o-fig9-4096-rts$rts" 50 --lights 4096 --grid-objects 280 --density medium --method deferred \
          --gbuffer-rts $rts --draw-order $o
      done
      run "do-$o-fig9-4096-rts4-em" 50 --lights 4096 --grid-objects 280 --density medium --method deferred \
        --gbuffer-rts 4 --emissive --draw-order $o
      run "do-$o-court-1024" 50 --lights 1024 --method deferred --draw-order $o
      run "do-$o-court-1024-em" 50 --lights 1024 --method deferred --emissive --draw-order $o
      run "do-$o-court-msaa4" 30 --lights 1024 --method deferred --msaa 4 --draw-order $o
      run "do-$o-fp-fig9-4096" 50 --lights 4096 --grid-objects 280 --density medium --draw-order $o
      run "do-$o-fp-court-1024" 50 --lights 1024 --draw-order $o
    done
    ;;
  emission)
    # Issue 14: the cost of emission. The courtyard with and without its banners glowing
    # (--emissive: the only change is three emissive materials), both methods: Tiled
    # Deferred's G-buffer gains its emission target (8 B a sample), both shading paths
    # the emission term. 1,024 and 16,384 lights; the Figure 9 scene with 4 G-buffer
    # targets; and 4x MSAA (the target is multisampled too).
    for m in forward-plus deferred; do
      for n in 1024 16384; do
        run "em-$m-$n-off" 50 --lights $n --method $m
        run "em-$m-$n-on" 50 --lights $n --method $m --emissive
      done
      run "em-$m-fig9-off" 50 --lights 1024 --grid-objects 280 --density medium --method $m --gbuffer-rts 4
      run "em-$m-fig9-on" 50 --lights 1024 --grid-objects 280 --density medium --method $m --gbuffer-rts 4 --emissive
      run "em-$m-msaa4-off" 30 --lights 1024 --method $m --msaa 4
      run "em-$m-msaa4-on" 30 --lights 1024 --method $m --msaa 4 --emissive
    done
    ;;
  grid)
    # The light grid's A/B set (issue 10): the Figure 9 scene, both methods, 1,024 to
    # 16,384 lights, then 65,536 lights (lists past the workgroup list).
    for n in 1024 4096 16384; do
      run "g-fp-$n" 50 --lights $n --grid-objects 280 --density medium
      run "g-td-$n" 50 --lights $n --grid-objects 280 --density medium --method deferred --gbuffer-rts 4
    done
    run g-fp-65536 20 --lights 65536
    run g-td-65536 20 --lights 65536 --method deferred
    ;;
  esac
done
