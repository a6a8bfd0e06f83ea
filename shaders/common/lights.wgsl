// Light layouts. Culling data (bounding sphere, 16 bytes) is kept apart from shading data.
// Keep in sync with crates/cull/src/light.rs (GpuCullLight, GpuShadingLight, GpuSpotLight).

// The light set's counts and the ambient term (crates/gpu/src/lights_gpu.rs,
// LightingUniforms), a uniform the including file declares as `lighting` next to its light
// buffers.
// The shadow fields are read only by the SHADOWS variant (common/shadow.wgsl).
struct Lighting {
    ambient: vec3<f32>,
    num_lights: u32,
    num_point_lights: u32,
    // Shadow casters: the first points and the first spots.
    num_shadow_points: u32,
    num_shadow_spots: u32,
    // Added to the reference depth: two 16-bit quanta for Depth16Unorm, 0 for Depth32Float.
    shadow_depth_bias: f32,
    // One atlas texel and one tile, in atlas coordinates.
    shadow_texel_uv: vec2<f32>,
    shadow_tile_uv: vec2<f32>,
}

struct CullLight {
    center: vec3<f32>,
    radius: f32,
}

struct ShadingLight {
    position: vec3<f32>,
    radius: f32,
    radiance: vec3<f32>,
    _pad: f32,
}

// Spot lights follow the point lights; spot `i` of the light list uses entry i - num_point_lights.
struct SpotLight {
    direction: vec3<f32>,
    cos_outer: f32,
    angle_scale: f32,
    angle_offset: f32,
    sin_outer: f32,
    _pad: f32,
}

// One face of the shadow atlas (crates/gpu/src/shadow_atlas.rs, GpuShadowFace), read by
// the SHADOWS variant (common/shadow.wgsl).
struct ShadowFace {
    world_to_clip: mat4x4<f32>,
    // Atlas coordinates (0..1) of the tile's top-left corner.
    uv_origin: vec2<f32>,
    layer: u32,
    // World size of one texel per unit of view depth.
    texel: f32,
}
