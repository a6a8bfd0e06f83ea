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
//    too long over its pixels).
// 2. The large list: cs_large below (a workgroup a triangle, the default) or the hardware
//    (visibility_raster_large.wgsl); alpha-masked instances by the hardware
//    (depth_prepass.wgsl with IDS ATOMIC), atomicMax from fragments.
// 3. cs_finalize: per pixel, the texel's depth to an R32Float texture and its ID to the
//    R32Uint ID texture (what the culling and shading passes read), then the texel back to
//    the clear value and the large list emptied, ready for the next frame.
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
}

// A triangle handed to the hardware: instance, triangle within the instance's mesh.
struct Large {
    instance: u32,
    triangle: u32,
}

// wgpu::util::DrawIndirectArgs.
struct LargeArgs {
    vertex_count: atomic<u32>,
    instance_count: u32,
    first_vertex: u32,
    first_instance: u32,
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
// Per triangle of the merged index buffer in cluster order, its index within its mesh
// (SceneGpu::cluster_triangles): the index buffer keeps each mesh's own order.
@group(1) @binding(50) var<storage, read> cluster_order: array<u32>;

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
    let large_px = vec2<i64>(i64(params.large_px));
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

// 2'. With large triangles by compute: a workgroup a large triangle (LARGE_GROUPS of them
// looping over the list), its 256 lanes sharing the triangle's pixels (raster_fill_strided:
// the same rules and values as one thread's fill). Back faces were culled when listed.
@compute @workgroup_size(256)
fn cs_large(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let count = atomicLoad(&large_args.vertex_count) / 3u;
    for (var t = wg.x; t < count; t += LARGE_GROUPS) {
        let l = large[t];
        let inst = instances[l.instance];
        let base = inst.first_index + 3u * l.triangle;
        let c0 = transform_position(l.instance, vertex_position(vis_indices[base], inst.base_vertex));
        let c1 = transform_position(l.instance, vertex_position(vis_indices[base + 1u], inst.base_vertex));
        let c2 = transform_position(l.instance, vertex_position(vis_indices[base + 2u], inst.base_vertex));
        let id = select(l.instance << params.triangle_bits, 0u, params.triangle_bits >= 32u) | l.triangle;
        if raster_inside(c0, c1, c2) {
            let s = raster_setup_inside(c0, c1, c2, view.screen, false);
            raster_fill_strided(s.a, s.b, s.c, view.screen, id, lane, LARGE_LANES);
        } else {
            raster_fill_setup_strided(raster_setup(c0, c1, c2, view.screen, false), view.screen, id, lane, LARGE_LANES);
        }
    }
}

@compute @workgroup_size(8, 8)
fn cs_finalize(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x == 0u && gid.y == 0u {
        atomicStore(&large_args.vertex_count, 0u);
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
