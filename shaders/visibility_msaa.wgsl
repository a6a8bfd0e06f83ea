// The visibility buffer's material-and-lights pass with MSAA (always set): a pixel whose
// samples share one ID is shaded once at its centre, others per sample, resolved as Tiled
// Deferred resolves its edge pixels (common/deferred_shade.wgsl, deferred_resolve.wgsl).
// variants: VISIBILITY MSAA SPOT_LIGHTS HALF_Z CLUSTERED SHADOWS VPLS
// variants: TEXTURES NORMAL_MAP UV1
#include "common/assigned_shade.wgsl"
