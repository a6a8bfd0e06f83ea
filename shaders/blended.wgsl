// Blended geometry shaded over light-grid lists: the blended grid's (one list per tile) or,
// with CLUSTERED, the frame's clustered grid's: common/blended_shade.wgsl. One entry file
// per light loop keeps each file's variants few (crates/gpu/src/variants.rs, BlendedKey).
// variants: SPOT_LIGHTS TEXTURES SHADOWS WBOIT CLUSTERED
// variants: NORMAL_MAP UV1
#include "common/blended_shade.wgsl"
