// The traced reference's material-and-lights pass, one sample per pixel: each pixel's
// surface rebuilt from the visibility buffer (common/visibility_surface.wgsl), lit by every
// light with no cutoff, each light's share multiplied by a shadow ray through the scene's
// BVH (common/traced_shade.wgsl, common/trace.wgsl). The MSAA kernel is traced_msaa.wgsl.
// variants: VISIBILITY TRACED NO_CUTOFF SPOT_LIGHTS VPLS TRACE_MASKS
// variants: TEXTURES NORMAL_MAP UV1
#include "common/traced_shade.wgsl"
