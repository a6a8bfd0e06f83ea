// Tiled Deferred's cull-and-shade kernel, one sample per pixel: common/deferred_tile.wgsl.
// The MSAA kernel is deferred_msaa.wgsl, the kernel shading lists assigned before it
// deferred_assigned.wgsl; one entry file each keeps each file's variants few
// (crates/gpu/src/variants.rs, DeferredTileKey). DROP_LIGHT is the culling's test hook.
// variants: SPOT_LIGHTS HALF_Z SPOT_CONE COARSE EXTRA_RTS
// variants: SHADOWS EMISSION VPLS DROP_LIGHT
#include "common/deferred_tile.wgsl"
