// Per-frame constants shared by every pass, bound at @group(0) @binding(0).
// Keep in sync with crates/gpu/src/frame.rs (FrameUniforms); `cargo xtask validate-shaders` checks it.

struct Frame {
    view: mat4x4<f32>,
    proj: mat4x4<f32>,
    view_proj: mat4x4<f32>,
    // View to world (deferred shading rebuilds world positions from depth).
    inv_view: mat4x4<f32>,
    eye: vec3<f32>,
    exposure: f32,
    // Screen size in pixels and tiles.
    screen: vec2<u32>,
    tiles: vec2<u32>,
    tile_size: u32,
    capacity: u32,
    num_lights: u32,
    num_point_lights: u32,
    // Reversed-Z depth -> view distance (crates/cull/src/camera.rs, DepthParams).
    depth_near: f32,
    depth_far: f32,
    depth_k: f32,
    orthographic: u32,
    ambient: vec3<f32>,
    lists_per_tile: u32,
}

@group(0) @binding(0) var<uniform> frame: Frame;

// View distance (positive, along -Z) of a reversed-Z depth; the caller excludes sky (depth 0).
fn view_distance(depth: f32) -> f32 {
    if frame.orthographic != 0u {
        return frame.depth_far - depth * (frame.depth_far - frame.depth_near);
    }
    return frame.depth_near / (depth * (1.0 - frame.depth_k) + frame.depth_k);
}

// View-space point at NDC (x, y) and view distance `dist`; uses the projection's entries
// directly, as crates/cull/src/camera.rs `view_point_at` does.
fn view_point_at(ndc: vec2<f32>, dist: f32) -> vec3<f32> {
    let p = frame.proj;
    let z = -dist;
    var w = dist;
    if frame.orthographic != 0u {
        w = 1.0;
    }
    let x = (ndc.x * w - p[2].x * z - p[3].x) / p[0].x;
    let y = (ndc.y * w - p[2].y * z - p[3].y) / p[1].y;
    return vec3<f32>(x, y, z);
}

fn pixel_to_ndc(p: vec2<f32>) -> vec2<f32> {
    let s = vec2<f32>(frame.screen);
    return vec2<f32>(2.0 * p.x / s.x - 1.0, 1.0 - 2.0 * p.y / s.y);
}

// Unit vector from a world-space surface point towards the viewer: towards the eye for
// perspective, the camera's backward axis for orthographic projections.
fn view_vector(world: vec3<f32>) -> vec3<f32> {
    if frame.orthographic != 0u {
        return normalize(frame.inv_view[2].xyz);
    }
    return normalize(frame.eye - world);
}
