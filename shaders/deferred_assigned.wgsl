// Tiled Deferred with lists assigned before this pass (light-centric assignment,
// assign.wgsl): common/assigned_shade.wgsl over the G-buffer (MSAA included).
// variants: SPOT_LIGHTS HALF_Z CLUSTERED EXTRA_RTS MSAA SHADOWS
// variants: EMISSION VPLS
#include "common/assigned_shade.wgsl"
