#!/usr/bin/env bash
# The peer benchmark (issues 16 and 32): tiledlight and Bevy (peers/bevy, bevy-peer) on the
# device machine, one GPU, Vulkan, the same exported glTF for both. Run from the repo root:
#   .device/tiledlight      the stripped tiledlight binary (as for scripts/device-bench.sh)
#   .device/bevy-peer.gz    the stripped peer binary, gzipped (peers/bevy/README.md builds it:
#                           it travels beside tiledlight within the 64 MiB carry limit); a
#                           plain .device/bevy-peer is used as it is
#   .gl/*.deb               the Vulkan loader packages (scripts/device-env.sh)
#
# Scenes (SCENES): court-N is the courtyard with N uniform random point lights (threshold
# 0.1 * sqrt(N / 1000): about the same lights per tile at every count), the dense case;
# many-lights is Bevy's own stress test (`--scene bevy-many-lights`: 100,000 lights of
# 0.3 m on a 50 m sphere), the sparse one. Each scene gets one fixed exposure for every
# renderer (tiledlight's automatic exposure of it, read from a `render`) and is exported
# once (`tiledlight export`) for Bevy.
#
# PHASE=sweep (one call) tunes Bevy's cluster grid per scene, forward renderer matched to
# tiledlight's frame (no MSAA, ACES fitted, depth prepass), dynamic resizing on with
# view_cluster_bindings_max_indices raised to MAX_INDICES:
#   1. clusters of SWEEP_PX (16 and 28) px, SWEEP_Z (16/24/32/48) Z slices (Bevy's default
#      Z config: first slice to 5 m, far end at the farthest light's range);
#   2. on the fastest of those, the first slice to FIRST_DEPTHS (2) m, and the far end
#      fixed at the scene's depth (FAR_court, FAR_many);
#   the fastest of all goes into $OUT/grids.txt ("scene px slices first_slice far ms");
#   plus Bevy as shipped (its defaults: 4x MSAA, TonyMcMapface, 4,096 clusters), once
#   (SHIPPED=0: not).
# PHASE=final (one call per scene group) runs every configuration of each scene, REPEATS
# (3) times, interleaved (each repeat starts one configuration later), with the grids the
# sweep found (GRIDS, a committed grids.txt):
#   bevy-fwd-default / bevy-fwd-tuned    Bevy forward, matched, its default / the tuned grid
#   bevy-def-tuned                       Bevy deferred (DeferredPrepass) on the tuned grid
#                                        (the clustering is the forward one's)
#   tl-fp, tl-fp-2.5d, tl-td             tiledlight Forward+ (tiled; 2.5D light-centric) and
#                                        Tiled Deferred (light-centric)
#   tl-fp-noeo, tl-td-noeo               the same without the shading's early-outs
#                                        (--no-early-outs: the per-light-cost ablation)
# Every run's JSON is NAME = SCENE.CONFIG.rK.json; the first repeat also keeps its frame
# (SCENE.CONFIG.png) for FLIP. Before and after every run the GPU's SM and memory clocks,
# temperature and power go into $OUT/clocks.csv. Each scene's results are archived into
# $OUT/peer-SCENE.tar.gz (the device returns at most 8 files of 16 MiB each), beside
# $OUT/summary.txt (one line per run), $OUT/log.txt and $OUT/gpu.txt.
# The report: for f in OUT/peer-*.tar.gz; do tar -xzf "$f" -C OUT; done; tiledlight peer-report OUT/peer
# BIN= / BEVY= pick other binaries; WIDTH, HEIGHT (1920x1080); FRAMES/WARMUP (30/15; the
# heavy Bevy runs, whose frames take over 0.5 s, HEAVY_FRAMES/HEAVY_WARMUP: 6/6).
# DRY_RUN=1 prints the commands without running them (for checking here).
set -uo pipefail
out=${OUT:-out/peer-run}
d=$out/peer
mkdir -p "$d"
work=${WORK:-$(mktemp -d)}
tl=${BIN:-./.device/tiledlight}
bevy=${BEVY:-./.device/bevy-peer}
W=${WIDTH:-1920}
H=${HEIGHT:-1080}
PHASE=${PHASE:-final}
SCENES=${SCENES:-"court-1000 court-10000 court-100000 many-lights"}
REPEATS=${REPEATS:-3}
GRIDS=${GRIDS:-docs/results/h200-peer-sweep/grids.txt}
MAX_INDICES=${MAX_INDICES:-16777216}
SWEEP_PX=${SWEEP_PX:-"16 28"}
SWEEP_Z=${SWEEP_Z:-"16 24 32 48"}
FIRST_DEPTHS=${FIRST_DEPTHS:-2}
FRAMES=${FRAMES:-30}
WARMUP=${WARMUP:-15}
HEAVY_FRAMES=${HEAVY_FRAMES:-6}
HEAVY_WARMUP=${HEAVY_WARMUP:-6}
# The far end of the last Z slice when fixed: the courtyard's far wall seen from its
# camera (36 m), the sphere's radius plus a light's range (50.3 m).
FAR_court=36
FAR_many=50.3
dry=${DRY_RUN:-0}
log=$out/log.txt
summary=$out/summary.txt
clocks=$out/clocks.csv
: >"$summary"
[ -f "$clocks" ] || echo "run,when,sm_mhz,mem_mhz,temp_c,power_w" >"$clocks"

