// The visibility buffer's surface (issue 28), what the G-buffer gives Tiled Deferred: per
// sample, the ID written by depth_prepass.wgsl with IDS names an instance and a triangle of its
// mesh; the triangle's three vertices are fetched from the scene's vertex and index buffers
// (storage-readable), transformed as the raster pass transformed them, and intersected with
// the sample's ray by perspective-correct barycentrics (common/visibility.wgsl), which
// interpolate the world position, normal, tangent and texture coordinates. Textures are
// sampled with explicit gradients: the barycentrics' one-pixel steps
// at the 2x2 quad's first pixel, the coarse derivatives the hardware's fragment stage
// takes (measured on lavapipe and the H200: tests/tests/visibility.rs). The material is
// common/scene.wgsl's material_at, as every raster pass evaluates it.
//
// One dispatch shades every material: a material's textures are per-pixel data in the
// texture arrays (common/material_textures.wgsl), so the material count does not matter.
// Included by common/deferred_shade.wgsl with VISIBILITY; bindings in
// crates/visibility/src/shading.rs (VISIBILITY_GROUP).
#include "common/scene.wgsl"
#include "common/visibility.wgsl"

#ifdef MSAA
@group(1) @binding(3) var vis_ids: texture_multisampled_2d<u32>;
#else
@group(1) @binding(3) var vis_ids: texture_2d<u32>;
#endif
// The scene's merged index buffer and vertex attributes (crates/gpu/src/scene_gpu.rs).
@group(1) @binding(26) var<storage, read> vis_indices: array<u32>;
// Positions and normals are tightly packed xyz (12 bytes a vertex).
@group(1) @binding(27) var<storage, read> vis_positions: array<f32>;
@group(1) @binding(28) var<storage, read> vis_normals: array<f32>;
@group(1) @binding(29) var<storage, read> vis_uvs: array<vec2<f32>>;
#ifdef NORMAL_MAP
@group(1) @binding(30) var<storage, read> vis_tangents: array<vec4<f32>>;
#endif
#ifdef UV1
@group(1) @binding(31) var<storage, read> vis_uvs1: array<vec2<f32>>;
#endif
// Low bits of an ID holding the triangle (depth_prepass.wgsl with IDS; IdLayout::triangle_bits).
override TRIANGLE_BITS: u32 = 16u;
// The clear value: no triangle (tiledlight_cull::visibility::NO_TRIANGLE).
const VIS_NO_TRIANGLE: u32 = 0xffffffffu;

// The ID of sample `s` of pixel `p` (mip level 0 without MSAA, as load_depth reads).
fn vis_id(p: vec2<u32>, s: u32) -> u32 {
    return textureLoad(vis_ids, p, s).x;
}

fn vis_instance(id: u32) -> u32 {
    return select(id >> TRIANGLE_BITS, 0u, TRIANGLE_BITS >= 32u);
}

fn vis_triangle(id: u32) -> u32 {
    return select(id & ((1u << TRIANGLE_BITS) - 1u), id, TRIANGLE_BITS >= 32u);
}

fn vis_position(v: u32) -> vec3<f32> {
    return vec3<f32>(vis_positions[3u * v], vis_positions[3u * v + 1u], vis_positions[3u * v + 2u]);
}

fn vis_normal(v: u32) -> vec3<f32> {
    return vec3<f32>(vis_normals[3u * v], vis_normals[3u * v + 1u], vis_normals[3u * v + 2u]);
}

fn vis_mix2(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, w: vec3<f32>) -> vec2<f32> {
    return a * w.x + b * w.y + c * w.z;
}

fn vis_mix3(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    return a * w.x + b * w.y + c * w.z;
}

