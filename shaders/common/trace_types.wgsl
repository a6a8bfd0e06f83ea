// The traced reference's hierarchy as uploaded (crates/gpu/src/bvh.rs, the Rust twin
// tiledlight_cull::trace::FlatNode, its layout checked by `cargo xtask validate-shaders`).

// The traversal stack: the deepest tree the builder makes has 96 levels
// (tiledlight_cull::trace::TRACE_STACK).
const TRACE_STACK: u32 = 96u;
const TRACE_NO_CHILD: u32 = 0xffffffffu;
const TRACE_NO_MASK: u32 = 0xffffffffu;
// The box test's far bound is kept this much wider (tiledlight_cull::trace::FAR_GROW).
const TRACE_FAR_GROW: f32 = 1.0000004768371582;

// Both children of a node: a child with count > 0 is a leaf of triangles link..link+count,
// with count 0 node `link` (or nothing when link is TRACE_NO_CHILD).
struct TraceNode {
    a_lo: vec3<f32>,
    a_link: u32,
    a_hi: vec3<f32>,
    a_count: u32,
    b_lo: vec3<f32>,
    b_link: u32,
    b_hi: vec3<f32>,
    b_count: u32,
}