if [ "$dry" != 1 ]; then
  . "$(dirname "$0")/device-env.sh"
  command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,memory.total --format=csv,noheader | tee "$out/gpu.txt"
  if [ ! -x "$bevy" ] && [ -f "$bevy.gz" ]; then
    gunzip -c "$bevy.gz" >"$work/bevy-peer" && chmod +x "$work/bevy-peer" && bevy=$work/bevy-peer
  fi
  for b in "$tl" "$bevy"; do [ -x "$b" ] || { echo "error: $b is missing or not executable" | tee -a "$log"; exit 1; }; done
fi

clock() { # run when: one clocks.csv line
  [ "$dry" = 1 ] && return 0
  local c
  c=$(nvidia-smi --query-gpu=clocks.sm,clocks.mem,temperature.gpu,power.draw --format=csv,noheader,nounits 2>/dev/null | head -1 | tr -d ' ')
  echo "$1,$2,${c:-,,,}" >>"$clocks"
}

x() { # label timeout command... : runs (or prints) one command, logging it
  local label=$1 limit=$2
  shift 2
  echo "== $label: $*" | tee -a "$log"
  [ "$dry" = 1 ] && return 0
  clock "$label" before
  timeout "$limit" "$@" >>"$log" 2>&1
  local rc=$?
  clock "$label" after
  [ $rc -ne 0 ] && echo "   FAILED ($label): exit $rc" | tee -a "$log" "$summary"
  return $rc
}

scene_flags() { # scene: tiledlight's scene flags
  case $1 in
    court-*)
      local n=${1#court-}
      echo "--lights $n --threshold $(awk -v n="$n" 'BEGIN { printf "%.4g", 0.1 * sqrt(n / 1000) }')"
      ;;
    many-lights) echo "--scene bevy-many-lights" ;;
    *) echo "error: unknown scene $1" >&2; exit 2 ;;
  esac
}

far_of() { case $1 in court-*) echo "$FAR_court" ;; *) echo "$FAR_many" ;; esac; }

# A scene whose Bevy frames at Bevy's default grid take over half a second.
heavy() { case $1 in court-100000 | many-lights) return 0 ;; *) return 1 ;; esac; }

exposure_of() { cat "$work/$1.exposure" 2>/dev/null || echo 1; }

prepare() { # scene: fixed exposure, glTF for Bevy
  local s=$1 flags e=1
  flags=$(scene_flags "$s")
  # shellcheck disable=SC2086
  if x "$s.exposure" 180 "$tl" render $flags --width "$W" --height "$H" --out "$work/$s-auto.png" && [ "$dry" != 1 ]; then
    local found
    found=$(grep -E '^exposure: ' "$log" | tail -1 | sed -E 's/^exposure: +([0-9.eE+-]+),.*/\1/')
    [ -n "$found" ] && e=$found
  fi
  echo "$e" >"$work/$s.exposure"
  echo "$s: $flags, exposure $e" | tee -a "$summary"
  # shellcheck disable=SC2086
  x "$s.export" 180 "$tl" export $flags --width "$W" --height "$H" --exposure "$e" --out "$work/$s.gltf"
}

