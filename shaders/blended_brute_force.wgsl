// Blended geometry shaded over every light (BRUTE_FORCE, always set; NO_CUTOFF: plain
// inverse-square): common/blended_shade.wgsl. One entry file per light loop keeps each
// file's variants few (crates/gpu/src/variants.rs, BlendedKey).
// variants: SPOT_LIGHTS TEXTURES BRUTE_FORCE NO_CUTOFF SHADOWS WBOIT
// variants: NORMAL_MAP UV1
#include "common/blended_shade.wgsl"
