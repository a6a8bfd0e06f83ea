// Tiled Deferred's shading, shared by its kernels (the tile cull-and-shade kernel,
// common/deferred_tile.wgsl behind deferred.wgsl and deferred_msaa.wgsl, and the
// assigned-list kernel, common/assigned_shade.wgsl behind deferred_assigned.wgsl) and by the
// visibility buffer's (visibility.wgsl, visibility_msaa.wgsl): with VISIBILITY the surface
// comes from the triangle IDs instead of a G-buffer (common/visibility_surface.wgsl defines
// load_gsample and classify_pixel) and the light grid is group 3. Group 1 (the G-buffer,
// the lights, the HDR output, shadows, VPLs; crates/deferred/src/shading.rs), the light
// grid (group 2, written by the tile kernel, read by both), one G-buffer sample's loading
// and shading (the including kernel defines `shade_lights_at`, its light loop), and the
// tile's pixel loop with the MSAA edge machinery.
//
// With MSAA the G-buffer is multisampled (SAMPLES per pixel). Each pixel first runs the edge
// test (is_edge); a pixel whose samples all lie on one surface is shaded once, at its centre
// on that surface, straight into the HDR image. Edge pixels are queued in workgroup
// memory, and once every pixel is classified the tile's threads are redistributed over the
// queued pixels' remaining samples. An edge pixel's samples go to the oversized `samples_out`
// texture (SAMPLES_X x SAMPLES_Y texels a pixel) and its position to a global edge list,
// which deferred_resolve.wgsl averages into the HDR image (an indirect dispatch sized here).
//
// With EXTRA_RTS the stress knob's extra G-buffer targets (EXTRA_TARGETS of them, all
// white) are read and multiplied into the albedo. With EMISSION (a scene with emissive or
// occlusion-mapped materials) the G-buffer's emission target holds each pixel's emission
// (rgb) and occlusion (alpha): the unlit part is ambient x albedo x occlusion + emission, as
// Forward+ computes it (common/scene.wgsl unlit_term). Normal maps and metallic-roughness
// textures need nothing here: the G-buffer holds their result.
//
// With TRACED (the traced reference, common/traced_shade.wgsl) there is no light grid and
// every VPL is summed, as brute force sums them.
//
// With VPLS each pixel also sums the virtual point lights of its tile's list in the VPLs'
// own light grid (culled before this pass by the lights' culling pass; tiledlight-vpl,
// common/vpl.wgsl vpl_light), as Forward+ does. The shadow atlas (15-17) and the VPLs
// (19-22) have the binding numbers of the forward passes' lights group
// (common/lights_group.wgsl).
#include "common/depth_range.wgsl"
#ifndef TRACED
#include "common/light_grid_rw.wgsl"
#endif
#include "common/shade.wgsl"

@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
@group(1) @binding(2) var<uniform> lighting: Lighting;
#ifdef VISIBILITY
// The visibility buffer's surface instead of a G-buffer.
#include "common/visibility_surface.wgsl"
#else
#include "common/gbuffer_texel.wgsl"
#ifdef MSAA
alias GTexture = texture_multisampled_2d<f32>;
alias GSurfaceTexture = texture_multisampled_2d<u32>;
#else
alias GTexture = texture_2d<f32>;
alias GSurfaceTexture = texture_2d<u32>;
#endif

