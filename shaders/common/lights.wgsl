// Light layouts. Culling data (bounding sphere, 16 bytes) is kept apart from shading data.
// Keep in sync with crates/cull/src/light.rs (GpuCullLight, GpuShadingLight, GpuSpotLight).

// The light set's counts and the ambient term (crates/gpu/src/lights_gpu.rs,
// LightingUniforms), a uniform the including file declares as `lighting` next to its light
// buffers.
struct Lighting {
    ambient: vec3<f32>,
    num_lights: u32,
    num_point_lights: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
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
