// The visibility buffer's compute raster (issue 29): the scene's opaque triangles drawn by
// compute into 64-bit texels, (depth bits << 32) | ID, resolved by atomicMax (reversed-Z:
// the nearest depth is the largest; equal depths keep the larger ID, as the CPU twin
// tiledlight_cull::raster does). Bindings: crates/visibility/src/compute_raster.rs.
//
// 1. cs_clusters: one workgroup per (instance, cluster) entry (entries, 2D-dispatched).
//    Its first lane tests the cluster's object-space bounds against the view frustum (all
//    eight corners outside one plane: culled; the whole workgroup leaves). Otherwise each
//    lane takes one triangle: fetches its vertices from the scene's index and position
//    buffers, transforms them as the hardware raster's vertex stage does
//    (common/scene.wgsl transform_position), clips, snaps and culls them
//    (common/compute_raster.wgsl raster_setup; back faces only for single-sided materials,
//    the entry's top bit), and fills it when its bounds span at most params.large_px
//    pixels each way; a larger one is appended to the large list (one thread would take
//    too long over its pixels). With CLIPPED_TO_LARGE (the large triangles by compute) a
//    triangle that needs clipping is appended too, unclipped and with its culling flag,
//    so the clipped polygon's arrays stay out of this, the hot kernel (issue 49).
// 2. The large list, by compute (the default) or by the hardware
//    (visibility_raster_large.wgsl); alpha-masked instances by the hardware
//    (depth_prepass.wgsl with IDS ATOMIC), atomicMax from fragments. By compute, in two
//    passes so that no workgroup waits on one triangle's many pixels (issue 49):
//    a. cs_large: a workgroup a large triangle sets it up once and lists the 16 x 16 px
//       screen tiles of its bounds that its edges do not rule out (raster_tile_open), as
//       (triangle, piece of its clipped fan, tile) items;
//    b. cs_large_tiles: 32 lanes an item, each setting the triangle up and covering eight
//       pixels of the tile, by the same rules and values as one thread's fill. A list
//       that would pass its capacity is not cut: the lane that finds it full fills that
//       tile's pixels itself.
// 3. cs_finalize: per pixel, the texel's depth to an R32Float texture and its ID to the
//    R32Uint ID texture (what the culling and shading passes read), then the texel back to
//    the clear value and the large list and its tiles emptied, ready for the next frame.
// variants: VISIBILITY
#include "common/scene.wgsl"
#include "common/compute_raster.wgsl"

// An (instance, cluster) pair to draw: `cluster` indexes `clusters`, its top bit set when
// back faces are culled (the instance's material is single-sided).
struct Entry {
    instance: u32,
    cluster: u32,
}

// tiledlight_scene::clusters::Cluster: object-space bounds, first slot of cluster_order
// (counted from the mesh's first triangle) and triangle count.
struct Cluster {
    bounds_min: vec3<f32>,
    first: u32,
    bounds_max: vec3<f32>,
    count: u32,
}

