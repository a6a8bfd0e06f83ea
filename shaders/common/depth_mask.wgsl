// The 32-bit depth-occupancy mask of a screen region, reduced by a workgroup: bit k is set
// when a non-sky sample of the region lies in bin k. With CLUSTERED the bins are the
// clusters' depth slices (cluster_slice with `a` = first, `b` = scale, `n` slices: the
// clusters that hold geometry); otherwise the 2.5D bins of the region's own depth range
// (depth_bin with `a` = near, `b` = far; Harada 2012). Include after
// common/depth_range.wgsl and common/tile_tests.wgsl. CPU twins:
// tiledlight_cull tile_depth_masks and cluster_occupancy.

var<workgroup> wg_mask: atomic<u32>;

fn mask_bin(d: f32, a: f32, b: f32, n: u32) -> u32 {
#ifdef CLUSTERED
    return cluster_slice(d, a, b, n);
#else
    return depth_bin(d, a, b);
#endif
}

// The mask of the `size` x `size` pixels at `origin` (every sample with MSAA), reduced by a
// `threads` x `threads` workgroup (this thread is `lid`). Every thread must call it from
// uniform control flow: it has barriers.
fn region_mask(origin: vec2<u32>, size: u32, threads: u32, lid: vec2<u32>, lidx: u32, a: f32, b: f32, n: u32) -> u32 {
    if lidx == 0u {
        atomicStore(&wg_mask, 0u);
    }
    workgroupBarrier();
    var m = 0u;
    let steps = size / threads;
    for (var j = 0u; j < steps; j++) {
        for (var i = 0u; i < steps; i++) {
            let p = origin + lid + vec2<u32>(i, j) * threads;
            if p.x < view.screen.x && p.y < view.screen.y {
#ifdef MSAA
                for (var s = 0u; s < SAMPLES; s++) {
                    let d = load_depth(p, s);
                    if d > 0.0 {
                        m |= 1u << mask_bin(view_distance(d), a, b, n);
                    }
                }
#else
                let d = load_depth(p, 0u);
                if d > 0.0 {
                    m |= 1u << mask_bin(view_distance(d), a, b, n);
                }
#endif
            }
        }
    }
    if m != 0u {
        atomicOr(&wg_mask, m);
    }
    workgroupBarrier();
    return atomicLoad(&wg_mask);
}
