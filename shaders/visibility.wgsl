// The visibility buffer's material-and-lights pass, one sample per pixel: each pixel's
// triangle rebuilt from its ID (common/visibility_surface.wgsl), its material evaluated and
// lit by its list in the light grid (common/assigned_shade.wgsl). The MSAA kernel is
// visibility_msaa.wgsl (one entry file each keeps each file's variants few:
// crates/gpu/src/variants.rs, VisibilityKey).
// variants: VISIBILITY SPOT_LIGHTS HALF_Z CLUSTERED SHADOWS VPLS
// variants: TEXTURES NORMAL_MAP UV1
#include "common/assigned_shade.wgsl"
