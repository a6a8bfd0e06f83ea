#!/usr/bin/env python3
"""docs/PERFORMANCE.md's summary table from one `scripts/device-bench.sh summary` run.

Usage: scripts/perf-summary.py DIR [--write docs/PERFORMANCE.md]

Reads DIR/sum-*.json (tiledlight bench's JSON; a name ending in -rN is repeat N of the same
run, and the repeat with the median total stands for it) and prints a Markdown table: per scene and
light count, each method's total GPU time and its largest passes, the ratio of Tiled
Deferred and the visibility buffer to Forward+, and whether any frame dropped lights; then
every pass against its floor, max(instruction issue, MUFU, HBM bandwidth), from the counts
in FLOOR_MODEL below (each with the shader it was counted from) and the GPU's numbers
picked from the adapter name (H200 or H100; another GPU gets no floor). A pass the model
does not know gets a "no floor" cell; a JSON without light pairs leaves its shading passes
without a floor and says so on stderr. Tests: scripts/test_perf_summary.py.
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
    reps = run.get("_repeats", [])
    spread = f" [{len(reps)} repeats {reps[0]:.3f}-{reps[-1]:.3f}]" if len(reps) > 1 else ""
    return f"**{run['total_gpu_median_ms']:.3f}**{spread} ({top}){drop}"


def median_runs(paths):
    """{key: run} from sum-<key>[-rN].json files: each key's repeat with the median total
    (the lower middle of an even count), its "_file" and "_repeats" (the totals, sorted)
    added."""
    groups = {}
    for path in paths:
        key = re.sub(r"-r[0-9]+$", "", os.path.basename(path)[4:-5])
        run = load(path)
        run["_file"] = path
        groups.setdefault(key, []).append(run)
    runs = {}
    for key, group in groups.items():
        group.sort(key=lambda r: r["total_gpu_median_ms"])
        run = group[(len(group) - 1) // 2]
        run["_repeats"] = [r["total_gpu_median_ms"] for r in group]
        runs[key] = run
    return runs


def table(folder):
    runs = median_runs(sorted(glob.glob(os.path.join(folder, "sum-*.json"))))
    if not runs:
        sys.exit(f"{folder}: no sum-*.json (run scripts/device-bench.sh summary)")
    any_run = next(iter(runs.values()))
    cfg = any_run["config"]
    commits = sorted({r["config"].get("commit", "?") for r in runs.values()})
    out = [
        f"{cfg['adapter']}, {cfg['resolution']}, commit {', '.join(commits)}; "
        f"`scripts/device-bench.sh summary`, raw JSON in `{folder}`. Total GPU ms a frame "
        "(the sum of the passes' medians; gaps between passes not counted; of several repeats the one with "
        "the median total, their range in brackets) and the two costliest passes; "
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


# ---------------------------------------------------------------------------------------
# The floor model (issue 49): per pass, an instruction-issue bound and a memory-bandwidth
# bound; the floor is the larger. Everything it assumes is the data below.
#
# The GPU. NVIDIA H200 and H100 SXM are both GH100: 132 SMs, 4 warp schedulers an SM,
# each issuing one warp instruction (32 thread-instructions) a clock, boost ~1.98 GHz:
# 132 x 4 x 32 x 1.98e9 = 33.45e12 thread-instructions/s. An FP32 FMA is one instruction
# like an FADD, an integer op or a load (no flop is priced at 2). The special-function
# unit (MUFU: rcp, rsq, sqrt, lg2, ex2) runs 16 lanes an SM a clock (4.2e12/s), checked
# as a third bound where a pass counts MUFU ops. HBM: 4.8 TB/s (H200), 3.35 TB/s (H100
# SXM). Only 2 of GH100's TPCs (4 SMs) run vertex and pixel shaders (NVIDIA's H100
# architecture white paper: "only two TPCs in both the SXM5 and PCIe H100 GPUs are
# graphics-capable"), so the passes drawn by the hardware raster (fragment and vertex
# shaders) issue at 4/132 of the compute rate: 1.01e12/s. The GPU is picked from the
# JSON's adapter name; another GPU gets no floor.
GPUS = [
    ("H200", {"name": "H200", "sms": 132, "clock_hz": 1.98e9, "bytes_per_s": 4.8e12, "graphics_sms": 4}),
    ("H100", {"name": "H100 SXM", "sms": 132, "clock_hz": 1.98e9, "bytes_per_s": 3.35e12, "graphics_sms": 4}),
]
LANES_PER_SM_CLOCK = 4 * 32  # 4 schedulers x one 32-thread warp instruction
MUFU_LANES_PER_SM_CLOCK = 16

# Per-pair counts of the shading loop, shared by every method (common/shade.wgsl
# shade_light_record + common/brdf.wgsl brdf_cos, point lights, no shadows, early-outs on),
# hand-counted as an ideal compile would issue them: a vec3 op is 3 instructions, a dot 3
# (FMUL + 2 FFMA), a division one MUFU.RCP + one FMUL (precise-division fix-ups not
# counted), pow(x, 5) three FMULs, terms that depend only on the pixel hoisted out of the
# loop (n.v, roughness^2, the Smith term of n.v, F0, the n.v diffuse falloff: counted per
# pixel below).
#   TEST, paid by every listed pair: loop counter, compare, branch 3; the list index
#   (running pointer + load) 2; the 32-byte record (address + 2 x 16-byte loads) 3;
#   to_light 3; d2 = dot 3; r^2 1; compare 1; early-out branch 1: 17.
#   LIT, paid only where the light is in range (and, from the n.l test on, in front):
#   l = to_light * rsq(max(d2)) 5 (1 MUFU); windowed attenuation (x = d2/r^2: RCP+FMUL,
#   saturate(1-x^2) 1, w^2 1, 1/d2 as min(rsq^2, 1e4) 2, x 1) 7 (1 MUFU); n.l + early-out 5;
#   h = (v+l) normalised: add 3, dot 3, RSQ 1, test 1, scale 3 = 11 (1 MUFU); v.h 3; GGX
#   times Smith (n.h 3, cross 6, dd 5, gv 1, gl FMUL FFMA SQRT FMUL 4, one division
#   0.5 a2 / (pi dd^2 (gv + gl)) 6 with 1 MUFU, select 2) 27 (2 MUFU); Schlick (1 - v.h,
#   ^5 by 3 FMUL, 3 FFMA) 7; diffuse (falloff(n.l) 7, x hoisted scale 1, vec3 3) 11;
#   (diffuse + F D V) n.l 7; radiance x atten x brdf 6; accumulate 3: 92, 5 of them MUFU
#   (issue 49: the code had 93 and 8, with a second division for D and the visibility
#   term, one for 1/d2, and pow(x, 5) as exp2 and log2).
PAIR_TEST = 17
PAIR_LIT = 92
PAIR_LIT_MUFU = 5
# The staged kernel (visibility, `stage-lights`) reads the index and record from workgroup
# memory (3 LDS for the 2 + 3 above): the same count within one instruction; not split.

# Per-pixel work of each shading pass (estimates by block, not instruction by instruction):
#   visibility.shade (common/visibility_surface.wgsl vis_surface): ID load and decode 4;
#   instance record 12; 3 indices, 9 positions, 9 normals, 6 UVs with addressing 40; 3
#   model and 3 clip transforms 84; two barycentric solves (position, derivatives) 80;
#   interpolation of world, normal (x normal matrix), UV and its derivatives 45; view
#   distance 4; material 25; hoisted BRDF terms 30; pixel loop and store 10: ~330.
#   deferred.shade (common/deferred_shade.wgsl load_gsample): depth load 2, unprojection
#   21, view distance 4, surface texel load and unpack 20, 3 sRGB LUT loads 6, ambient 3,
#   hoisted BRDF terms 30, loop and store 10: ~95; plus the tile's depth bounds reduction
#   (common/tile_cull.wgsl) ~10 a pixel: 105.
#   forward.shade (common/forward_shade.wgsl, a fragment): interpolants 10, material 15,
#   list lookup 5, hoisted BRDF terms 30, output 3: ~60.
VIS_PIXEL = 330
DEFERRED_PIXEL = 105
FORWARD_PIXEL = 60

# Rasters, per triangle and per covered pixel (the compute raster: common/compute_raster.wgsl
# and visibility_raster.wgsl cs_clusters, one thread a triangle, estimated by block):
#   per triangle: cluster test amortised 2; entry, cluster, instance, order, 3 indices, 9
#   positions with addressing 40; 3 transform_position (model 12 + clip 16 FFMA) 84; 3
#   raster_finite 27; raster_inside (6 planes x 3 vertices) 54; 3 raster_snap (RCP, 3 FMUL,
#   viewport 6, round 4, f32->i64 2) 48; the i64 area (64-bit multiplies ~4 instructions
#   each) 18; span test 34; raster_prepare (area, swap, 4 floor divisions, bounds, 3
#   top-left tests, 1/area) 90; raster_edges at the corner 60; steps and 32-bit span test
#   44: ~500.
#   per covered pixel: a triangle's bounding box is at least twice its area, and each box
#   pixel costs ~20 (3 edge signs and top-left 12, 3 IADD steps, loop 5); each covered one
#   adds ~16 (3 I2F, depth 6, pack 2, address 3, 64-bit atomicMax 1): 2 x 20 + 16 = 56.
# The JSON has no fragment count: covered pixels are taken as the screen's (depth
# complexity 1, overdraw left out, no sky), all priced in raster.compute's row (the large
# triangles' share of them is not in the JSON: raster.large is priced by its tiles below).
# Hardware raster (depth_prepass.wgsl, gbuffer.wgsl, visibility's MSAA raster): vertices
# taken as triangles / 2 (post-transform reuse on a closed mesh, a lower bound), vertex
# shader ~35 instructions (loads 6, transform 28, out 1; gbuffer's ~50 with normal and UV),
# fragment shader 0 (depth only), ~40 (gbuffer: material, octahedral normal, pack), ~5
# (visibility: the ID); all issued on the 4 graphics SMs. Bytes: 3 x 4-byte indices + half
# a 12-byte position a triangle (18 B; gbuffer + half a 20-byte normal/UV: 28 B).
RASTER_TRI = 500
RASTER_PIXEL = 56

# Target formats (crates/gpu/src): depth Depth32Float 4 B, HDR Rgba16Float 8 B, LDR
# Rgba8Unorm 4 B, visibility IDs R32Uint 4 B, the compute raster's texel a u64 8 B, the
# packed G-buffer surface 8 B (bench's gpu_memory: deferred.gbuffer = 8 B a pixel), light
# list indices 4 B. A depth test reads and writes depth (8 B a sample).

# One entry per pass name pattern ('*' stands for one method's name segment); the longest
# match wins. Each entry: source (what was counted), bound kind ("compute" or "graphics"
# SMs for the issue rate), instr / mufu / bytes: {quantity: count per unit}, lit: the
# per-pair instructions the floor leaves to early-outs (priced only in the full-path
# column), none: why no floor. Quantities: px (pixels), samples (pixels x MSAA), shaded
# (pixels + edge pixels x (MSAA - 1)), pair (bench's light pairs per tile, spread over the
# tile's pixels: pixels x pairs / tiles), tile_pair (the pairs themselves), all_pair
# (pixels x lights), tri (triangles), vert (triangles / 2), light, cell_light (64-pixel
# cells x lights).
def _shade(pixel, source, graphics=False, pairs="pair"):
    return {
        "source": source,
        "issue": "graphics" if graphics else "compute",
        "instr": {"shaded": pixel, pairs: PAIR_TEST},
        "lit": {pairs: PAIR_LIT},
        "lit_mufu": {pairs: PAIR_LIT_MUFU},
        "bytes": {},
    }


FLOOR_MODEL = {
    "visibility.shade": dict(
        _shade(VIS_PIXEL, "visibility.wgsl + common/{assigned_shade,visibility_surface,shade,brdf}.wgsl"),
        bytes={"samples": 4, "shaded": 8, "tile_pair": 4},
    ),
    "deferred.shade": dict(
        _shade(DEFERRED_PIXEL, "deferred.wgsl + common/{deferred_tile,deferred_shade,shade,brdf}.wgsl"),
        bytes={"samples": 12, "shaded": 8, "tile_pair": 4},
    ),
    "forward.shade": dict(
        _shade(FORWARD_PIXEL, "forward.wgsl + common/{forward_shade,shade,brdf}.wgsl (fragment)", graphics=True),
        bytes={"samples": 12, "tile_pair": 4},
    ),
    "brute_force.shade": dict(
        _shade(FORWARD_PIXEL, "brute_force.wgsl + common/{forward_shade,shade,brdf}.wgsl (fragment, every light)",
               graphics=True, pairs="all_pair"),
        bytes={"samples": 12},
    ),
    "visibility.raster.compute": {
        "source": "visibility_raster.wgsl cs_clusters + common/compute_raster.wgsl",
        "issue": "compute",
        "instr": {"tri": RASTER_TRI, "px": RASTER_PIXEL},
        "bytes": {"tri": 18, "px": 8},
    },
    # The large triangles by tiles (issue 49; visibility_raster.wgsl cs_large and
    # cs_large_tiles), priced per listed 16 px tile (bench's large_tiles): 32 lanes each set
    # the triangle up (~330 as a triangle above, less the span test and edge steps) and
    # cover 8 pixels (~38 a pixel: bounds 4, i64 edge steps 6, inside test 12, depth, pack
    # and atomicMax 16), 32 x 330 + 256 x 38 = 20,288; listing it ~100 (four corners'
    # i64 edges, the append); 256 texels' atomicMax 8 B each and the 8-byte item. The
    # per-triangle set-up of cs_large (256 lanes, once a large triangle) is not in the JSON.
    "visibility.raster.large": {
        "source": "visibility_raster.wgsl cs_large + cs_large_tiles: ~20,400 a listed tile, 2,056 B",
        "issue": "compute",
        "instr": {"large_tile": 20400},
        "bytes": {"large_tile": 2056},
    },
    "visibility.raster.finalize": {
        "source": "visibility_raster.wgsl cs_finalize: texel read 8, depth 4 + ID 4 written, texel reset 8",
        "issue": "compute",
        "instr": {"px": 12},
        "bytes": {"px": 24},
    },
    "visibility.raster": {
        "source": "visibility's hardware raster (depth_prepass.wgsl ID target): vertex ~35, fragment ~5",
        "issue": "graphics",
        "instr": {"vert": 35, "px": 5},
        "bytes": {"tri": 18, "samples": 12},
    },
    "depth_prepass": {
        "source": "depth_prepass.wgsl: vertex ~35, no fragment work",
        "issue": "graphics",
        "instr": {"vert": 35},
        "bytes": {"tri": 18, "samples": 8},
    },
    "deferred.gbuffer": {
        "source": "gbuffer.wgsl: vertex ~50, fragment ~40; depth 8 + surface 8 B a sample",
        "issue": "graphics",
        "instr": {"vert": 50, "px": 40},
        "bytes": {"tri": 28, "samples": 16},
    },
    # Coarse cells (cull_coarse.wgsl): every 64-px cell tests every light: load 2, view
    # transform 9, radius test 2, sphere_vs_frustum (4 planes x 5 + depth 4) 24, loop 3 = 40;
    # the cell's depth range ~3 a pixel; depth read 4 B a pixel.
    "deferred.cull_cells": {
        "source": "cull_coarse.wgsl: 40 a cell-light test, 3 a pixel",
        "issue": "compute",
        "instr": {"cell_light": 40, "px": 3},
        "bytes": {"px": 4},
    },
    # The tile cull (cull.wgsl + common/tile_cull.wgsl; coarse cells on by default): the
    # tile's depth bounds ~10 a pixel, then each candidate light of its cell tested (~40 as
    # above) and each survivor appended (~5): candidates are not in the JSON, so only the
    # survivors (the pairs) are priced; depth 4 B a pixel read, 4 B a pair written.
    "*.cull": {
        "source": "cull.wgsl + common/tile_cull.wgsl: 45 a kept pair (candidates not in the JSON), 10 a pixel",
        "issue": "compute",
        "instr": {"px": 10, "tile_pair": 45},
        "bytes": {"px": 4, "tile_pair": 4},
    },
    # The million preset's light-centric assignment (assign.wgsl): tile depth bounds; each
    # light projected to a tile rectangle (cull light 16 B read, rectangle 8 B written, ~40)
    # and counted into its tiles (~5 a pair); the lists allocated (a scan of the tiles);
    # the indices written (rectangle reread, ~8 and 4 B a pair). The big lights' split is
    # not in the JSON.
    "*.cull.depth": {"source": "assign.wgsl depth bounds: ~6 a pixel, 4 B read", "issue": "compute",
                     "instr": {"px": 6}, "bytes": {"px": 4}},
    "*.cull.count": {"source": "assign.wgsl count: ~40 a light + 5 a pair; 24 B a light", "issue": "compute",
                     "instr": {"light": 40, "tile_pair": 5}, "bytes": {"light": 24}},
    "*.cull.allocate": {"source": "assign.wgsl allocate: a scan of the tiles, ~10 and 8 B a tile", "issue": "compute",
                        "instr": {"tile": 10}, "bytes": {"tile": 8}},
    "*.cull.write": {"source": "assign.wgsl write: ~20 a light + 8 a pair; 8 B a light, 4 B a pair", "issue": "compute",
                     "instr": {"light": 20, "tile_pair": 8}, "bytes": {"light": 8, "tile_pair": 4}},
    "*.cull.count_big": {"none": "the big lights' count is not in the JSON"},
    "*.cull.write_big": {"none": "the big lights' count is not in the JSON"},
    # MSAA resolve: each edge pixel's samples read (8 B each), one HDR pixel written.
    "*.resolve": {"source": "deferred_resolve.wgsl: ~10 a sample; 8 B a sample read, 8 B written", "issue": "compute",
                  "instr": {"edge_samples": 10}, "bytes": {"edge_samples": 8, "edge": 8}},
    # The tail. tonemap.wgsl: bounds 4, load 1, exposure 3, ACES (2 FFMA, FMUL, FFMA, RCP +
    # FMUL a channel) 18 with 3 MUFU, linear_to_srgb (pow as LG2 FMUL EX2, FFMA, select a
    # channel) 18 with 6 MUFU, store 3: ~45 a pixel, 9 MUFU; HDR 8 B read, LDR 4 B written.
    "tonemap": {"source": "tonemap.wgsl: ~45 a pixel (9 MUFU); 8 B read, 4 B written", "issue": "compute",
                "instr": {"px": 45}, "mufu": {"px": 9}, "bytes": {"px": 12}},
    # exposure.wgsl reduce: load 2, luminance 3, log2 1 (MUFU), range test 3, 8 tree steps
    # of ~6 with barriers 48, store ~3: ~60 a pixel; HDR 8 B read. finish: a few us of
    # dispatch, not priced.
    "exposure": {"source": "exposure.wgsl reduce: ~60 a pixel (1 MUFU); 8 B read", "issue": "compute",
                 "instr": {"px": 60}, "mufu": {"px": 1}, "bytes": {"px": 8}},
}
# The million preset's deferred steps are named deferred.assign.* (the same kernels).
for _step in ("depth", "count", "allocate", "write", "count_big", "write_big"):
    FLOOR_MODEL["*.assign." + _step] = FLOOR_MODEL["*.cull." + _step]

COARSE_CELL = 64

LEFT_OUT = (
    "What the floor leaves out: the early-outs (it charges each listed pair only the range "
    f"test, {PAIR_TEST} instructions; 'full path' charges every pair the whole BRDF, "
    f"{PAIR_TEST + PAIR_LIT}, as a warp pays whenever one of its 32 pixels is lit, so the "
    "kernel's real cost lies between the two), divergence beyond that (the compute raster's "
    "one thread a triangle runs each warp for its largest triangle), overdraw and sky "
    "(covered pixels = the screen's), the tile cull's rejected candidates, the fixed-function "
    "raster and ROP rates of the hardware raster, latency and occupancy, dispatch gaps, "
    "L2 hits (light records and vertices are counted as cached, list indices and targets as "
    "HBM traffic)."
)


def gpu_of(adapter):
    """The GPU numbers for a bench adapter name, or None (no floors) if unknown."""
    for key, gpu in GPUS:
        if key in adapter:
            return gpu
    return None


def match(name):
    """The model entry for a pass name (longest pattern wins), or None."""
    best, best_len = None, -1
    parts = name.split(".")
    for pattern, entry in FLOOR_MODEL.items():
        pp = pattern.split(".")
        if len(pp) != len(parts):
            continue
        if all(p == "*" or p == q for p, q in zip(pp, parts)):
            score = sum(p != "*" for p in pp)
            if score > best_len:
                best, best_len = entry, score
    return best


class MissingCount(Exception):
    pass


def quantities(run):
    """The counts a floor multiplies, from a bench JSON; missing ones are absent."""
    cfg = run["config"]
    w, h = cfg["width"], cfg["height"]
    msaa = cfg.get("msaa", 1) or 1
    tile = cfg.get("tile_size", 16)
    tiles = -(-w // tile) * -(-h // tile)
    cells = -(-w // COARSE_CELL) * -(-h // COARSE_CELL)
    lights = cfg.get("point_lights", 0) + cfg.get("spot_lights", 0)
    edge = run.get("edge_pixels") or 0
    q = {
        "px": w * h,
        "samples": w * h * msaa,
        "shaded": w * h + edge * (msaa - 1),
        "edge": edge,
        "edge_samples": edge * msaa,
        "tile": tiles,
        "light": lights,
        "cell_light": cells * lights,
        "all_pair": w * h * lights,
    }
    if cfg.get("triangles") is not None:
        q["tri"] = cfg["triangles"]
        q["vert"] = cfg["triangles"] / 2
    if run.get("large_tiles") is not None:
        q["large_tile"] = run["large_tiles"]
    if run.get("light_pairs") is not None:
        q["tile_pair"] = run["light_pairs"]
        q["pair"] = q["shaded"] * run["light_pairs"] / tiles
    return q


def _sum(counts, q):
    missing = [k for k in counts if k not in q]
    if missing:
        raise MissingCount(", ".join(missing))
    return sum(v * q[k] for k, v in counts.items())


def pass_floor(entry, q, gpu):
    """(floor s, bound, full-path s) of one pass; raises MissingCount."""
    sms = gpu["graphics_sms"] if entry["issue"] == "graphics" else gpu["sms"]
    issue_rate = sms * LANES_PER_SM_CLOCK * gpu["clock_hz"]
    mufu_rate = sms * MUFU_LANES_PER_SM_CLOCK * gpu["clock_hz"]

    def bound(lit):
        instr = _sum(entry["instr"], q) + (_sum(entry.get("lit", {}), q) if lit else 0)
        mufu = _sum(entry.get("mufu", {}), q) + (_sum(entry.get("lit_mufu", {}), q) if lit else 0)
        times = [
            (instr / issue_rate, "issue" + (" (graphics SMs)" if entry["issue"] == "graphics" else "")),
            (mufu / mufu_rate, "MUFU"),
            (_sum(entry.get("bytes", {}), q) / gpu["bytes_per_s"], "bandwidth"),
        ]
        return max(times, key=lambda t: t[0])

    t, kind = bound(False)
    full = bound(True)[0] if entry.get("lit") else None
    return t, kind, full


def counts_text(entry):
    def fmt(d):
        return ", ".join(f"{v:g}/{k}" for k, v in d.items())
    parts = [f"instr {fmt(entry['instr'])}"]
    if entry.get("lit"):
        parts.append(f"+ lit {fmt(entry['lit'])}")
    if entry.get("mufu"):
        parts.append(f"MUFU {fmt(entry['mufu'])}")
    if entry.get("bytes"):
        parts.append(f"B {fmt(entry['bytes'])}")
    return "; ".join(parts)


def pass_row(run, p, gpu, warn=None):
    """The floor cells of one pass: (floor ms, x floor, bound, full path ms, counts)."""
    entry = match(p["pass"])
    if gpu is None:
        return ("no floor", "-", "-", "-", "unknown GPU: " + run["config"].get("adapter", "?"))
    if entry is None:
        return ("no floor", "-", "-", "-", "not in the model")
    if "none" in entry:
        return ("no floor", "-", "-", "-", entry["none"])
    try:
        t, kind, full = pass_floor(entry, quantities(run), gpu)
    except MissingCount as e:
        needs_pairs = "pair" in str(e)
        msg = "no light_pairs in the JSON" if needs_pairs else f"no count for {e} in the JSON"
        if needs_pairs and warn is not None:
            warn(f"{run.get('_file', '?')}: no light_pairs: {p['pass']}'s floor needs bench's light-pair count")
        return ("no floor", "-", "-", "-", msg)
    ms = p["median_ms"]
    full_cell = f"{full * 1e3:.3g} ({ms / (full * 1e3):.2f}x)" if full is not None else "-"
    return (f"{t * 1e3:.3g}", f"{ms / (t * 1e3):.1f}", kind, full_cell, counts_text(entry))


def floors(runs, warn=lambda m: print(m, file=sys.stderr)):
    """Every pass of every summary row against its floor (issue or bandwidth bound)."""
    gpus = {r["config"].get("adapter", "?") for r in runs.values()}
    gpu = gpu_of(next(iter(gpus)))
    head = (
        f"Each pass against its floor on the {gpu['name']} (picked from the adapter name): "
        f"max(instructions / issue rate, MUFU ops / MUFU rate, bytes / {gpu['bytes_per_s'] / 1e12:g} TB/s); "
        f"issue {gpu['sms']} SMs x {LANES_PER_SM_CLOCK} lanes x {gpu['clock_hz'] / 1e9:g} GHz = "
        f"{gpu['sms'] * LANES_PER_SM_CLOCK * gpu['clock_hz'] / 1e12:.2f}e12 instructions/s for compute, "
        f"{gpu['graphics_sms']} graphics SMs ({gpu['graphics_sms'] * LANES_PER_SM_CLOCK * gpu['clock_hz'] / 1e12:.2f}e12/s) "
        "for vertex and fragment shaders; an FMA is one instruction. Counts a unit: px pixel, samples "
        "pixel x MSAA, shaded pixels + edge pixels x (MSAA - 1), pair a pixel's listed light (pixels x "
        "bench's light pairs / tiles), tile_pair a light pair, tri triangle, vert triangles / 2, "
        "cell_light 64-px cell x light; the sources and hand counts are in `scripts/perf-summary.py`'s "
        "FLOOR_MODEL."
        if gpu else "No floors: the adapter is not a GPU the model knows (" + ", ".join(sorted(gpus)) + ")."
    )
    out = [
        head,
        "",
        "| scene | method | pass | ms | floor ms | x floor | bound | full path ms | counts |",
        "| --- | --- | --- | ---: | ---: | ---: | --- | ---: | --- |",
    ]
    for key, label in ROWS:
        for m, name in METHODS:
            run = runs.get(key.format(m=m))
            if not run:
                continue
            g = gpu_of(run["config"].get("adapter", ""))
            for p in run["passes"]:
                cells = pass_row(run, p, g, warn)
                out.append(f"| {label} | {name} | {p['pass']} | {p['median_ms']:.3f} | " + " | ".join(cells) + " |")
    used = []
    for run in runs.values():
        for p in run["passes"]:
            e = match(p["pass"])
            if e is not None and "source" in e and e not in used:
                used.append(e)
    out += ["", LEFT_OUT, "", "Where the counts come from: " + "; ".join(
        f"{'/'.join(sorted({pat for pat, x in FLOOR_MODEL.items() if x is e}))}: {e['source']}" for e in used) + "."]
    return "\n".join(out)


def write_block(path, text):
    """Replaces what lies between the file's summary markers with `text`."""
    doc = open(path).read()
    pattern = re.compile(r"(<!-- summary:begin -->\n).*?(<!-- summary:end -->)", re.S)
    if not pattern.search(doc):
        sys.exit(f"{path}: no <!-- summary:begin --> ... <!-- summary:end --> markers")
    open(path, "w").write(pattern.sub(lambda m: m.group(1) + text + m.group(2), doc))


def main():
    args = sys.argv[1:]
    if not args:
        sys.exit(__doc__)
    text = table(args[0].rstrip("/"))
    if len(args) == 3 and args[1] == "--write":
        write_block(args[2], text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
