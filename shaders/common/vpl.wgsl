// Virtual point lights (crates/cull/src/vpl.rs, GpuVpl; tiledlight_cull::vpl is the CPU twin):
// one VPL's shading data. Its culling sphere is a CullLight (common/lights.wgsl) of a
// buffer of its own, at the same index. The number of VPLs is min(count, cap), count being
// the generation pass's atomic counter (it counts the candidates the cap refused too).
struct Vpl {
    position: vec3<f32>,
    radius: f32,
    normal: vec3<f32>,
    _pad0: f32,
    flux: vec3<f32>,
    _pad1: f32,
}
