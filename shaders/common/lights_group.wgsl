// Group 3, the lights, of every forward shading entry (forward.wgsl, forward_clustered.wgsl,
// brute_force.wgsl, blended.wgsl, blended_brute_force.wgsl): declared once here, as
// crates/gpu/src/lights_group.rs (LightsGroup) binds it. The binding numbers of the shared
// resources are those of Tiled Deferred's group 1 (deferred.wgsl): shadows 15-17, VPLs
// 19-22.
//
// Always the shading lights (0) and the lighting uniform (5); with SPOT_LIGHTS the spots (1);
// unless BRUTE_FORCE the light grid (2) and its indices (3), with HALF_Z the tile ranges (4)
// (common/light_grid_pixel.wgsl looks a pixel's list up); with SHADOWS the shadow atlas (15),
// its comparison sampler (16) and faces (17); with VPLS the VPLs (19), their shading uniform
// (20) and the generation's counter (23), and unless BRUTE_FORCE their light grid (21) and
// its indices (22).
#include "common/shade.wgsl"

@group(3) @binding(0) var<storage, read> shading_lights: array<ShadingLight>;
@group(3) @binding(5) var<uniform> lighting: Lighting;
#ifdef SPOT_LIGHTS
@group(3) @binding(1) var<storage, read> spot_lights: array<SpotLight>;
#endif
#ifdef SHADOWS
// The shadow atlas (common/shadow.wgsl).
@group(3) @binding(15) var shadow_atlas: texture_depth_2d_array;
@group(3) @binding(16) var shadow_sampler: sampler_comparison;
@group(3) @binding(17) var<storage, read> shadow_faces: array<ShadowFace>;
#endif
#ifdef VPLS
#include "common/vpl.wgsl"
@group(3) @binding(19) var<storage, read> vpls: array<Vpl>;
@group(3) @binding(20) var<uniform> vpl_shading: VplShading;
@group(3) @binding(23) var<storage, read> vpl_count: u32;
#ifndef BRUTE_FORCE
#include "common/light_grid.wgsl"
@group(3) @binding(21) var<storage, read> vpl_grid: LightGrid;
@group(3) @binding(22) var<storage, read> vpl_indices: array<u32>;
#endif
#endif
#ifndef BRUTE_FORCE
// The light grid (common/light_grid.wgsl).
@group(3) @binding(2) var<storage, read> light_grid: LightGrid;
@group(3) @binding(3) var<storage, read> light_indices: array<u32>;
#ifdef HALF_Z
// Per tile: near and far view distance (the half-z lookup).
@group(3) @binding(4) var<storage, read> tile_ranges: array<vec2<f32>>;
#endif
#include "common/light_grid_pixel.wgsl"
#endif
