#!/usr/bin/env bash
# A/B image check for refactors that must not change a pixel (issue 27: "images equal the
# previous commit's"): renders one set of configurations with two binaries on the same
# adapter and compares the PNGs byte for byte (pixels, through ImageMagick's `compare -metric AE`
# when the files differ). Exposure is fixed so that the automatic exposure cannot hide a change.
#
#   scripts/ab-images.sh OLD_BINARY NEW_BINARY [OUT_DIR]
#
# Prints one line per configuration (identical / N pixels differ) and exits 1 when any differs.
# Runs on lavapipe by default (WGPU_ADAPTER_NAME=llvmpipe, WGPU_BACKEND=vulkan) at 320x180.
set -uo pipefail
old=${1:?old binary}
new=${2:?new binary}
out=${3:-target/ab-images}
mkdir -p "$out"
export WGPU_ADAPTER_NAME=${WGPU_ADAPTER_NAME:-llvmpipe} WGPU_BACKEND=${WGPU_BACKEND:-vulkan}
base=(render --width 320 --height 180 --exposure 1)
configs=(
  "fp|--lights 512"
  "td|--lights 512 --method deferred"
  "bf|--lights 512 --method brute-force"
  "bfnc|--lights 256 --method brute-force-no-cutoff"
  "fp-msaa4|--lights 512 --msaa 4"
  "td-msaa4|--lights 512 --method deferred --msaa 4"
  "fp-tests|--lights 512 --spot-lights 64 --half-z --aabb --spot-cone"
  "td-tests|--lights 512 --spot-lights 64 --half-z --aabb --spot-cone --method deferred"
  "fp-clustered|--lights 512 --grid clustered"
  "td-2.5d|--lights 512 --grid 2.5d --method deferred"
  "fp-scatter|--lights 512 --assign scatter"
  "td-scatter|--lights 512 --assign scatter --method deferred"
  "fp-shadows|--lights 128 --spot-lights 16 --shadow-point-lights 4 --shadow-spot-lights 4"
  "td-shadows|--lights 128 --spot-lights 16 --shadow-point-lights 4 --shadow-spot-lights 4 --method deferred"
  "fp-blended|--lights 512 --grid-objects 40 --transparent-objects 10"
  "td-oit|--lights 512 --grid-objects 40 --transparent-objects 10 --blend-mode wboit --method deferred"
  "fp-oit-msaa4|--lights 512 --grid-objects 40 --transparent-objects 10 --blend-mode wboit --msaa 4"
  "td-blended|--lights 512 --grid-objects 40 --transparent-objects 10 --method deferred"
  "fp-vpl|--lights 64 --shadow-point-lights 4 --vpl"
  "td-vpl|--lights 64 --shadow-point-lights 4 --vpl --method deferred"
  "td-emissive-rts4|--lights 512 --emissive --gbuffer-rts 4 --method deferred"
  "fp-heatmap|--lights 512 --heatmap"
  "vb|--lights 512 --method visibility --raster hardware"
  "vb-compute|--lights 512 --method visibility --raster compute"
  "vb-msaa4|--lights 512 --method visibility --msaa 4"
  "vb-shadows-blended|--lights 128 --spot-lights 16 --shadow-point-lights 4 --grid-objects 40 --transparent-objects 10 --method visibility"
  "vb-materials|--scene materials --materials 16 --lights 256 --method visibility"
  "td-materials|--scene materials --materials 16 --lights 256 --method deferred"
  "traced|--lights 64 --method traced-reference"
  "bf-blended|--lights 256 --grid-objects 40 --transparent-objects 10 --method brute-force"
  "bfnc-shadows|--lights 64 --spot-lights 8 --shadow-point-lights 2 --shadow-spot-lights 2 --method brute-force-no-cutoff"
  "traced-cutoff-blended|--lights 32 --grid-objects 40 --transparent-objects 10 --method traced-reference-cutoff"
)
differ=0
for c in "${configs[@]}"; do
  name=${c%%|*}
  read -r -a args <<<"${c#*|}"
  for side in old new; do
    bin=$old
    [[ $side == new ]] && bin=$new
    if ! "$bin" "${base[@]}" "${args[@]}" --out "$out/$name-$side.png" >"$out/$name-$side.log" 2>&1; then
      echo "$name: $side binary failed (see $out/$name-$side.log)"
      differ=1
      continue 2
    fi
  done
  if cmp -s "$out/$name-old.png" "$out/$name-new.png"; then
    echo "$name: identical"
  else
    px=$(compare -metric AE "$out/$name-old.png" "$out/$name-new.png" "$out/$name-diff.png" 2>&1 || true)
    echo "$name: files differ, $px pixels differ"
    [[ $px == 0 ]] || differ=1
  fi
done
exit $differ
