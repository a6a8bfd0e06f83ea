// Light-centric assignment (crates/gpu/src/culling/scatter.rs): each light scatters itself into
// the lists of the tiles (or clusters) it covers, so the cost grows with lights + pairs,
// not lights x tiles. After the tile-depth pass (tile_depth.wgsl) has written each tile's
// depth range (and mask), one frame runs, in order:
//
// 1. count_lights: a thread per light finds the light's tile rectangle (light_rect: the
//    tiles whose four side planes the sphere passes, by binary search on the same planes
//    the tile-centric kernel tests; near_cap_rect for a sphere reaching the eye plane),
//    tests each tile of it exactly as the tile-centric kernel would (common/tile_tests.wgsl;
//    with CLUSTERED the light's depth slices instead of the tile's range) and counts the
//    hits per list. A light covering more than BIG_TILES tiles is queued instead (one
//    thread would hold up its warp). The rectangle is kept (light_rects) for the passes
//    after it.
// 2. count_big: the huge lights (more than HUGE_BLOCKS blocks; walk_huge), then a team of
//    TEAM threads per big light, a tile per thread at a time.
// The walks skip blocks of 4 x 4 tiles whose surfaces the sphere cannot reach in depth
// (visit_block, block_reached).
// 3. allocate: a thread per list; a workgroup scan of 256 lists' counts and one atomic add
//    on the grid's counter give each list its first index (the light grid's contract:
//    common/light_grid.wgsl; a full index buffer drops and counts, never writes out of
//    bounds); the count becomes the list's write cursor.
// 4. write_lights and 5. write_big: the same walk, each hit written at its list's cursor.
//
// The lists hold the tile-centric kernel's lights (order aside) but for false positives of
// lights reaching the eye plane outside near_cap_rect: the CPU twin is tiledlight_cull's
// cull_tiles_scatter (and cull_clusters), the rectangle's light_tile_rect.
// variants: HALF_Z SPOT_CONE DEPTH_MASK CLUSTERED GEOMETRY_ONLY
#include "common/tile_tests.wgsl"
#include "common/light_grid_rw.wgsl"

// Side of the grid's tiles in pixels.
override TILE_SIZE: u32 = 16u;
// A light whose rectangle holds more tiles than this goes to the big-light queue, and one
// with more blocks than HUGE_BLOCKS to the huge-light queue (crates/gpu/src/culling/scatter.rs
// sets both).
override BIG_TILES: u32 = 8u;
override HUGE_BLOCKS: u32 = 32u;
// Side of a block in tiles (tile_depth.wgsl keeps each block's depth range).
const BLOCK: u32 = 4u;

@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
@group(1) @binding(9) var<uniform> lighting: Lighting;
#ifdef SPOT_CONE
@group(1) @binding(6) var<storage, read> shading_lights: array<ShadingLight>;
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#endif
#ifdef DEPTH_MASK
// Per tile: the 2.5D bins holding a surface (tile_depth.wgsl).
@group(1) @binding(3) var<storage, read> tile_masks: array<u32>;
#else
#ifdef GEOMETRY_ONLY
// Per tile: the depth slices holding a surface (tile_depth.wgsl).
@group(1) @binding(3) var<storage, read> tile_masks: array<u32>;
#endif
#endif
#ifndef CLUSTERED
// Per block of BLOCK x BLOCK tiles: the nearest surface's view distance (x, bit-inverted)
// and the farthest's (y), order-preserving encoded (tile_depth.wgsl; 0, 0: no geometry).
@group(1) @binding(2) var<storage, read> block_ranges: array<vec2<u32>>;
#endif
// Per list: the lights found (count passes), then the write cursor (write passes).
@group(1) @binding(4) var<storage, read_write> list_counts: array<atomic<u32>>;
// The big- and huge-light queues: their lengths, then the big lights' indices from the
// start and the huge lights' from the end.
@group(1) @binding(5) var<storage, read_write> big_lights: array<atomic<u32>>;
// Per light: its tile rectangle (lo and hi, x in the low 16 bits), found by count_lights,
// read by the later passes.
@group(1) @binding(8) var<storage, read_write> light_rects: array<vec2<u32>>;
// The light grid (crates/gpu/src/light_grid.rs) and the tiles' depth ranges.
@group(2) @binding(0) var<storage, read_write> light_grid: LightGridRw;
@group(2) @binding(1) var<storage, read_write> light_indices: array<u32>;
@group(2) @binding(2) var<storage, read_write> tile_ranges: array<vec2<f32>>;

