// The forward shading pass's body, shared by its entry files (one per light loop:
// forward.wgsl, forward_clustered.wgsl, brute_force.wgsl): each fragment loops over its
// light-grid list (Forward+: its tile's, its half's with HALF_Z, its cluster's with
// CLUSTERED), or over every light (BRUTE_FORCE, the reference renderer), with the shared
// BRDF, into linear HDR. The depth test is Equal against the pre-pass, so each pixel is
// shaded once.
// Alpha-masked draws (ALPHA_MASK) discard as the pre-pass did: depth Equal alone would let a
// masked-out texel shade a coplanar surface behind it.
// The material defines (TEXTURES NORMAL_MAP UV1) are common/scene.wgsl's.
// With VPLS every fragment also sums the virtual point lights (tiledlight-vpl;
// common/vpl.wgsl vpl_light): Forward+ those of its tile's list in the VPLs' own light grid
// (one list per tile), brute force all min(count, cap) of them, the count read from the
// GPU's generation counter.
#include "common/scene.wgsl"
#include "common/lights_group.wgsl"

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    return transform_vertex(v);
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let ms = material_sample(in, front);
    let n = ms.normal;
    let v = view_vector(in.world_pos);
    let s = Surface(ms.base, ms.roughness, ms.metallic);
    var color = unlit_term(lighting.ambient, ms);
#ifdef BRUTE_FORCE
    for (var i = 0u; i < lighting.num_lights; i++) {
        color += shade_light(i, in.world_pos, n, v, s);
    }
#else
    let list = pixel_list(vec2<u32>(in.clip.xy), view_distance(in.clip.z));
    for (var i = 0u; i < list.count; i++) {
        color += shade_light(light_indices[list.first + i], in.world_pos, n, v, s);
    }
#endif
#ifdef VPLS
    let physical = vpl_shading.model != 0u;
#ifdef BRUTE_FORCE
    let num_vpls = min(vpl_count, vpl_shading.cap);
    for (var i = 0u; i < num_vpls; i++) {
        let vl = vpl_light(vpls[i], in.world_pos, physical, vpl_shading.distance_clamp);
        color += brdf_cos(n, v, vl.l, s) * vl.factor;
    }
#else
    let vtile = vec2<u32>(in.clip.xy) / vpl_grid.header.tile_size;
    let vlist = light_list(vpl_grid.lists[vtile.y * vpl_grid.header.tiles.x + vtile.x], vpl_grid.header.capacity);
    for (var i = 0u; i < vlist.count; i++) {
        let vl = vpl_light(vpls[vpl_indices[vlist.first + i]], in.world_pos, physical, vpl_shading.distance_clamp);
        color += brdf_cos(n, v, vl.l, s) * vl.factor;
    }
#endif
#endif
    return vec4<f32>(color, 1.0);
}
