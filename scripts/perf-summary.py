#!/usr/bin/env python3
"""docs/PERFORMANCE.md's summary table from one `scripts/device-bench.sh summary` run.

Usage: scripts/perf-summary.py DIR [--write docs/PERFORMANCE.md]

Reads DIR/sum-*.json (tiledlight bench's JSON) and prints a Markdown table: per scene and
light count, each method's total GPU time and its largest passes, the ratio of Tiled
Deferred and the visibility buffer to Forward+, and whether any frame dropped lights.
With --write the table replaces what lies between the file's
`<!-- summary:begin -->` and `<!-- summary:end -->` markers (an error if they are missing).
Standard library only.
"""
import glob
import json
import os
import re
import sys

METHODS = [("forward-plus", "Forward+"), ("deferred", "Tiled Deferred"), ("visibility", "visibility buffer")]
# (file key, row label) in table order; the key is the middle of sum-<key>-<method>[-N].json.
ROWS = [
    ("f9-{m}-1024", "Figure 9 scene, 1,024 lights"),
    ("f9-{m}-4096", "Figure 9 scene, 4,096 lights"),
    ("f9-{m}-16384", "Figure 9 scene, 16,384 lights"),
    ("court-{m}-1024", "courtyard, 1,024 lights"),
    ("msaa4-{m}-4096", "Figure 9 scene, 4,096 lights, 4x MSAA"),
    ("mp-{m}", "million preset (1,000,000 lights on the surfaces, light-centric)"),
]


def load(path):
    with open(path) as f:
        return json.load(f)


def cell(run):
    """Total GPU ms in bold, then the two costliest passes; a dropped frame is flagged."""
    if run is None:
        return "not run"
    passes = sorted(run["passes"], key=lambda p: -p["median_ms"])[:2]
    top = ", ".join(f"{p['pass']} {p['median_ms']:.2f}" for p in passes)
    drop = " (dropped lights!)" if run.get("dropped_frames") else ""
    return f"**{run['total_gpu_median_ms']:.3f}** ({top}){drop}"


def table(folder):
    runs = {}
    for path in glob.glob(os.path.join(folder, "sum-*.json")):
        runs[os.path.basename(path)[4:-5]] = load(path)
    if not runs:
        sys.exit(f"{folder}: no sum-*.json (run scripts/device-bench.sh summary)")
    any_run = next(iter(runs.values()))
    cfg = any_run["config"]
    commits = sorted({r["config"].get("commit", "?") for r in runs.values()})
    out = [
        f"{cfg['adapter']}, {cfg['resolution']}, commit {', '.join(commits)}; "
        f"`scripts/device-bench.sh summary`, raw JSON in `{folder}`. Total GPU ms a frame "
        "(the sum of the passes' medians; gaps between passes not counted) and the two costliest passes; "
        "ratio = the method's total over Forward+'s.",
        "",
        "| scene | " + " | ".join(name for _, name in METHODS) + " | Tiled Deferred / Forward+ | visibility / Forward+ |",
        "| --- | " + " | ".join("---" for _ in METHODS) + " | ---: | ---: |",
    ]
    for key, label in ROWS:
        row = [runs.get(key.format(m=m)) for m, _ in METHODS]
        fp = row[0]["total_gpu_median_ms"] if row[0] else None
        ratio = lambda r: f"{r['total_gpu_median_ms'] / fp:.3f}" if r and fp else "-"
        out.append(f"| {label} | " + " | ".join(cell(r) for r in row) + f" | {ratio(row[1])} | {ratio(row[2])} |")
    out += ["", floors(runs)]
    return "\n".join(out) + "\n"


# The arithmetic floor of a shading pass (docs/PERFORMANCE.md, DESIGN.md's anchors): every
# pixel evaluates every light of its tile's list at ~120 flop, at the Hopper chip's ~56
# TFLOP/s of fp32 FMA (measured on the H100; the H200 is the same chip).
FLOP_PER_LIGHT = 120.0
FLOPS = 56e12


def floors(runs):
    """How far each method's shading pass is from its arithmetic floor (Figure 9 rows)."""
    out = [
        "Shading passes against their arithmetic floor (pixels x the tile lists' mean length x "
        f"{FLOP_PER_LIGHT:.0f} flop at {FLOPS / 1e12:.0f} TFLOP/s; lists from bench's light pairs):",
        "",
        "| scene | method | shading pass | ms | floor ms | x floor |",
        "| --- | --- | --- | ---: | ---: | ---: |",
    ]
    for key, label in ROWS[:3]:
        for m, name in METHODS:
            run = runs.get(key.format(m=m))
            if not run or not run.get("light_pairs"):
                continue
            cfg = run["config"]
            w, h = cfg["width"], cfg["height"]
            tile = cfg.get("tile_size", 16)
            tiles = -(-w // tile) * -(-h // tile)
            per_pixel = run["light_pairs"] / tiles
            floor_ms = w * h * per_pixel * FLOP_PER_LIGHT / FLOPS * 1e3
            shade = [p for p in run["passes"] if "shade" in p["pass"]]
            if not shade:
                continue
            p = max(shade, key=lambda p: p["median_ms"])
            out.append(
                f"| {label} | {name} | {p['pass']} | {p['median_ms']:.3f} | {floor_ms:.3f} | {p['median_ms'] / floor_ms:.1f} |"
            )
    return "\n".join(out)


def main():
    args = sys.argv[1:]
    if not args:
        sys.exit(__doc__)
    text = table(args[0].rstrip("/"))
    if len(args) == 3 and args[1] == "--write":
        doc = open(args[2]).read()
        pattern = re.compile(r"(<!-- summary:begin -->\n).*?(<!-- summary:end -->)", re.S)
        if not pattern.search(doc):
            sys.exit(f"{args[2]}: no <!-- summary:begin --> ... <!-- summary:end --> markers")
        open(args[2], "w").write(pattern.sub(lambda m: m.group(1) + text + m.group(2), doc))
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
