#!/usr/bin/env bash
# Renders the README's gallery: every demo setup (`--demo`, docs/USAGE.md "Demos") at
# 1920x1080 with the release binary, then (with `thumbs`) scales them for the README.
#
#   OUT=dir scripts/gallery.sh render     # on the device machine (carry .gl and .device,
#                                         # staged by ../shared/tools/device-prep.sh): the
#                                         # full-size PNGs and each command's report under $OUT
#   scripts/gallery.sh thumbs DIR         # here: DIR's PNGs -> docs/gallery/*.png at 640x360
#                                         # (ImageMagick), the commands -> docs/gallery/COMMANDS.md
#
# Each picture's command is in COMMANDS.md and under its picture in the README.
set -uo pipefail
cmd=${1:-}
case $cmd in
render)
  out=${OUT:-gallery-out}
  mkdir -p "$out"
  . "$(dirname "$0")/device-env.sh"
  bin=${BIN:-./.device/tiledlight}
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader >"$out/gpu.txt" 2>/dev/null
  shot() { # name args...
    local name=$1; shift
    echo "tiledlight render $* --width 1920 --height 1080" >>"$out/commands.txt"
    echo "$name|tiledlight render $*" >>"$out/index.txt"
    timeout 240 "$bin" render --width 1920 --height 1080 --out "$out/$name.png" "$@" >"$out/$name.txt" 2>&1
    echo "exit $?" >>"$out/$name.txt"
  }
  shot shadows --demo shadows
  shot vpl-off --demo vpl
  shot vpl-on --demo vpl --vpl
  shot glass --demo glass --method deferred
  shot million --demo million --method deferred --assign scatter
  for g in tiled half-z 2.5d clustered; do shot "heatmap-$g" --demo heatmap --grid "$g"; done
  shot clusters --demo clusters
  shot courtyard
  ;;
thumbs)
  src=${2:?usage: scripts/gallery.sh thumbs DIR}
  mkdir -p docs/gallery
  for f in "$src"/*.png; do
    convert "$f" -resize 640x360 -strip "docs/gallery/$(basename "$f")"
  done
  {
    echo "# Gallery commands"
    echo
    echo "Rendered by \`scripts/gallery.sh render\` at 1920x1080 on $(cat "$src/gpu.txt" 2>/dev/null || echo 'the device machine'),"
    echo "scaled to 640x360 by \`scripts/gallery.sh thumbs\`. Each picture and the command that made it:"
    echo
    while IFS='|' read -r name command; do
      echo "- \`$name.png\`: \`${command% }\`"
    done <"$src/index.txt"
  } >docs/gallery/COMMANDS.md
  ;;
*)
  echo "usage: scripts/gallery.sh render | thumbs DIR" >&2
  exit 2
  ;;
esac
