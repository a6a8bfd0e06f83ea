// The brute-force reference (BRUTE_FORCE, always set): every fragment loops over every
// light, with the windowed falloff or, with NO_CUTOFF, plain inverse-square:
// common/forward_shade.wgsl. One entry file per light loop keeps each file's variants few
// (crates/gpu/src/variants.rs, ForwardKey).
// variants: SPOT_LIGHTS TEXTURES BRUTE_FORCE NO_CUTOFF ALPHA_MASK SHADOWS
// variants: NORMAL_MAP UV1 VPLS
#include "common/forward_shade.wgsl"
