// The traced reference's shadow rays one segment a thread, for the twin test
// (tests/tests/traced.rs): tiledlight_gpu::bvh::RayQueries binds the hierarchy
// (crates/gpu/src/bvh.rs, GpuBvh) and the segments; each thread writes whether its segment
// is blocked (common/trace.wgsl trace_occluded, CPU twin tiledlight_cull::trace).
// variants: TRACE_MASKS
#include "common/trace.wgsl"

@group(0) @binding(0) var<storage, read> trace_nodes: array<TraceNode>;
@group(0) @binding(1) var<storage, read> trace_tris: array<vec4<f32>>;
#ifdef TRACE_MASKS
@group(0) @binding(2) var<storage, read> trace_uvs: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> trace_mask_slots: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> trace_mask_bits: array<u32>;
#endif
// Per segment: (from, eps) and (to, unused).
@group(0) @binding(5) var<storage, read> segments: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> blocked: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&blocked) {
        return;
    }
    let a = segments[2u * i];
    let b = segments[2u * i + 1u];
    blocked[i] = select(0u, 1u, trace_occluded(a.xyz, b.xyz, a.w));
}