resized() { # label: did Bevy resize its cluster lists inside the measured frames?
  awk -v run="== $1:" 'index($0, run) == 1 { on = 1; next } /^== / { on = 0 }
    on && /bevy-peer: measuring from/ { m = 1 } on && /bevy-peer: measured/ { m = 0 }
    on && m && /Resizing the view clustering/ { bad = 1 } END { exit !bad }' "$log"
}

bevy_run() { # name scene frames warmup flags...
  local name=$1 s=$2 f=$3 w=$4
  shift 4
  x "$name" 300 "$bevy" --gltf "$work/$s.gltf" --width "$W" --height "$H" --frames "$f" --warmup "$w" \
    --max-frames 4000 --out "$d" --name "$name" "$@"
  [ "$dry" = 1 ] && return 0
  resized "$name" && echo "  warning: $name: Bevy resized its cluster lists inside the measured frames (some missed lights)" | tee -a "$summary"
  [ -f "$d/$name.json" ] && echo "  $name: $(grep -E '"gpu_frame_ms_median"' "$d/$name.json" | tr -d ' \n')" | tee -a "$summary"
}

tl_run() { # name scene png flags...
  local name=$1 s=$2 png=$3 flags
  shift 3
  flags=$(scene_flags "$s")
  # shellcheck disable=SC2086
  x "$name" 300 "$tl" bench $flags --width "$W" --height "$H" --exposure "$(exposure_of "$s")" \
    --frames "$FRAMES" --warmup "$WARMUP" --json "$d/$name.json" "$@"
  [ -f "$d/$name.json" ] && echo "  $name: $(grep -E '"total_gpu_median_ms"' "$d/$name.json" | tr -d ' \n')" | tee -a "$summary"
  if [ -n "$png" ]; then
    # shellcheck disable=SC2086
    x "$name-png" 180 "$tl" render $flags --width "$W" --height "$H" --exposure "$(exposure_of "$s")" --out "$png" "$@"
  fi
}

MATCHED=(--msaa 1 --tonemapping aces --depth-prepass)
DEFERRED=(--msaa 1 --tonemapping aces --deferred)

median_of() { grep -E '"gpu_frame_ms_median"' "$1" 2>/dev/null | head -1 | sed -E 's/.*: *([0-9.eE+-]+).*/\1/'; }

sweep() { # scene
  local s=$1 f=$FRAMES w=$WARMUP best="" best_ms=""
  heavy "$s" && f=$HEAVY_FRAMES w=$HEAVY_WARMUP
  [ "${SHIPPED:-1}" = 1 ] && bevy_run "$s.bevy-shipped.r1" "$s" "$f" "$w"
  try() { # tag flags...: one grid; remembers the fastest complete one
    local tag=$1
    shift
    bevy_run "$s.sweep-$tag.r1" "$s" "$f" "$w" "${MATCHED[@]}" --max-indices "$MAX_INDICES" "$@"
    [ "$dry" = 1 ] && return 0
    # The sweep's frames are not compared (the final runs' are): the archive stays small.
    rm -f "$d/$s.sweep-$tag.r1.png"
    resized "$s.sweep-$tag.r1" && return 0
    local ms
    ms=$(median_of "$d/$s.sweep-$tag.r1.json")
    [ -z "$ms" ] && return 0
    if [ -z "$best_ms" ] || awk -v a="$ms" -v b="$best_ms" 'BEGIN { exit !(a < b) }'; then
      best_ms=$ms
      best="$*"
    fi
  }
  for px in $SWEEP_PX; do
    for z in $SWEEP_Z; do
      try "px$px-z$z" --cluster-px "$px" --z-slices "$z" --first-slice-depth 5 --far-z max
    done
  done
  [ "$dry" = 1 ] && best="--cluster-px 16 --z-slices 24 --first-slice-depth 5 --far-z max"
  local grid
  grid=$(echo "$best" | sed -E 's/--first-slice-depth [^ ]+ --far-z [^ ]+//')
  local gtag
  gtag=$(echo "$grid" | awk '{ print "px" $2 "-z" $4 }')
  local first
  for first in $FIRST_DEPTHS; do
    # shellcheck disable=SC2086
    try "$gtag-first$first" $grid --first-slice-depth "$first" --far-z max
  done
  # shellcheck disable=SC2086
  try "$gtag-far$(far_of "$s")" $grid --first-slice-depth 5 --far-z "$(far_of "$s")"
  # "scene px slices first_slice far ms"
  echo "$s $(echo "$best" | awk '{ print $2, $4, $6, $8 }') ${best_ms:-?}" | tee -a "$out/grids.txt" "$summary"
}