struct RasterParams {
    // Entries to draw.
    entries: u32,
    // Workgroups per row of the 2D dispatch.
    groups_x: u32,
    // A triangle whose bounds span more pixels than this (either way) goes to the hardware.
    large_px: u32,
    // Triangle IDs' low bits (tiledlight_cull::visibility::IdLayout::triangle_bits).
    triangle_bits: u32,
    // Items the large triangles' tile list holds.
    tile_capacity: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// A large triangle: instance, triangle within the instance's mesh; the triangle's top bit
// (LARGE_CULL) set when it still needs back-face culling (appended before its set-up, with
// CLIPPED_TO_LARGE).
struct Large {
    instance: u32,
    triangle: u32,
}

// wgpu::util::DrawIndirectArgs (the hardware's draw of the large list), then the count of
// the large triangles' tile items listed (it may pass the capacity) and the last frame's
// (kept by cs_finalize for tests).
struct LargeArgs {
    vertex_count: atomic<u32>,
    instance_count: u32,
    first_vertex: u32,
    first_instance: u32,
    tiles: atomic<u32>,
    tiles_last: u32,
    pad0: u32,
    pad1: u32,
}

@group(1) @binding(26) var<storage, read> vis_indices: array<u32>;
@group(1) @binding(27) var<storage, read> vis_positions: array<f32>;
@group(1) @binding(40) var<uniform> params: RasterParams;
@group(1) @binding(41) var<storage, read> entries: array<Entry>;
@group(1) @binding(42) var<storage, read> clusters: array<Cluster>;
@group(1) @binding(43) var<storage, read_write> texels: array<atomic<u64>>;
// The same buffer as plain words (low, high) for the finalize pass's loads and stores.
@group(1) @binding(44) var<storage, read_write> texel_words: array<vec2<u32>>;
@group(1) @binding(45) var<storage, read_write> large: array<Large>;
@group(1) @binding(46) var<storage, read_write> large_args: LargeArgs;
@group(1) @binding(47) var depth_out: texture_storage_2d<r32float, write>;
@group(1) @binding(48) var ids_out: texture_storage_2d<r32uint, write>;
// The large triangles' tile items: (large list index << 3 | piece, tile x | tile y << 16).
@group(1) @binding(51) var<storage, read_write> large_tiles: array<vec2<u32>>;
// Per triangle of the merged index buffer in cluster order, its index within its mesh
// (SceneGpu::cluster_triangles): the index buffer keeps each mesh's own order.
@group(1) @binding(50) var<storage, read> cluster_order: array<u32>;

// Whether cs_clusters hands every triangle that needs clipping to the large list (true with
// the large triangles by compute, whose kernels clip; the hardware's draw has no culling
// of its own, so with it cs_clusters clips and culls them).
override CLIPPED_TO_LARGE: bool = false;
const LARGE_CULL: u32 = 0x80000000u;

// The clear value: depth 0 (infinitely far), no triangle (tiledlight_cull::raster::CLEAR).
const VIS_NO_TRIANGLE: u32 = 0xffffffffu;

fn raster_emit(x: u32, y: u32, texel: u64) {
    atomicMax(&texels[y * view.screen.x + x], texel);
}

fn vertex_position(index: u32, base_vertex: i32) -> vec3<f32> {
    let v = u32(i32(index) + base_vertex) * 3u;
    return vec3<f32>(vis_positions[v], vis_positions[v + 1u], vis_positions[v + 2u]);
}

// Whether the box `lo`..`hi` (object space of `instance`) may be in the view frustum:
// false only when all eight corners lie outside one plane (x and y at +-w, the near plane
// z = w, behind the eye; reversed-Z puts the far plane at z = 0).
fn cluster_visible(instance: u32, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    var outside = vec4<u32>(0u);
    var outside2 = vec2<u32>(0u);
    for (var k = 0u; k < 8u; k++) {
        let p = select(lo, hi, vec3<bool>((k & 1u) != 0u, (k & 2u) != 0u, (k & 4u) != 0u));
        let c = transform_position(instance, p);
        outside += vec4<u32>(vec4<bool>((c.x > c.w), (c.x < -c.w), (c.y > c.w), (c.y < -c.w)));
        outside2 += vec2<u32>(vec2<bool>((c.z > c.w), (c.z < 0.0)));
    }
    return !(any(outside == vec4<u32>(8u)) || any(outside2 == vec2<u32>(8u)));
}

var<workgroup> wg_visible: u32;

@compute @workgroup_size(128)
fn cs_clusters(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let e = wg.y * params.groups_x + wg.x;
    if e >= params.entries {
        return;
    }
    let entry = entries[e];
    let cluster = clusters[entry.cluster & 0x7fffffffu];
    if lane == 0u {
        wg_visible = u32(cluster_visible(entry.instance, cluster.bounds_min, cluster.bounds_max));
    }
    if workgroupUniformLoad(&wg_visible) == 0u || lane >= cluster.count {
        return;
    }
    let inst = instances[entry.instance];
    let triangle = cluster_order[inst.first_index / 3u + cluster.first + lane];
    let base = inst.first_index + 3u * triangle;
    let c0 = transform_position(entry.instance, vertex_position(vis_indices[base], inst.base_vertex));
    let c1 = transform_position(entry.instance, vertex_position(vis_indices[base + 1u], inst.base_vertex));
    let c2 = transform_position(entry.instance, vertex_position(vis_indices[base + 2u], inst.base_vertex));
    let cull_back = (entry.cluster & 0x80000000u) != 0u;
    let id = select(entry.instance << params.triangle_bits, 0u, params.triangle_bits >= 32u) | triangle;
    // Through i32: u32::MAX ("none is large") became -1 (every triangle large) when
    // converted to i64 directly (seen on lavapipe); no span passes 2^31 px.
    let large_px = vec2<i64>(i64(i32(min(params.large_px, 0x7fffffffu))));
    // Most triangles need no clipping: three snapped vertices, no polygon arrays.
    if raster_finite(c0) && raster_finite(c1) && raster_finite(c2) && raster_inside(c0, c1, c2) {
        let t = raster_setup_inside(c0, c1, c2, view.screen, cull_back);
        if !t.drawn {
            return;
        }
        if any(raster_span_tri(t) > large_px) {
            append_large(entry.instance, triangle);
            return;
        }
        raster_fill(t.a, t.b, t.c, view.screen, id);
        return;
    }
    if CLIPPED_TO_LARGE {
        if raster_finite(c0) && raster_finite(c1) && raster_finite(c2) {
            append_large(entry.instance, triangle | select(0u, LARGE_CULL, cull_back));
        }
        return;
    }
    let t = raster_setup(c0, c1, c2, view.screen, cull_back);
    if t.n == 0u {
        return;
    }
    if any(raster_span(t) > large_px) {
        append_large(entry.instance, triangle);
        return;
    }
    raster_fill_setup(t, view.screen, id);
}

// Appends a triangle to the large list (cs_large or the hardware draws it).
fn append_large(instance: u32, triangle: u32) {
    let slot = atomicAdd(&large_args.vertex_count, 3u) / 3u;
    large[slot] = Large(instance, triangle);
}

// Workgroups of cs_large (crates/visibility/src/compute_raster.rs LARGE_GROUPS): each takes
// every LARGE_GROUPS-th large triangle.
const LARGE_GROUPS: u32 = 1024u;
const LARGE_LANES: u32 = 256u;

// A large triangle's clip-space vertices and ID (inside every plane, its back face was
// culled when it was listed; one that needs clipping carries LARGE_CULL, and its set-up
// culls it).
struct LargeClip {
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    id: u32,
}

fn large_clip(l: Large) -> LargeClip {
    let inst = instances[l.instance];
    let triangle = l.triangle & ~LARGE_CULL;
    let base = inst.first_index + 3u * triangle;
    let c0 = transform_position(l.instance, vertex_position(vis_indices[base], inst.base_vertex));
    let c1 = transform_position(l.instance, vertex_position(vis_indices[base + 1u], inst.base_vertex));
    let c2 = transform_position(l.instance, vertex_position(vis_indices[base + 2u], inst.base_vertex));
    let id = select(l.instance << params.triangle_bits, 0u, params.triangle_bits >= 32u) | triangle;
    return LargeClip(c0, c1, c2, id);
}

// Lists the tiles of piece `piece` (prepared as f) of large triangle `t` (step 2a).
fn list_tiles(f: RasterFill, t: u32, piece: u32, id: u32, lane: u32) {
    if !f.drawn || any(f.hi < f.lo) {
        return;
    }
    let t0 = f.lo / vec2<i64>(RASTER_TILE);
    let t1 = f.hi / vec2<i64>(RASTER_TILE);
    let width = u32(t1.x - t0.x) + 1u;
    let tiles = width * (u32(t1.y - t0.y) + 1u);
    for (var k = lane; k < tiles; k += LARGE_LANES) {
        let tile = t0 + vec2<i64>(i64(k % width), i64(k / width));
        if !raster_tile_open(f, tile) {
            continue;
        }
        let slot = atomicAdd(&large_args.tiles, 1u);
        if slot < params.tile_capacity {
            large_tiles[slot] = vec2<u32>((t << 3u) | piece, u32(tile.x) | (u32(tile.y) << 16u));
        } else {
            raster_fill_tile(f, tile, id);
        }
    }
}

// 2a. With large triangles by compute: a workgroup a large triangle (LARGE_GROUPS of them
// looping over the list), its 256 lanes sharing the tiles of its bounds.
@compute @workgroup_size(256)
fn cs_large(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let count = atomicLoad(&large_args.vertex_count) / 3u;
    for (var t = wg.x; t < count; t += LARGE_GROUPS) {
        let l = large[t];
        let c = large_clip(l);
        // Inside every plane: culled when listed. Clipped: culled here when flagged.
        if raster_inside(c.c0, c.c1, c.c2) {
            let s = raster_setup_inside(c.c0, c.c1, c.c2, view.screen, false);
            list_tiles(raster_prepare(s.a, s.b, s.c, view.screen), t, 0u, c.id, lane);
        } else {
            let s = raster_setup(c.c0, c.c1, c.c2, view.screen, (l.triangle & LARGE_CULL) != 0u);
            for (var i = 1u; i + 1u < s.n; i++) {
                list_tiles(raster_prepare(s.s[0], s.s[i], s.s[i + 1u], view.screen), t, i - 1u, c.id, lane);
            }
        }
    }
}

// 2b. Two tile items a 64-lane workgroup (as many workgroups as the screen has tiles,
// looping over the items), 32 lanes an item: each lane sets the triangle up once and
// covers eight pixels of the tile, a column of it every second row, its edge values
// stepped by exact integer additions from the first (the set-up, a few hundred
// instructions, paid once per eight pixels): the same coverage and depth as raster_fill's.
@compute @workgroup_size(64)
fn cs_large_tiles(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                  @builtin(local_invocation_index) lane: u32) {
    let count = min(atomicLoad(&large_args.tiles), params.tile_capacity);
    let stride = 2u * groups.x * groups.y;
    let column = vec2<i64>(i64(lane % 16u), i64((lane / 16u) % 2u));
    for (var w = 2u * (wg.y * groups.x + wg.x) + lane / 32u; w < count; w += stride) {
        let item = large_tiles[w];
        let l = large[item.x >> 3u];
        let c = large_clip(l);
        let piece = item.x & 7u;
        var f: RasterFill;
        if raster_inside(c.c0, c.c1, c.c2) {
            let s = raster_setup_inside(c.c0, c.c1, c.c2, view.screen, false);
            f = raster_prepare(s.a, s.b, s.c, view.screen);
        } else {
            let s = raster_setup(c.c0, c.c1, c.c2, view.screen, (l.triangle & LARGE_CULL) != 0u);
            f = raster_prepare(s.s[0], s.s[piece + 1u], s.s[piece + 2u], view.screen);
        }
        if !f.drawn {
            continue;
        }
        var p = vec2<i64>(i64(item.y & 0xffffu), i64(item.y >> 16u)) * RASTER_TILE + column;
        var e = raster_edges(f, p.x, p.y);
        // Two rows down: the edge functions' y step (raster_fill's sy) twice.
        let step = vec3<i64>(f.v2.x - f.v1.x, f.v0.x - f.v2.x, f.v1.x - f.v0.x) * (2li * RASTER_ONE);
        for (var k = 0u; k < 8u; k++) {
            if all(p >= f.lo) && all(p <= f.hi) {
                raster_cover(f, e, p.x, p.y, c.id);
            }
            p.y += 2li;
            e += step;
        }
    }
}

@compute @workgroup_size(8, 8)
fn cs_finalize(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x == 0u && gid.y == 0u {
        atomicStore(&large_args.vertex_count, 0u);
        large_args.tiles_last = atomicLoad(&large_args.tiles);
        atomicStore(&large_args.tiles, 0u);
    }
    if gid.x >= view.screen.x || gid.y >= view.screen.y {
        return;
    }
    let i = gid.y * view.screen.x + gid.x;
    let t = texel_words[i];
    textureStore(depth_out, gid.xy, vec4<f32>(bitcast<f32>(t.y), 0.0, 0.0, 0.0));
    textureStore(ids_out, gid.xy, vec4<u32>(t.x, 0u, 0u, 0u));
    texel_words[i] = vec2<u32>(VIS_NO_TRIANGLE, 0u);
}
