// The stochastic method's material-and-lights pass (issue 48), one sample a pixel: each
// pixel's surface rebuilt from the visibility buffer (common/visibility_surface.wgsl), its
// light a few candidates resampled by their unshadowed contribution, one kept and shadowed
// by a ray through the scene's BVH, the frames accumulated (common/stochastic_shade.wgsl,
// in the traced kernel's body common/traced_shade.wgsl).
// variants: VISIBILITY TRACED STOCHASTIC NO_CUTOFF SPOT_LIGHTS TRACE_MASKS HALF_Z CLUSTERED
// variants: TEXTURES NORMAL_MAP UV1 DENOISE REUSE
#include "common/traced_shade.wgsl"