// The packed surface (common/gbuffer_texel.wgsl) and its base colour's decoding table:
// every 8-bit sRGB code in a 256 x 1 Rgba8UnormSrgb texture, so the base colour decodes
// through the texture unit exactly as the material textures did (tiledlight_deferred::gbuffer
// GBuffer::srgb_lut_view says why).
@group(1) @binding(3) var gbuffer_surface: GSurfaceTexture;
@group(1) @binding(4) var gbuffer_srgb_lut: texture_2d<f32>;
// The stress knob's extra targets read (1 to 3; a pipeline constant, so the count is not a
// variant): with EXTRA_RTS all three bindings exist, those past the count bound to the first
// target and never read.
override EXTRA_TARGETS: u32 = 0u;
#ifdef EXTRA_RTS
@group(1) @binding(5) var gbuffer_extra0: GTexture;
@group(1) @binding(10) var gbuffer_extra1: GTexture;
@group(1) @binding(11) var gbuffer_extra2: GTexture;
#endif
#ifdef EMISSION
@group(1) @binding(18) var gbuffer_emission: GTexture;
#endif
#endif
@group(1) @binding(6) var<storage, read> shading_lights: array<ShadingLight>;
#ifdef SPOT_LIGHTS
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#else
#ifdef SPOT_CONE
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#endif
#endif
#ifdef COARSE
// Cell counts, then COARSE_CAPACITY indices per cell (see cull_coarse.wgsl).
@group(1) @binding(8) var<storage, read> cell_lists: array<u32>;
#endif
@group(1) @binding(9) var output: texture_storage_2d<rgba16float, write>;
#ifdef SHADOWS
// The shadow atlas (common/shadow.wgsl).
@group(1) @binding(15) var shadow_atlas: texture_depth_2d_array;
@group(1) @binding(16) var shadow_sampler: sampler_comparison;
@group(1) @binding(17) var<storage, read> shadow_faces: array<ShadowFace>;
#endif
#ifdef VPLS
#include "common/vpl.wgsl"
@group(1) @binding(19) var<storage, read> vpls: array<Vpl>;
@group(1) @binding(20) var<uniform> vpl_shading: VplShading;
#ifdef TRACED
// The traced reference sums every VPL, as brute force does: the generation's counter.
@group(1) @binding(23) var<storage, read> vpl_count: u32;
#else
#include "common/light_grid.wgsl"
@group(1) @binding(21) var<storage, read> vpl_grid: LightGrid;
@group(1) @binding(22) var<storage, read> vpl_indices: array<u32>;
#endif
#endif
// The light grid (crates/gpu/src/light_grid.rs); group 3 in the visibility kernels, whose
// group 2 is the material textures (common/scene.wgsl). The traced reference has none.
#ifdef VISIBILITY
#ifndef TRACED
@group(3) @binding(0) var<storage, read_write> light_grid: LightGridRw;
@group(3) @binding(1) var<storage, read_write> light_indices: array<u32>;
#endif
#else
@group(2) @binding(0) var<storage, read_write> light_grid: LightGridRw;
@group(2) @binding(1) var<storage, read_write> light_indices: array<u32>;
#endif

#ifdef MSAA
// Texels per pixel of `samples_out` across and down (SAMPLES_X * SAMPLES_Y = SAMPLES).
override SAMPLES_X: u32 = 2u;
// The edge test's thresholds (tiledlight_deferred::EdgeTest): a sample off sample 0's
// tangent plane by more than EDGE_DISTANCE times its view distance, or whose normal turns
// more than acos(EDGE_COS) from sample 0's, makes the pixel an edge.
override EDGE_DISTANCE: f32 = 0.01;
override EDGE_COS: f32 = 0.9848;
// Pixels a tile holds (TILE_SIZE^2): the edge queue's size.
override TILE_PIXELS: u32 = 256u;
@group(1) @binding(12) var samples_out: texture_storage_2d<rgba16float, write>;
// Edge pixels of the frame, packed x | y << 16, for the resolve.
@group(1) @binding(13) var<storage, read_write> edge_list: array<u32>;
// The resolve's indirect dispatch (x, y, z) and the frame's edge-pixel count.
@group(1) @binding(14) var<storage, read_write> edge_args: array<atomic<u32>, 4>;

var<workgroup> wg_edge_count: atomic<u32>;
var<workgroup> wg_edge_first: u32;
var<workgroup> wg_edges: array<u32, TILE_PIXELS>;

// Standard sample positions (Vulkan, D3D and Metal agree), in pixels from the pixel's corner.
fn sample_position(s: u32) -> vec2<f32> {
    if SAMPLES == 2u {
        return select(vec2<f32>(0.25, 0.25), vec2<f32>(0.75, 0.75), s == 0u);
    }
    if SAMPLES == 4u {
        var p4 = array<vec2<f32>, 4>(vec2(0.375, 0.125), vec2(0.875, 0.375), vec2(0.125, 0.625), vec2(0.625, 0.875));
        return p4[s];
    }
    var p8 = array<vec2<f32>, 8>(
        vec2(0.5625, 0.3125), vec2(0.4375, 0.6875), vec2(0.8125, 0.5625), vec2(0.3125, 0.1875),
        vec2(0.1875, 0.8125), vec2(0.0625, 0.4375), vec2(0.6875, 0.9375), vec2(0.9375, 0.0625),
    );
    return p8[s];
}

fn sample_texel(p: vec2<u32>, s: u32) -> vec2<u32> {
    return p * vec2<u32>(SAMPLES_X, SAMPLES / SAMPLES_X) + vec2<u32>(s % SAMPLES_X, s / SAMPLES_X);
}
#else
fn sample_position(s: u32) -> vec2<f32> {
    return vec2<f32>(0.5);
}
#endif

