// Shadow lookup for shadow-casting lights (variant SHADOWS), the GPU side of
// crates/cull/src/shadow.rs (its module doc numbers the steps: atlas, widened faces,
// reversed-Z infinite projection, bias). Included by common/shade.wgsl; the including file
// declares `shadow_atlas: texture_depth_2d_array`, `shadow_sampler: sampler_comparison`
// and `shadow_faces: array<ShadowFace>` (crates/gpu/src/shadow_atlas.rs, GpuShadowFace),
// and sets the override SHADOW_RADIUS (taps each side of the centre: 0, 1, 2).
//
// Casters are the first `num_shadow_points` lights and the first `num_shadow_spots` spots
// (lights num_point_lights..): the light order is the caster flag, so unshadowed lights
// pay one comparison and read nothing.

// ShadowFace is declared in common/lights.wgsl.

override SHADOW_RADIUS: i32 = 2;

// Normal offset in texels per sin(theta), and the cap of the slope factor
// (tiledlight_cull::shadow::{NORMAL_OFFSET_TEXELS, MAX_SLOPE}).
const SHADOW_NORMAL_OFFSET: f32 = 1.0;
const SHADOW_MAX_SLOPE: f32 = 20.0;

// Shadowed lights: the first points and the first spots.
fn casts_shadow(i: u32) -> bool {
    return i < lighting.num_shadow_points
        || (i >= lighting.num_point_lights && i - lighting.num_point_lights < lighting.num_shadow_spots);
}

// Cube face of a direction from the light: the largest axis, ties to x then y
// (tiledlight_cull::shadow::cube_face).
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, d.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, d.y >= 0.0);
    }
    return select(5u, 4u, d.z >= 0.0);
}

// Fraction of caster `i` (at `light_pos`) that reaches surface point `p` with unit normal
// `n`; `l` is the unit direction to the light. The steps and the bias are
// tiledlight_cull::shadow's (biased_position, slope_bias, biased_depth).
fn shadow_visibility(i: u32, light_pos: vec3<f32>, p: vec3<f32>, n: vec3<f32>, l: vec3<f32>) -> f32 {
    let is_point = i < lighting.num_point_lights;
    var face: ShadowFace;
    var depth: f32;
    var texel_per_depth: f32;
    if is_point {
        // A cube face's view depth is the largest axis distance, whichever face; every face
        // of the light has the same texel size.
        let a = abs(p - light_pos);
        depth = max(a.x, max(a.y, a.z));
        texel_per_depth = shadow_faces[6u * i].texel;
    } else {
        face = shadow_faces[6u * lighting.num_shadow_points + (i - lighting.num_point_lights)];
        depth = (face.world_to_clip * vec4<f32>(p, 1.0)).w;
        texel_per_depth = face.texel;
    }
    let texel_world = texel_per_depth * depth;
    let cos_t = clamp(dot(n, l), -1.0, 1.0);
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    let q = p + n * (SHADOW_NORMAL_OFFSET * texel_world * sin_t);
    if is_point {
        // The face of the biased point: its taps stay inside that face's tile.
        face = shadow_faces[6u * i + cube_face(q - light_pos)];
    }
    let clip = face.world_to_clip * vec4<f32>(q, 1.0);
    let ndc = clip.xyz / clip.w;
    var uv = face.uv_origin + (vec2<f32>(0.5) + vec2<f32>(0.5, -0.5) * ndc.xy) * lighting.shadow_tile_uv;
    // Keep the centre in the face's inner rectangle, so no tap reads a neighbouring tile: a
    // point's biased lookup is there already (its face was chosen from it); a spot's can
    // leave it where the bias pushes a point at the cone's rim outward.
    let margin = f32(SHADOW_RADIUS + 1) * lighting.shadow_texel_uv;
    uv = clamp(uv, face.uv_origin + margin, face.uv_origin + lighting.shadow_tile_uv - margin);
    // Slope-scaled bias in view depth: how far a plane's depth moves over the filter's
    // reach as this face sees it (the face's axis is the matrix's w row), plus half a texel.
    let m = face.world_to_clip;
    let axis = vec3<f32>(m[0].w, m[1].w, m[2].w);
    let n_a = dot(n, axis);
    let sin_alpha = sqrt(max(1.0 - n_a * n_a, 0.0));
    let cos_phi = max(dot(-l, axis), 0.0);
    let slope = min(sin_alpha * cos_phi / max(cos_t, 1e-3), SHADOW_MAX_SLOPE);
    let bias = (f32(SHADOW_RADIUS + 1) * slope + 0.5) * texel_world;
    // Reversed-Z, infinite far: depth = near / w, so moving toward the light by `bias` is
    // near / (w - bias). Lit where the receiver is at least as near as the stored depth.
    let w = clip.w;
    let z = ndc.z * w / max(w - bias, w * 1e-3) + lighting.shadow_depth_bias;
    var sum = 0.0;
    for (var y = -SHADOW_RADIUS; y <= SHADOW_RADIUS; y++) {
        for (var x = -SHADOW_RADIUS; x <= SHADOW_RADIUS; x++) {
            let at = uv + vec2<f32>(f32(x), f32(y)) * lighting.shadow_texel_uv;
            sum += textureSampleCompareLevel(shadow_atlas, shadow_sampler, at, face.layer, z);
        }
    }
    let taps = f32((2 * SHADOW_RADIUS + 1) * (2 * SHADOW_RADIUS + 1));
    return sum / taps;
}
