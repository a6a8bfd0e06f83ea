//! The material maths of the shading paths, as the CPU twin of `shaders/common/scene.wgsl`
//! (`material_sample` and what it calls): texture-coordinate transforms, the tangent-space
//! normal map, occlusion and emission, and how they enter a pixel's colour. Tests compute
//! their expected pixels with these; every renderer (Forward+, Tiled Deferred's G-buffer and
//! shading, brute force, the blended path) runs the WGSL. Depends on glam only.

use glam::{Vec2, Vec3, Vec4};

/// Texture coordinates through a 2x3 transform given as two rows (`KHR_texture_transform`'s
/// matrix, `tiledlight_scene::UvTransform::rows`): `u' = r0 . (u, v, 1)`, `v' = r1 . (u, v, 1)`.
pub fn transform_uv(rows: [[f32; 3]; 2], uv: Vec2) -> Vec2 {
    let [r0, r1] = rows;
    Vec2::new(r0[0] * uv.x + r0[1] * uv.y + r0[2], r1[0] * uv.x + r1[1] * uv.y + r1[2])
}

/// The shading normal from a tangent-space normal map (glTF's convention): `n` the
/// interpolated vertex normal, `tangent` the interpolated tangent with its bitangent sign in
/// w (`bitangent = w * cross(n, t)`), `texel` the map's linear RGB in [0, 1], `scale` glTF's
/// `normalTexture.scale` (scales x and y). The tangent is re-orthogonalised against the
/// normal first (interpolation bends both). Faces seen from behind flip the result, as
/// they flip the vertex normal.
pub fn normal_from_map(n: Vec3, tangent: Vec4, texel: Vec3, scale: f32) -> Vec3 {
    let n = n.normalize();
    let t = (tangent.truncate() - n * n.dot(tangent.truncate())).normalize_or(n.any_orthonormal_vector());
    let b = n.cross(t) * tangent.w;
    let m = (texel * 2.0 - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
    (t * m.x + b * m.y + n * m.z).normalize_or(n)
}

/// The occlusion factor of an occlusion texel's red channel: `1 + strength (r - 1)`.
pub fn occlusion(texel_r: f32, strength: f32) -> f32 {
    1.0 + strength * (texel_r - 1.0)
}

/// Linear emitted radiance: the emissive factor times its strength
/// (`KHR_materials_emissive_strength`) times the emissive texel (linear RGB, white without
/// a texture).
pub fn emission(factor: Vec3, strength: f32, texel: Vec3) -> Vec3 {
    factor * strength * texel
}

/// Roughness and metalness from their factors and a metallic-roughness texel (linear:
/// roughness in green, metalness in blue; white without a texture).
pub fn roughness_metallic(roughness: f32, metallic: f32, texel: Vec4) -> (f32, f32) {
    (roughness * texel.y, metallic * texel.z)
}

/// The part of a pixel's colour no light adds: ambient light on the albedo, scaled by the
/// occlusion (glTF applies occlusion to indirect light only), plus emission. Every lit
/// renderer starts its light loop from this.
pub fn unlit_term(ambient: Vec3, albedo: Vec3, occlusion: f32, emission: Vec3) -> Vec3 {
    ambient * albedo * occlusion + emission
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_map_keeps_the_normal_and_tilts_follow_the_tangent_frame() {
        let n = Vec3::Z;
        let t = Vec4::new(1.0, 0.0, 0.0, 1.0);
        assert!(normal_from_map(n, t, Vec3::new(0.5, 0.5, 1.0), 1.0).abs_diff_eq(n, 1e-6));
        // Texel x = 1: the normal leans 45 degrees towards +t.
        let tilted = normal_from_map(n, t, Vec3::new(1.0, 0.5, 1.0), 1.0);
        assert!(tilted.abs_diff_eq(Vec3::new(1.0, 0.0, 1.0).normalize(), 1e-6), "{tilted}");
        // y leans towards the bitangent, w * cross(n, t) = +y (w = 1) or -y (w = -1).
        let up = normal_from_map(n, t, Vec3::new(0.5, 1.0, 1.0), 1.0);
        assert!(up.y > 0.7, "{up}");
        let down = normal_from_map(n, Vec4::new(1.0, 0.0, 0.0, -1.0), Vec3::new(0.5, 1.0, 1.0), 1.0);
        assert!(down.y < -0.7, "{down}");
        // Scale 0 flattens the map; a tangent not perpendicular to n is straightened.
        assert!(normal_from_map(n, t, Vec3::new(1.0, 0.0, 1.0), 0.0).abs_diff_eq(n, 1e-6));
        let bent = normal_from_map(n, Vec4::new(1.0, 0.0, 1.0, 1.0), Vec3::new(1.0, 0.5, 1.0), 1.0);
        assert!(bent.abs_diff_eq(tilted, 1e-6), "{bent}");
    }

    #[test]
    fn occlusion_emission_and_factors() {
        assert_eq!(occlusion(0.25, 1.0), 0.25);
        assert_eq!(occlusion(0.25, 0.0), 1.0);
        assert_eq!(occlusion(0.25, 0.5), 0.625);
        assert_eq!(emission(Vec3::new(1.0, 0.5, 0.0), 4.0, Vec3::splat(0.5)), Vec3::new(2.0, 1.0, 0.0));
        assert_eq!(roughness_metallic(0.5, 1.0, Vec4::new(9.0, 0.5, 0.25, 9.0)), (0.25, 0.25));
        assert_eq!(unlit_term(Vec3::splat(0.5), Vec3::ONE, 0.5, Vec3::X), Vec3::new(1.25, 0.25, 0.25));
        let rot90 = [[0.0, -1.0, 0.5], [1.0, 0.0, 0.0]];
        assert_eq!(transform_uv(rot90, Vec2::new(1.0, 0.0)), Vec2::new(0.5, 1.0));
    }
}