grid_flags() { # scene: the tuned grid's bevy-peer flags, from GRIDS
  local line
  line=$(grep -E "^$1 " "$GRIDS" 2>/dev/null | tail -1)
  if [ -z "$line" ]; then
    echo "error: no grid for $1 in $GRIDS (run PHASE=sweep first)" >&2
    return 1
  fi
  echo "$line" | awk -v m="$MAX_INDICES" '{ print "--cluster-px", $2, "--z-slices", $3, "--first-slice-depth", $4, "--far-z", $5, "--max-indices", m }'
}

CONFIGS=(bevy-fwd-default bevy-fwd-tuned bevy-def-tuned tl-fp tl-fp-2.5d tl-td tl-fp-noeo tl-td-noeo)
# ONLY="a b": run only these configurations (a call that must add some to an earlier one).
if [ -n "${ONLY:-}" ]; then read -r -a CONFIGS <<<"$ONLY"; fi

final_run() { # scene config repeat
  local s=$1 c=$2 k=$3 name=$1.$2.r$3 f=$FRAMES w=$WARMUP png="" grid
  [ "$k" = 1 ] && png="$d/$s.$c.png"
  case $c in
    bevy-*-default) heavy "$s" && f=$HEAVY_FRAMES w=$HEAVY_WARMUP ;;
  esac
  case $c in
    bevy-*-tuned) grid=$(grid_flags "$s") || return 1 ;;
  esac
  case $c in
    # shellcheck disable=SC2086
    bevy-fwd-default) bevy_run "$name" "$s" "$f" "$w" "${MATCHED[@]}" ;;
    # shellcheck disable=SC2086
    bevy-fwd-tuned) bevy_run "$name" "$s" "$f" "$w" "${MATCHED[@]}" $grid ;;
    # shellcheck disable=SC2086
    bevy-def-tuned) bevy_run "$name" "$s" "$f" "$w" "${DEFERRED[@]}" $grid ;;
    tl-fp) tl_run "$name" "$s" "$png" --method forward-plus ;;
    tl-fp-2.5d) tl_run "$name" "$s" "$png" --method forward-plus --assign scatter --grid 2.5d ;;
    tl-td) tl_run "$name" "$s" "$png" --method deferred --assign scatter ;;
    tl-fp-noeo) tl_run "$name" "$s" "" --method forward-plus --no-early-outs ;;
    tl-td-noeo) tl_run "$name" "$s" "" --method deferred --assign scatter --no-early-outs ;;
  esac
  # Bevy writes its frame every run: keep the first repeat's only.
  if [ "$dry" != 1 ] && [ -f "$d/$name.png" ]; then
    if [ "$k" = 1 ]; then mv "$d/$name.png" "$d/$s.$c.png"; else rm -f "$d/$name.png"; fi
  fi
}

archive() { # scene: its results into one archive as soon as it is done (a call cut short
  # keeps the scenes finished before)
  [ "$dry" = 1 ] && return 0
  local files
  files=$(cd "$out" && ls -d peer/"$1".* 2>/dev/null)
  # shellcheck disable=SC2086
  [ -n "$files" ] && tar -czf "$out/peer-$1.tar.gz" -C "$out" $files && (cd "$out" && rm -f $files)
}

case $PHASE in sweep | final) ;; *)
  echo "error: PHASE=$PHASE: sweep or final" >&2
  exit 2
  ;;
esac
[ "$PHASE" = sweep ] && : >"$out/grids.txt"
n=${#CONFIGS[@]}
for s in $SCENES; do
  prepare "$s"
  if [ "$PHASE" = sweep ]; then
    sweep "$s"
  else
    # Repeat k runs the configurations from the k-th on, wrapping round: every
    # configuration is measured early, in the middle and late of the scene's runs.
    for k in $(seq 1 "$REPEATS"); do
      for i in $(seq 0 $((n - 1))); do
        final_run "$s" "${CONFIGS[$(((i + k - 1) % n))]}" "$k"
      done
    done
  fi
  archive "$s"
done
[ "$dry" != 1 ] && rm -rf "$d" && ls -l "$out"
