// Forward+ shading over clusters (CLUSTERED, always set: the fragment's list is its
// depth slice's in the light grid): common/forward_shade.wgsl. One entry file per light
// loop keeps each file's variants few (crates/gpu/src/variants.rs, ForwardKey).
// variants: SPOT_LIGHTS TEXTURES CLUSTERED ALPHA_MASK SHADOWS
// variants: NORMAL_MAP UV1 VPLS
#include "common/forward_shade.wgsl"
