// The traced reference's material-and-lights pass with MSAA (always set): a pixel whose
// samples share one ID is shaded once at its centre, others per sample, resolved as the
// visibility buffer resolves them (common/deferred_shade.wgsl, deferred_resolve.wgsl).
// variants: VISIBILITY TRACED NO_CUTOFF MSAA SPOT_LIGHTS VPLS TRACE_MASKS
// variants: TEXTURES NORMAL_MAP UV1
#include "common/traced_shade.wgsl"