// What the G-buffer holds for one sample (sample 0 without MSAA), with its world position.
struct GSample {
    sky: bool,
    dist: f32,
    world: vec3<f32>,
    normal: vec3<f32>,
    surface: Surface,
    // The unlit part of the colour: ambient x albedo (x occlusion) (+ emission).
    unlit: vec3<f32>,
}

#ifndef VISIBILITY
// `textureLoad(t, p, k)` reads mip level k of a plain texture and sample k of a
// multisampled one: with k = s (0 without MSAA) the same code serves both.
fn load_gsample(p: vec2<u32>, s: u32) -> GSample {
    var g: GSample;
    let d = load_depth(p, s);
    g.sky = d <= 0.0;
    if g.sky {
        return g;
    }
    g.dist = view_distance(d);
    let view_pos = view_point_at(pixel_to_ndc(vec2<f32>(p) + sample_position(s)), g.dist);
    g.world = (view.view_to_world * vec4<f32>(view_pos, 1.0)).xyz;
    let packed = textureLoad(gbuffer_surface, p, s);
    let t = unpack_gtexel(packed);
    let codes = gtexel_base_codes(packed);
    var albedo = vec3<f32>(
        textureLoad(gbuffer_srgb_lut, vec2<u32>(codes.r, 0u), 0).r,
        textureLoad(gbuffer_srgb_lut, vec2<u32>(codes.g, 0u), 0).r,
        textureLoad(gbuffer_srgb_lut, vec2<u32>(codes.b, 0u), 0).r,
    );
#ifdef EXTRA_RTS
    albedo *= textureLoad(gbuffer_extra0, p, s).rgb;
    if EXTRA_TARGETS >= 2u {
        albedo *= textureLoad(gbuffer_extra1, p, s).rgb;
    }
    if EXTRA_TARGETS >= 3u {
        albedo *= textureLoad(gbuffer_extra2, p, s).rgb;
    }
#endif
    g.normal = t.normal;
    g.surface = Surface(albedo, t.roughness, t.metallic);
#ifdef EMISSION
    let eo = textureLoad(gbuffer_emission, p, s);
    g.unlit = lighting.ambient * albedo * eo.a + eo.rgb;
#else
    g.unlit = lighting.ambient * albedo;
#endif
    return g;
}
#endif

// Linear HDR of one G-buffer sample of pixel `p`: its lights, and with VPLS its tile's VPLs.
fn shade_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    var color = shade_lights_at(g, p);
#ifdef VPLS
    if !g.sky {
        let v = view_vector(g.world);
        let physical = vpl_shading.model != 0u;
#ifdef TRACED
        let num_vpls = min(vpl_count, vpl_shading.cap);
        for (var i = 0u; i < num_vpls; i++) {
            let vl = vpl_light(vpls[i], g.world, physical, vpl_shading.distance_clamp);
            color += brdf_cos(g.normal, v, vl.l, g.surface) * vl.factor;
        }
#else
        let tile = p / vpl_grid.header.tile_size;
        let l = light_list(vpl_grid.lists[tile.y * vpl_grid.header.tiles.x + tile.x], vpl_grid.header.capacity);
        for (var i = 0u; i < l.count; i++) {
            let vl = vpl_light(vpls[vpl_indices[l.first + i]], g.world, physical, vpl_shading.distance_clamp);
            color += brdf_cos(g.normal, v, vl.l, g.surface) * vl.factor;
        }
#endif
    }
#endif
    return color;
}

#ifdef MSAA
// A pixel as the tile loop shades it: an edge (shaded per sample; `g` is sample 0) or not
// (shaded once; `g` is the surface at the pixel centre).
struct PixelClass {
    g: GSample,
    edge: bool,
}

#ifndef VISIBILITY
// The G-buffer's pixel: sample 0, and the edge test against it.
fn classify_pixel(p: vec2<u32>) -> PixelClass {
    let g0 = load_gsample(p, 0u);
    if is_edge(p, g0) {
        return PixelClass(g0, true);
    }
    return PixelClass(at_pixel_centre(p, g0), false);
}

