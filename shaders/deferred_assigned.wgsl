// Tiled Deferred with lists assigned before this pass (light-centric assignment,
// assign.wgsl): common/assigned_shade.wgsl over the G-buffer (MSAA included).
// variants: SPOT_LIGHTS HALF_Z CLUSTERED EXTRA_RTS EXTRA_RTS_2 EXTRA_RTS_3 MSAA SHADOWS
// variants: EMISSION VPLS
#include "common/assigned_shade.wgsl"
