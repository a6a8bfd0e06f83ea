// Forward+ shading over 2D tile lists (one per tile, or the near and far half's with
// HALF_Z): common/forward_shade.wgsl. One entry file per light loop keeps each file's
// variants few (crates/gpu/src/variants.rs, ForwardKey).
// variants: SPOT_LIGHTS TEXTURES HALF_Z ALPHA_MASK SHADOWS
// variants: NORMAL_MAP UV1 VPLS
#include "common/forward_shade.wgsl"
