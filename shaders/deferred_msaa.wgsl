// Tiled Deferred's cull-and-shade kernel with MSAA (always set: the edge test, per-sample
// shading of edge pixels and the resolve's edge list): common/deferred_tile.wgsl. One entry
// file per kernel keeps each file's variants few (crates/gpu/src/variants.rs,
// DeferredTileKey).
// variants: SPOT_LIGHTS HALF_Z SPOT_CONE COARSE EXTRA_RTS
// variants: MSAA SHADOWS EMISSION VPLS
#include "common/deferred_tile.wgsl"
