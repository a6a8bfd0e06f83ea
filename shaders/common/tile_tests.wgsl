// The per-tile light tests shared by the tile-centric culler (common/tile_cull.wgsl: a
// workgroup per tile gathers the lights) and the light-centric assignment (assign.wgsl: a
// thread per light scatters itself into the tiles it covers), so both find the same lists,
// and the 2.5D depth bins (Harada 2012); the clusters' depth slices are part of the grid
// contract (common/light_grid.wgsl). The CPU twins are
// crates/cull/src/reference.rs (light_in_volume), crates/cull/src/assign.rs (light_tile_rect)
// and the 2.5D functions of tiledlight_cull (depth_bin): keep the arithmetic identical.
//
// The including file declares `lighting: Lighting` and, with SPOT_CONE, `shading_lights`
// and `spot_lights`.
#include "common/cull_tests.wgsl"
#include "common/lights.wgsl"

// The light tests beyond the sphere/planes one, switched by pipeline constants rather than
// defines (a define each doubled every kernel's variants: issue 45): the view-space box
// test (AABB_TEST, `--aabb`), and with SPOT_CONE (the spot buffers bound) the spot cone
// against the tile's box (SPOT_CONE_TEST; Tiled Deferred compiles the cone with any spot
// light and switches it here, the culling kernels define SPOT_CONE only when it is on).
override AABB_TEST: bool = false;
override SPOT_CONE_TEST: bool = true;

// The light's tests beyond the sphere/planes one (AABB, spot cone); `c` is the view-space centre.
fn extra_tests(v: TileVolume, light: u32, c: vec3<f32>, r: f32) -> bool {
    if AABB_TEST {
        if !sphere_vs_aabb(volume_aabb(v), c, r) {
            return false;
        }
    }
#ifdef SPOT_CONE
    if SPOT_CONE_TEST && light >= lighting.num_point_lights {
        let b = volume_aabb(v);
        let s = spot_lights[light - lighting.num_point_lights];
        let sh = shading_lights[light];
        let apex = (view.world_to_view * vec4<f32>(sh.position, 1.0)).xyz;
        let axis = (view.world_to_view * vec4<f32>(s.direction, 0.0)).xyz;
        let sc = (b.lo + b.hi) * 0.5;
        // The farthest corner from the rounded centre (crates/cull/src/bounds.rs aabb_sphere).
        let sr = length(max(b.hi - sc, sc - b.lo));
        if !cone_vs_sphere(apex, axis, sh.radius, s.cos_outer, s.sin_outer, sc, sr) {
            return false;
        }
    }
#endif
    return true;
}

// The distance where half-z splits a tile's range (tiledlight_cull::lists::half_z_split).
fn half_z_split(near: f32, far: f32) -> f32 {
    return 0.5 * (near + far);
}

// The near (or only) list's volume, and the far list's with HALF_Z.
struct TileVolumes {
    v0: TileVolume,
    v1: TileVolume,
}

// The volumes of the `tile_size` tile `tile` whose surfaces span view distances [near, far].
fn tile_volumes_at(tile: vec2<u32>, tile_size: u32, near: f32, far: f32) -> TileVolumes {
    var v: TileVolumes;
    let ndc = tile_ndc(tile, tile_size);
#ifdef HALF_Z
    let mid = half_z_split(near, far);
    v.v0 = tile_volume(ndc, near, mid);
    v.v1 = tile_volume(ndc, mid, far);
#else
    v.v0 = tile_volume(ndc, near, far);
#endif
    return v;
}

// Whether a light (view-space centre `c`, radius `r` > 0) belongs to the near (x) and far
// (y, HALF_Z only) list of a tile with volumes `vols`.
fn volume_hits(vols: TileVolumes, light: u32, c: vec3<f32>, r: f32) -> vec2<bool> {
    var hit = vec2<bool>(false);
    hit.x = sphere_vs_frustum(vols.v0, c, r) && extra_tests(vols.v0, light, c, r);
#ifdef HALF_Z
    hit.y = sphere_vs_frustum(vols.v1, c, r) && extra_tests(vols.v1, light, c, r);
#endif
    return hit;
}

// 2.5D culling: the bin (0..31) of view distance `d` in a tile whose surfaces span
// [near, far] (tiledlight_cull depth_bin). Monotone in `d`, so a surface at a distance
// inside [dist - r, dist + r] lands in a bin of the light's mask: no false negative.
fn depth_bin(d: f32, near: f32, far: f32) -> u32 {
    var inv = 0.0;
    if far > near {
        inv = 32.0 / (far - near);
    }
    // A range within ~1e-37 of empty: everything in bin 0 (the CPU twin's `is_finite`).
    if inv > 3.4e38 {
        inv = 0.0;
    }
    // Not (d - near) * 0 for an empty range: a sample at infinite distance (infinite far
    // plane) would give inf * 0 = NaN, and WGSL leaves max(NaN, 0) undefined.
    let x = select((d - near) * inv, 0.0, inv == 0.0);
    return u32(min(max(x, 0.0), 31.0));
}

// The bins of the distances [lo, hi] as a mask (tiledlight_cull light_depth_mask).
fn depth_mask_between(lo: f32, hi: f32, near: f32, far: f32) -> u32 {
    let a = depth_bin(lo, near, far);
    let b = depth_bin(hi, near, far);
    return (0xffffffffu >> (31u - b)) & (0xffffffffu << a);
}