// A non-edge pixel's samples lie on one plane: its shading point is where the pixel-centre
// ray meets that plane (sample 0's tangent plane), the point Forward+ and the no-MSAA path
// shade, rather than sample 0's own position up to 0.4 px away.
fn at_pixel_centre(p: vec2<u32>, g: GSample) -> GSample {
    if g.sky {
        return g;
    }
    let ndc = pixel_to_ndc(vec2<f32>(p) + 0.5);
    // The ray's point at view distance 0 (the eye, or the ortho image plane) and its step
    // per unit of view distance.
    let o = view_point_at(ndc, 0.0);
    let d = view_point_at(ndc, 1.0) - o;
    let n = (view.world_to_view * vec4<f32>(g.normal, 0.0)).xyz;
    let p0 = (view.world_to_view * vec4<f32>(g.world, 1.0)).xyz;
    let denom = dot(d, n);
    // Edge-on to the ray (only if the plane test let it through): keep sample 0's point.
    if abs(denom) < 1e-6 * length(d) {
        return g;
    }
    let t = dot(p0 - o, n) / denom;
    if !(t > 0.0) {
        return g;
    }
    var out = g;
    out.dist = t;
    out.world = (view.view_to_world * vec4<f32>(o + t * d, 1.0)).xyz;
    return out;
}

// Scale-independent edge test. Sample 0's normal gives the surface's depth slope across the
// pixel exactly (the role of Lauritzen's screen-space depth derivatives), so instead of a
// depth threshold in scene units each sample is tested against sample 0's tangent plane,
// relative to the view distance: a tilted or distant surface is no edge, a silhouette or
// crease is, at any scene scale. Sky next to a surface is always an edge.
fn is_edge(p: vec2<u32>, g0: GSample) -> bool {
    for (var s = 1u; s < SAMPLES; s++) {
        let g = load_gsample(p, s);
        if g.sky != g0.sky {
            return true;
        }
        if g.sky {
            continue;
        }
        if abs(dot(g.world - g0.world, g0.normal)) > EDGE_DISTANCE * g0.dist || dot(g.normal, g0.normal) < EDGE_COS {
            return true;
        }
    }
    return false;
}
#endif
#endif

// Shades the pixels of the workgroup's tile (TILE_SIZE^2, WG x WG threads) into the HDR
// output; with MSAA, queues the tile's edge pixels and shades their other samples.
fn shade_tile_pixels(wid: vec3<u32>, lid: vec3<u32>, lidx: u32) {
    let origin = wid.xy * TILE_SIZE;
    let steps = TILE_SIZE / WG;
    for (var j = 0u; j < steps; j++) {
        for (var i = 0u; i < steps; i++) {
            let p = origin + lid.xy + vec2<u32>(i, j) * WG;
            if p.x < view.screen.x && p.y < view.screen.y {
#ifdef MSAA
                let c = classify_pixel(p);
                if c.edge {
                    wg_edges[atomicAdd(&wg_edge_count, 1u)] = p.x | (p.y << 16u);
                    textureStore(samples_out, sample_texel(p, 0u), vec4<f32>(shade_at(c.g, p), 1.0));
                    continue;
                }
                textureStore(output, p, vec4<f32>(shade_at(c.g, p), 1.0));
#else
                textureStore(output, p, vec4<f32>(shade_at(load_gsample(p, 0u), p), 1.0));
#endif
            }
        }
    }
#ifdef MSAA
    workgroupBarrier();
    let edges = atomicLoad(&wg_edge_count);
    if lidx == 0u && edges > 0u {
        // Reserve the tile's block of the frame's edge list and grow the resolve's dispatch
        // to cover it (64 pixels a workgroup); the max over tiles is the frame's total.
        let first = atomicAdd(&edge_args[3], edges);
        wg_edge_first = first;
        atomicMax(&edge_args[0], (first + edges + 63u) / 64u);
        atomicMax(&edge_args[1], 1u);
        atomicMax(&edge_args[2], 1u);
    }
    workgroupBarrier();
    let first = wg_edge_first;
    for (var k = lidx; k < edges; k += WG * WG) {
        edge_list[first + k] = wg_edges[k];
    }
    // The queued pixels' other samples, spread over every thread of the tile.
    let per_pixel = SAMPLES - 1u;
    for (var k = lidx; k < edges * per_pixel; k += WG * WG) {
        let packed = wg_edges[k / per_pixel];
        let p = vec2<u32>(packed & 0xffffu, packed >> 16u);
        let s = 1u + k % per_pixel;
        textureStore(samples_out, sample_texel(p, s), vec4<f32>(shade_at(load_gsample(p, s), p), 1.0));
    }
#endif
}