// The surface of triangle `id` where the ray through window position `at` (pixels) meets
// it; pixel `p` is the one shaded (its quad gives the texture gradients).
fn vis_surface(p: vec2<u32>, id: u32, at: vec2<f32>) -> GSample {
    var g: GSample;
    g.sky = id == VIS_NO_TRIANGLE;
    if g.sky {
        return g;
    }
    let inst = instances[vis_instance(id)];
    let first = inst.first_index + 3u * vis_triangle(id);
    let vi = vec3<u32>(
        u32(i32(vis_indices[first]) + inst.base_vertex),
        u32(i32(vis_indices[first + 1u]) + inst.base_vertex),
        u32(i32(vis_indices[first + 2u]) + inst.base_vertex),
    );
    // As transform_position: world, then clip.
    let w0 = inst.model * vec4<f32>(vis_position(vi.x), 1.0);
    let w1 = inst.model * vec4<f32>(vis_position(vi.y), 1.0);
    let w2 = inst.model * vec4<f32>(vis_position(vi.z), 1.0);
    let c0 = view.world_to_clip * w0;
    let c1 = view.world_to_clip * w1;
    let c2 = view.world_to_clip * w2;
    let size = vec2<f32>(view.screen);
    let b = vis_barycentrics(c0, c1, c2, pixel_to_ndc(at), size);
    if !b.valid {
        // The ray lies in the triangle's plane (edge-on, a zero-area coverage the raster
        // cannot give): nothing to shade, drawn as sky.
        g.sky = true;
        return g;
    }
    // The rasteriser's winding: counter-clockwise in NDC is the front (wgpu FrontFace::Ccw),
    // the sign of det(c0.xyw, c1.xyw, c2.xyw).
    let front = dot(cross(c1.xyw - c0.xyw, c2.xyw - c0.xyw), c0.xyw) > 0.0;
    // Gradients as the fragment stage's coarse derivatives: the steps at the quad's first
    // pixel centre.
    let q = vis_barycentrics(c0, c1, c2, pixel_to_ndc(vec2<f32>(p & vec2<u32>(~1u)) + 0.5), size);
    let lambda = b.lambda;
    g.world = vis_mix3(w0.xyz, w1.xyz, w2.xyz, lambda);
    g.dist = -(view.world_to_view * vec4<f32>(g.world, 1.0)).z;
    let n = inst.normal_matrix * vis_mix3(vis_normal(vi.x), vis_normal(vi.y), vis_normal(vi.z), lambda);
    let uv_a = vis_uvs[vi.x];
    let uv_b = vis_uvs[vi.y];
    let uv_c = vis_uvs[vi.z];
    var sets: UvSets;
    sets.uv0 = vis_mix2(uv_a, uv_b, uv_c, lambda);
    sets.dx0 = vis_mix2(uv_a, uv_b, uv_c, q.ddx);
    sets.dy0 = vis_mix2(uv_a, uv_b, uv_c, q.ddy);
#ifdef UV1
    let t_a = vis_uvs1[vi.x];
    let t_b = vis_uvs1[vi.y];
    let t_c = vis_uvs1[vi.z];
    sets.uv1 = vis_mix2(t_a, t_b, t_c, lambda);
    sets.dx1 = vis_mix2(t_a, t_b, t_c, q.ddx);
    sets.dy1 = vis_mix2(t_a, t_b, t_c, q.ddy);
#else
    sets.uv1 = sets.uv0;
    sets.dx1 = sets.dx0;
    sets.dy1 = sets.dy0;
#endif
#ifdef NORMAL_MAP
    let t = vis_mix3(vis_tangents[vi.x].xyz, vis_tangents[vi.y].xyz, vis_tangents[vi.z].xyz, lambda);
    let tangent = vec4<f32>((inst.model * vec4<f32>(t, 0.0)).xyz, vis_tangents[vi.x].w * inst.det_sign);
#else
    let tangent = vec4<f32>(0.0);
#endif
    let ms = material_at(inst.material, sets, material_color(inst.material, sets), n, tangent, front);
    g.normal = ms.normal;
    g.surface = Surface(ms.base, ms.roughness, ms.metallic);
    g.unlit = unlit_term(lighting.ambient, ms);
    return g;
}

// Sample `s` of pixel `p`, at the sample's position.
fn load_gsample(p: vec2<u32>, s: u32) -> GSample {
    return vis_surface(p, vis_id(p, s), vec2<f32>(p) + sample_position(s));
}

#ifdef MSAA
// Two IDs in a pixel make it an edge only where their surfaces differ (the pass settings'
// row `surface-edges`, on by default): another material, sky, or a sample off sample 0's
// tangent plane or turned from its normal beyond the edge test's thresholds (Tiled
// Deferred's test, common/deferred_shade.wgsl). Off: any two IDs do. A floor split into
// triangles, or a finely tessellated smooth surface, is then shaded once a pixel, as the
// G-buffer's test shades it.
override SURFACE_EDGES: bool = true;

// A pixel whose samples all hold one ID is shaded once; two IDs make it an edge where their
// surfaces differ (SURFACE_EDGES).
fn is_edge(p: vec2<u32>, g0: GSample) -> bool {
    let id0 = vis_id(p, 0u);
    for (var s = 1u; s < SAMPLES; s++) {
        let id = vis_id(p, s);
        if id == id0 {
            continue;
        }
        if !SURFACE_EDGES || g0.sky || id == VIS_NO_TRIANGLE {
            return true;
        }
        // Another material shades differently even on one plane: a real edge.
        if instances[vis_instance(id)].material != instances[vis_instance(id0)].material {
            return true;
        }
        let g = vis_surface(p, id, vec2<f32>(p) + sample_position(s));
        if g.sky || abs(dot(g.world - g0.world, g0.normal)) > EDGE_DISTANCE * g0.dist
            || dot(g.normal, g0.normal) < EDGE_COS {
            return true;
        }
    }
    return false;
}

// The pixel's class and surface, each surface reconstructed once: a pixel whose samples
// all hold one ID (nearly every pixel) is no edge and its triangle is met at the pixel
// centre (the point Forward+ shades) without first reconstructing sample 0; otherwise
// sample 0's surface decides the edge test, and only a pixel the test finds on one surface
// is reconstructed again, at its centre.
fn classify_pixel(p: vec2<u32>) -> PixelClass {
    let id0 = vis_id(p, 0u);
    let centre = vec2<f32>(p) + 0.5;
    var one_id = true;
    for (var s = 1u; s < SAMPLES; s++) {
        one_id = one_id && vis_id(p, s) == id0;
    }
    if one_id {
        return PixelClass(vis_surface(p, id0, centre), false);
    }
    let g0 = vis_surface(p, id0, vec2<f32>(p) + sample_position(0u));
    if is_edge(p, g0) {
        return PixelClass(g0, true);
    }
    return PixelClass(vis_surface(p, id0, centre), false);
}
#endif
