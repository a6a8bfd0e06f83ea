// Tiled Deferred's cull-and-shade kernel, one sample per pixel: common/deferred_tile.wgsl.
// The MSAA kernel is deferred_msaa.wgsl, the kernel shading lists assigned before it
// deferred_assigned.wgsl; one entry file each keeps each file's variants few
// (crates/gpu/src/variants.rs, DeferredTileKey). DROP_LIGHT is the culling's test hook.
// variants: SPOT_LIGHTS HALF_Z AABB SPOT_CONE COARSE EXTRA_RTS EXTRA_RTS_2 EXTRA_RTS_3
// variants: SHADOWS EMISSION VPLS DROP_LIGHT
#include "common/deferred_tile.wgsl"