// Lists a tile has.
fn lists_per_tile() -> u32 {
#ifdef CLUSTERED
    return light_grid.header.lists_per_tile;
#else
#ifdef HALF_Z
    return 2u;
#else
    return 1u;
#endif
#endif
}

// The side plane test of sphere_vs_frustum (common/cull_tests.wgsl) for one plane.
fn side_passes(row: u32, edge: f32, sign: f32, c: vec3<f32>, r: f32) -> bool {
    let p = clip_edge_plane(row, edge, sign);
    return !(dot(p.xyz, c) + p.w < -r);
}

// NDC of pixel column x and row y, as tile_ndc computes a tile's edges.
fn ndc_x(x: u32) -> f32 {
    return 2.0 * f32(x) / f32(view.screen.x) - 1.0;
}

fn ndc_y(y: u32) -> f32 {
    return 1.0 - 2.0 * f32(y) / f32(view.screen.y);
}

// Tiles [lo, hi) (hi exclusive; empty when not lo < hi on both axes).
struct TileRect {
    lo: vec2<u32>,
    hi: vec2<u32>,
}

// The tiles whose four side planes the sphere (view-space centre `c`, radius `r`) passes
// (tiledlight_cull light_tile_rect). Each plane test is monotone over the columns (rows)
// for a sphere wholly in front of the eye plane, so four binary searches find them;
// a perspective sphere reaching the eye plane gets every tile.
fn light_rect(c: vec3<f32>, r: f32) -> TileRect {
    let n = light_grid.header.tiles;
    if view.orthographic == 0u && c.z + r >= 0.0 {
        return near_cap_rect(c, r);
    }
    // Columns passing the left plane are a prefix, the right plane's a suffix; rows (down
    // the screen) passing the top plane a prefix, the bottom plane's a suffix.
    let x_end = plane_search(0u, n.x, false, 1.0, true, c, r);
    let x_begin = plane_search(0u, n.x, true, -1.0, false, c, r);
    let y_begin = plane_search(1u, n.y, true, 1.0, false, c, r);
    let y_end = plane_search(1u, n.y, false, -1.0, true, c, r);
    return TileRect(vec2<u32>(x_begin, y_begin), vec2<u32>(x_end, y_end));
}

// The tiles the part of a perspective sphere reaching the eye plane in front of the near
// plane can cover (tiledlight_cull near_cap_rect): the projections of the eight corners of
// the box c +- r cut at z <= -near bound it.
fn near_cap_rect(c: vec3<f32>, r: f32) -> TileRect {
    let n = light_grid.header.tiles;
    let z_lo = c.z - r;
    let z_hi = min(c.z + r, -view.depth_near);
    if !(z_lo <= z_hi) {
        return TileRect(vec2<u32>(0u), vec2<u32>(0u));
    }
    var lo = vec2<f32>(3.0e38);
    var hi = vec2<f32>(-3.0e38);
    var finite = true;
    for (var corner = 0u; corner < 8u; corner++) {
        let p = vec3<f32>(
            select(c.x + r, c.x - r, (corner & 1u) == 0u),
            select(c.y + r, c.y - r, (corner & 2u) == 0u),
            select(z_hi, z_lo, (corner & 4u) == 0u),
        );
        let clip = view.view_to_clip * vec4<f32>(p, 1.0);
        let ndc = clip.xy / clip.w;
        // Not finite (NaN fails both tests; +-inf fails one).
        finite = finite && abs(ndc.x) <= 3.0e38 && abs(ndc.y) <= 3.0e38;
        lo = min(lo, ndc);
        hi = max(hi, ndc);
    }
    if !finite {
        return TileRect(vec2<u32>(0u), n);
    }
    // Columns whose right edge reaches lo.x and whose left edge stays below hi.x; rows (down
    // the screen) whose bottom edge is at most hi.y and whose top edge reaches lo.y.
    let x0 = ndc_search(0u, n.x, true, lo.x, false);
    let x1 = ndc_search(0u, n.x, false, hi.x, true);
    let y0 = ndc_search(1u, n.y, true, hi.y, true);
    let y1 = ndc_search(1u, n.y, false, lo.y, false);
    return TileRect(vec2<u32>(x0, y0), vec2<u32>(x1, y1));
}

