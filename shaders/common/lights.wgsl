// Light layouts. Culling data (bounding sphere, 16 bytes) is kept apart from shading data.
// Keep in sync with crates/cull/src/light.rs (GpuCullLight, GpuShadingLight, GpuSpotLight).

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
