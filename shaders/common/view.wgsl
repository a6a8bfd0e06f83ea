// One view: a camera and the screen it renders to, bound at @group(0) @binding(0) of every
// scene and culling pipeline, by dynamic offset into an array of views (the main camera
// now; shadow faces and RSM views draw with the same pipelines at other offsets).
// Keep in sync with crates/gpu/src/view.rs (ViewUniforms); `cargo xtask validate-shaders` checks it.

struct View {
    world_to_view: mat4x4<f32>,
    view_to_clip: mat4x4<f32>,
    world_to_clip: mat4x4<f32>,
    // Deferred shading rebuilds world positions from depth.
    view_to_world: mat4x4<f32>,
    eye: vec3<f32>,
    // 1 for orthographic projections.
    orthographic: u32,
    // Screen size in pixels.
    screen: vec2<u32>,
    // Reversed-Z depth -> view distance (crates/cull/src/camera.rs, DepthParams).
    depth_near: f32,
    depth_far: f32,
    depth_k: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> view: View;

// View distance (positive, along -Z) of a reversed-Z depth; the caller excludes sky (depth 0).
fn view_distance(depth: f32) -> f32 {
    if view.orthographic != 0u {
        return view.depth_far - depth * (view.depth_far - view.depth_near);
    }
    return view.depth_near / (depth * (1.0 - view.depth_k) + view.depth_k);
}

// View-space point at NDC (x, y) and view distance `dist`; uses the projection's entries
// directly, as crates/cull/src/camera.rs `view_point_at` does.
fn view_point_at(ndc: vec2<f32>, dist: f32) -> vec3<f32> {
    return point_in_view(view.view_to_clip, view.orthographic, ndc, dist);
}

// view_point_at through another view's projection (`orthographic` 1 for orthographic):
// the stochastic method's previous frame.
fn point_in_view(p: mat4x4<f32>, orthographic: u32, ndc: vec2<f32>, dist: f32) -> vec3<f32> {
    let z = -dist;
    var w = dist;
    if orthographic != 0u {
        w = 1.0;
    }
    let x = (ndc.x * w - p[2].x * z - p[3].x) / p[0].x;
    let y = (ndc.y * w - p[2].y * z - p[3].y) / p[1].y;
    return vec3<f32>(x, y, z);
}

fn pixel_to_ndc(p: vec2<f32>) -> vec2<f32> {
    let s = vec2<f32>(view.screen);
    return vec2<f32>(2.0 * p.x / s.x - 1.0, 1.0 - 2.0 * p.y / s.y);
}

// Unit vector from a world-space surface point towards the viewer: towards the eye for
// perspective, the camera's backward axis for orthographic projections.
fn view_vector(world: vec3<f32>) -> vec3<f32> {
    return vector_to_viewer(view.view_to_world, view.eye, view.orthographic, world);
}

// view_vector for another view (its view-to-world matrix, eye and projection kind).
fn vector_to_viewer(view_to_world: mat4x4<f32>, eye: vec3<f32>, orthographic: u32, world: vec3<f32>) -> vec3<f32> {
    if orthographic != 0u {
        return normalize(view_to_world[2].xyz);
    }
    return normalize(eye - world);
}