// The first column (axis 0) or row (1) of `n` whose near (left, top) or far (right,
// bottom: `far_edge`) edge's NDC passes `v`: columns' edges rise (>=, or > when
// `strict`), rows' fall (<, or <= when `strict`), as near_cap_rect's predicates read.
fn ndc_search(axis: u32, n: u32, far_edge: bool, v: f32, strict: bool) -> u32 {
    var lo = 0u;
    var hi = n;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        let e = edge_ndc(axis, mid, far_edge);
        var found: bool;
        if axis == 0u {
            // x0: right edge >= lo.x; x1_end: left edge > hi.x.
            found = select(e >= v, e > v, strict);
        } else {
            // y0: bottom edge <= hi.y; y1_end: top edge < lo.y.
            found = select(e < v, e <= v, strict);
        }
        if found {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// NDC of the near (left, top) or far (right, bottom) edge of tile column (`axis` 0) or
// row (1) `i`, as tile_ndc computes it.
fn edge_ndc(axis: u32, i: u32, far_edge: bool) -> f32 {
    let px = min(i * TILE_SIZE + select(0u, TILE_SIZE, far_edge), view.screen[axis]);
    if axis == 0u {
        return ndc_x(px);
    }
    return ndc_y(px);
}

// Binary search over the `n` columns or rows on one side plane (clip row `axis`, the
// edge `far_edge`, `sign` as tile_volume builds it): with `prefix`, the passing ones come
// first and their count is returned; else they come last and the first is returned.
fn plane_search(axis: u32, n: u32, far_edge: bool, sign: f32, prefix: bool, c: vec3<f32>, r: f32) -> u32 {
    var lo = 0u;
    var hi = n;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if side_passes(axis, edge_ndc(axis, mid, far_edge), sign, c, r) == prefix {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// One light as the walks see it.
struct Walk {
    light: u32,
    c: vec3<f32>,
    r: f32,
    rect: TileRect,
    // Tiles of the rectangle (0 when it is empty or the light reaches nothing).
    tiles: u32,
    // Its blocks of BLOCK x BLOCK tiles: the first, how many across, and in all.
    block0: vec2<u32>,
    blocks_x: u32,
    blocks: u32,
    // CLUSTERED: the light's depth slices, first and last.
    slices: vec2<u32>,
    // The rectangle is the whole grid because the sphere reaches the eye plane (the plane
    // tests are not monotone there): each tile tests its side planes itself.
    planes: bool,
    // The light reaches some tile (it has a rectangle).
    reaches: bool,
}

// The side-plane part of sphere_vs_frustum for one tile.
fn side_planes_pass(tile: vec2<u32>, c: vec3<f32>, r: f32) -> bool {
    let v = tile_volume(tile_ndc(tile, TILE_SIZE), 0.0, 0.0);
    for (var i = 0u; i < 4u; i++) {
        if dot(v.planes[i].xyz, c) + v.planes[i].w < -r {
            return false;
        }
    }
    return true;
}

// Light `light` as the walks see it, its rectangle not yet set (`reaches`: false when the
// light reaches no tile, and then it has no rectangle).
fn walk_base(light: u32) -> Walk {
    var k: Walk;
    k.light = light;
    let cl = cull_lights[light];
    k.c = (view.world_to_view * vec4<f32>(cl.center, 1.0)).xyz;
    k.r = cl.radius;
    if !(k.r > 0.0) {
        return k;
    }
#ifdef CLUSTERED
    let dist = -k.c.z;
    // A light wholly behind the eye reaches no cluster.
    if !(dist + k.r > 0.0) {
        return k;
    }
    let hd = &light_grid.header;
    k.slices = vec2<u32>(
        cluster_slice(max(dist - k.r, 0.0), (*hd).slice_first, (*hd).slice_scale, (*hd).lists_per_tile),
        cluster_slice(dist + k.r, (*hd).slice_first, (*hd).slice_scale, (*hd).lists_per_tile),
    );
#endif
    k.planes = view.orthographic == 0u && k.c.z + k.r >= 0.0;
    k.reaches = true;
    return k;
}

// The walk `k` over the tiles of `rect`.
fn with_rect(k0: Walk, rect: TileRect) -> Walk {
    var k = k0;
    k.rect = rect;
    if k.rect.lo.x < k.rect.hi.x && k.rect.lo.y < k.rect.hi.y {
        let e = k.rect.hi - k.rect.lo;
        k.tiles = e.x * e.y;
        k.block0 = k.rect.lo / BLOCK;
        let b = (k.rect.hi - 1u) / BLOCK - k.block0 + 1u;
        k.blocks_x = b.x;
        k.blocks = b.x * b.y;
    }
    return k;
}

// The rectangle count_lights kept for `light`.
fn stored_rect(light: u32) -> TileRect {
    let p = light_rects[light];
    return TileRect(vec2<u32>(p.x & 0xffffu, p.x >> 16u), vec2<u32>(p.y & 0xffffu, p.y >> 16u));
}

fn store_rect(light: u32, r: TileRect) {
    light_rects[light] = vec2<u32>(r.lo.x | (r.lo.y << 16u), r.hi.x | (r.hi.y << 16u));
}

// Light `light` as the walks see it; `found`: its rectangle was found by count_lights.
fn walk_of(light: u32, found: bool) -> Walk {
    let k = walk_base(light);
    if !k.reaches {
        return k;
    }
    if found {
        return with_rect(k, stored_rect(light));
    }
    let rect = light_rect(k.c, k.r);
    store_rect(light, rect);
    return with_rect(k, rect);
}

// A hit of the walk's light in list `l`: counted, or written at the list's cursor.
fn emit(l: u32, light: u32, write: bool) {
    if write {
        let slot = atomicAdd(&list_counts[l], 1u);
        let e = light_list(light_grid.lists[l], light_grid.header.capacity);
        if slot < e.count {
            light_indices[e.first + slot] = light;
        }
    } else {
        // The result unused: a reduction the walk need not wait for (a returning atomic
        // is a round trip to L2 per hit, and a thread's hits are a chain of them).
        atomicAdd(&list_counts[l], 1u);
    }
}

// The tile-centric kernel's test without its side planes, which every tile of a
// rectangle found by the binary searches passes (the same plane arithmetic): the depth
// range (sphere_vs_frustum's expression) and the AABB and cone tests, which read only the
// volume's NDC rectangle and depth range. Near (x) and far (y, HALF_Z) list.
fn depth_hits(tile: vec2<u32>, range: vec2<f32>, k: Walk) -> vec2<bool> {
    var v: TileVolume;
    v.ndc = tile_ndc(tile, TILE_SIZE);
    let dist = -k.c.z;
    var hit = vec2<bool>(false);
#ifdef HALF_Z
    let mid = half_z_split(range.x, range.y);
    v.near = mid;
    v.far = range.y;
    hit.y = dist + k.r >= v.near && dist - k.r <= v.far && extra_tests(v, k.light, k.c, k.r);
    v.far = mid;
#else
    v.far = range.y;
#endif
    v.near = range.x;
    hit.x = dist + k.r >= v.near && dist - k.r <= v.far && extra_tests(v, k.light, k.c, k.r);
    return hit;
}

// Decodes a view distance encoded by tile_depth.wgsl's order_key.
fn from_order_key(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u ^ 0x80000000u, (u & 0x80000000u) != 0u));
}

// Block `j` (row-major within the rectangle's blocks) of the walk: its tiles inside the
// rectangle. For tiles (not clusters, whose empty slices still get lights), a block whose
// surfaces all lie nearer than the sphere or all farther is skipped whole: every tile's
// depth test would fail (the block's range is the min and max of its tiles' own values).
// Most lights of a dense scene are hidden behind walls, so this saves most tile visits.
fn visit_block(k: Walk, j: u32, write: bool) {
    let block = block_at(k, j);
    if !block_reached(k, block) {
        return;
    }
    let lo = max(block * BLOCK, k.rect.lo);
    let hi = min(block * BLOCK + BLOCK, k.rect.hi);
    for (var y = lo.y; y < hi.y; y++) {
        for (var x = lo.x; x < hi.x; x++) {
            visit(k, vec2<u32>(x, y), write);
        }
    }
}

// Block `j` (row-major within the rectangle's blocks) of the walk.
fn block_at(k: Walk, j: u32) -> vec2<u32> {
    return k.block0 + vec2<u32>(j % k.blocks_x, j / k.blocks_x);
}

// Whether the walk's sphere reaches the depth range of block `block`'s surfaces (always
// for clusters).
fn block_reached(k: Walk, block: vec2<u32>) -> bool {
#ifndef CLUSTERED
    let e = block_ranges[block.y * ((light_grid.header.tiles.x + BLOCK - 1u) / BLOCK) + block.x];
    let dist = -k.c.z;
    if e.y == 0u || !(dist + k.r >= from_order_key(~e.x) && dist - k.r <= from_order_key(e.y)) {
        return false;
    }
#endif
    return true;
}

// Tile `tile` of the walk.
fn visit(k: Walk, tile: vec2<u32>, write: bool) {
    let t = tile.y * light_grid.header.tiles.x + tile.x;
#ifdef CLUSTERED
    // The side planes passed (the rectangle, unless it is the whole grid); the depth test is
    // the slice range.
    if k.planes && !side_planes_pass(tile, k.c, k.r) {
        return;
    }
    let slices = light_grid.header.lists_per_tile;
#ifdef GEOMETRY_ONLY
    let occupied = tile_masks[t];
#endif
    for (var s = k.slices.x; s <= k.slices.y; s++) {
#ifdef GEOMETRY_ONLY
        if ((occupied >> s) & 1u) == 0u {
            continue;
        }
#endif
        emit(t * slices + s, k.light, write);
    }
#else
    visit_in(k, tile, tile_ranges[t], write, true);
#endif
}

#ifndef CLUSTERED
// Tile `tile` of the walk, its depth range `range` loaded. Without `planes_path` the walk
// must not be a whole-grid one (k.planes): the team walks never get those (walk_light
// queues them as huge), and leaving the tile-centric kernel's full test out of their code
// made them faster (H200, 100,000 lights: 0.049 -> 0.045 ms).
fn visit_in(k: Walk, tile: vec2<u32>, range: vec2<f32>, write: bool, planes_path: bool) {
    let t = tile.y * light_grid.header.tiles.x + tile.x;
    if range.y < 0.0 {
        // No geometry in the tile: no list (as the tile-centric kernel).
        return;
    }
    var hit = vec2<bool>(false);
    if planes_path && k.planes {
        // The whole grid: the tile-centric kernel's test, planes included.
        hit = volume_hits(tile_volumes_at(tile, TILE_SIZE, range.x, range.y), k.light, k.c, k.r);
    } else {
        hit = depth_hits(tile, range, k);
    }

#ifdef DEPTH_MASK
    if (tile_masks[t] & depth_mask_between(-k.c.z - k.r, -k.c.z + k.r, range.x, range.y)) == 0u {
        hit.x = false;
    }
#endif
    if hit.x {
        emit(t * lists_per_tile(), k.light, write);
    }
#ifdef HALF_Z
    if hit.y {
        emit(t * 2u + 1u, k.light, write);
    }
#endif
}
#endif

// Steps 1 and 4: a thread per light; big lights are queued by the count pass and left to
// the big-light passes by both.
fn walk_light(light: u32, write: bool) {
    if light >= lighting.num_lights {
        return;
    }
    let k = walk_of(light, write);
    // A whole-grid light (k.planes) of more than BIG_TILES tiles is walked as a huge one
    // (see visit_in).
    if k.blocks > HUGE_BLOCKS || (k.planes && k.tiles > BIG_TILES) {
        if !write {
            // The huge queue fills the buffer from its end, the big one from its start:
            // together they hold at most every light.
            let slot = atomicAdd(&big_lights[1], 1u);
            atomicStore(&big_lights[arrayLength(&big_lights) - 1u - slot], light);
        }
        return;
    }
    if k.tiles > BIG_TILES {
        if !write {
            let slot = atomicAdd(&big_lights[0], 1u);
            atomicStore(&big_lights[2u + slot], light);
        }
        return;
    }
    for (var j = 0u; j < k.blocks; j++) {
        visit_block(k, j, write);
    }
}

// The tiles of the walk's rectangle spread over `lanes` threads, one tile at a time (a
// light of a few blocks spread by blocks would keep most lanes idle while a few walk 16
// tiles each).
fn visit_tiles(k: Walk, lane: u32, lanes: u32, write: bool) {
    let w = k.rect.hi.x - k.rect.lo.x;
    // The lane's tile within the rectangle, stepped without a division per tile.
    var p = vec2<u32>(lane % w, lane / w);
    let step = vec2<u32>(lanes % w, lanes / w);
    for (var i = lane; i < k.tiles; i += lanes) {
        let tile = k.rect.lo + p;
#ifdef CLUSTERED
        visit(k, tile, write);
#else
        // No block test: the tile's own depth test implies it (a block's range is the min
        // and max of its tiles'), and a lane visits one tile of a block, so the test would
        // cost a dependent load and save none (H200, 100,000 lights: 0.055 -> 0.049 ms).
        visit_in(k, tile, tile_ranges[tile.y * light_grid.header.tiles.x + tile.x], write, false);
#endif
        p += step;
        if p.x >= w {
            p.x -= w;
            p.y += 1u;
        }
    }
}

// Steps 2 and 5: the huge lights (walk_huge), then a team of TEAM threads per big light
// (256 / TEAM teams a workgroup), its tiles spread over the lanes.
override TEAM: u32 = 32u;
// With more huge lights than workgroups, a light of more blocks than this gets a whole
// workgroup (walk_huge_many).
override WIDE_BLOCKS: u32 = 128u;

fn walk_big(group: u32, groups: u32, lidx: u32, write: bool) {
    walk_huge(group, groups, lidx, write);
    let queued = atomicLoad(&big_lights[0]);
    let teams = 256u / TEAM;
    for (var b = group * teams + lidx / TEAM; b < queued; b += groups * teams) {
        visit_tiles(walk_of(atomicLoad(&big_lights[2u + b]), true), lidx % TEAM, TEAM, write);
    }
}

var<workgroup> wg_count: u32;
var<workgroup> wg_reached: atomic<u32>;
var<workgroup> wg_blocks: array<u32, 256>;

// The huge lights share the workgroups: each gets `spread` of them (all of them for one
// light around the camera, one each when there are more lights than workgroups), its
// blocks cut into `spread` chunks. A workgroup tests up to 256 blocks of its chunk at once
// (a thread a block), gathers those the light reaches in workgroup memory and spreads
// their tiles over its threads: the blocks a light cannot reach cost one test, and no
// thread walks a chain of tiles while the rest of the GPU waits.
fn walk_huge(group: u32, groups: u32, lidx: u32, write: bool) {
    if lidx == 0u {
        wg_count = atomicLoad(&big_lights[1]);
    }
    let huge = workgroupUniformLoad(&wg_count);
    let spread = groups / max(huge, 1u);
    if spread == 0u {
        walk_huge_many(group, groups, lidx, huge, write);
        return;
    }
    // b < groups always: no product overflows.
    for (var b = group; b < huge * spread; b += groups) {
        let k = walk_of(atomicLoad(&big_lights[arrayLength(&big_lights) - 1u - b / spread]), true);
        let per = (k.blocks + spread - 1u) / spread;
        let lo = min((b % spread) * per, k.blocks);
        let hi = min(lo + per, k.blocks);
        if lidx == 0u {
            wg_count = hi - lo;
        }
        let n = workgroupUniformLoad(&wg_count);
        for (var r = 0u; r < n; r += 256u) {
            if lidx == 0u {
                atomicStore(&wg_reached, 0u);
            }
            workgroupBarrier();
            let j = lo + r + lidx;
            if j < hi && block_reached(k, block_at(k, j)) {
                wg_blocks[atomicAdd(&wg_reached, 1u)] = j;
            }
            workgroupBarrier();
            let m = atomicLoad(&wg_reached) * BLOCK * BLOCK;
            for (var u = lidx; u < m; u += 256u) {
                let tile = block_at(k, wg_blocks[u / (BLOCK * BLOCK)]) * BLOCK + vec2<u32>(u % BLOCK, (u / BLOCK) % BLOCK);
                if all(tile >= k.rect.lo) && all(tile < k.rect.hi) {
                    visit(k, tile, write);
                }
            }
            workgroupBarrier();
        }
    }
}

// More huge lights than the GPU has workgroups to spare: no barriers (a workgroup's
// threads each walk on at their own pace, hiding each other's loads): a light of more than
// WIDE_BLOCKS blocks by a whole workgroup, the rest by a team each, block by block.
fn walk_huge_many(group: u32, groups: u32, lidx: u32, huge: u32, write: bool) {
    let end = arrayLength(&big_lights) - 1u;
    for (var b = group; b < huge; b += groups) {
        let k = walk_of(atomicLoad(&big_lights[end - b]), true);
        if k.blocks > WIDE_BLOCKS {
            for (var j = lidx; j < k.blocks; j += 256u) {
                visit_block(k, j, write);
            }
        }
    }
    let teams = 256u / TEAM;
    for (var b = group * teams + lidx / TEAM; b < huge; b += groups * teams) {
        let k = walk_of(atomicLoad(&big_lights[end - b]), true);
        if k.blocks <= WIDE_BLOCKS {
            for (var j = lidx % TEAM; j < k.blocks; j += TEAM) {
                visit_block(k, j, write);
            }
        }
    }
}

@compute @workgroup_size(256)
fn count_lights(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    walk_light(gid.x + gid.y * nwg.x * 256u, false);
}

@compute @workgroup_size(256)
fn count_big(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    walk_big(wid.x, nwg.x, lidx, false);
}

@compute @workgroup_size(256)
fn write_lights(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    walk_light(gid.x + gid.y * nwg.x * 256u, true);
}

@compute @workgroup_size(256)
fn write_big(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    walk_big(wid.x, nwg.x, lidx, true);
}

var<workgroup> wg_scan: array<u32, 256>;
var<workgroup> wg_base: u32;

// Step 3: a thread per list. The workgroup's 256 counts are scanned in workgroup memory
// and allocated with one atomic add (as the tile-centric kernel allocates a tile's lists).
@compute @workgroup_size(256)
fn allocate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    let tiles = light_grid.header.tiles;
    let lists = tiles.x * tiles.y * lists_per_tile();
    let l = gid.x + gid.y * nwg.x * 256u;
    var count = 0u;
    if l < lists {
        count = atomicLoad(&list_counts[l]);
    }
    wg_scan[lidx] = count;
    workgroupBarrier();
    // Inclusive Hillis-Steele scan.
    for (var o = 1u; o < 256u; o <<= 1u) {
        var v = wg_scan[lidx];
        if lidx >= o {
            v += wg_scan[lidx - o];
        }
        workgroupBarrier();
        wg_scan[lidx] = v;
        workgroupBarrier();
    }
    let cap = light_grid.header.capacity;
    if lidx == 255u {
        wg_base = grid_allocate(wg_scan[255]);
    }
    workgroupBarrier();
    if l >= lists {
        return;
    }
    let base = wg_base;
    var first = cap;
    if base < cap {
        first = base + wg_scan[lidx] - count;
    }
    grid_place(l, first, count);
    // The write passes count again from 0: the cursor.
    atomicStore(&list_counts[l], 0u);
}

