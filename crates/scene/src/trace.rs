//! The geometry the traced reference's shadow rays see ([`TraceGeometry::of`]): every
//! triangle of the opaque and alpha-masked instances in world space, in the f64-exact SAH
//! hierarchy of `tiledlight_cull::raycast` and its flattened GPU form
//! (`tiledlight_cull::trace`), and the alpha masks of the masked materials.
//!
//! What casts, as the other methods' shadow maps decide it: opaque and masked instances,
//! never alpha-blended ones (their draws go only through the blended path). A masked
//! material blocks where base colour alpha times its texture's alpha (mip 0, nearest texel,
//! the sampler's wrap modes, after `KHR_texture_transform`) reaches the cutoff; without a
//! texture it blocks everywhere or nowhere. Depends on tiledlight-cull and the scene model.

use glam::{Vec2, Vec3};
use tiledlight_cull::raycast::Triangles;
use tiledlight_cull::trace::{FlatBvh, MaskWrap, Masks, NO_MASK};

use crate::model::{AlphaMode, Scene, Wrap};

/// The alpha masks and, per world triangle (input order), its mask slot and texture
/// coordinates after the texture transform.
#[derive(Clone, Debug, Default)]
pub struct TraceMasks {
    /// The masks' bits.
    pub masks: Masks,
    /// Per triangle, its slot ([`NO_MASK`] for opaque triangles).
    pub slots: Vec<u32>,
    /// Per triangle, its vertices' texture coordinates (zero for opaque triangles).
    pub uvs: Vec<[Vec2; 3]>,
}

impl TraceMasks {
    /// Whether world triangle `id` blocks at barycentrics `(u, v)` (weights of its second
    /// and third vertices): the CPU side of `trace_blocks` in `shaders/common/trace.wgsl`.
    pub fn blocks(&self, id: u32, u: f32, v: f32) -> bool {
        let slot = self.slots[id as usize];
        if slot == NO_MASK {
            return true;
        }
        let [a, b, c] = self.uvs[id as usize];
        self.masks.blocks(slot, a * (1.0 - u - v) + b * u + c * v)
    }
}

/// The shadow rays' geometry of a scene.
pub struct TraceGeometry {
    /// The world triangles (opaque and masked instances, input order) in the f64 hierarchy:
    /// the CPU reference (`Triangles::occluded_where`).
    pub bvh: Triangles,
    /// The flattened hierarchy the GPU traverses.
    pub flat: FlatBvh,
    /// The masks, when some instance's material is alpha-masked.
    pub masks: Option<TraceMasks>,
    /// The scene's size as the rays' offset bounds it (`tiledlight_cull::trace::scene_scale`
    /// of these triangles).
    pub scale: f32,
}

fn mask_wrap(w: Wrap) -> MaskWrap {
    match w {
        Wrap::Repeat => MaskWrap::Repeat,
        Wrap::ClampToEdge => MaskWrap::Clamp,
        Wrap::MirroredRepeat => MaskWrap::Mirror,
    }
}

impl TraceGeometry {
    /// The triangles [`Self::of`] would build over: every instance's but the blended ones'
    /// (counted without building, so a caller can refuse a scene before the seconds and the
    /// memory of the build).
    pub fn casting_triangles(scene: &Scene) -> u64 {
        scene
            .instances
            .iter()
            .filter(|i| scene.materials.get(i.material).is_some_and(|m| !matches!(m.alpha_mode, AlphaMode::Blend)))
            .filter_map(|i| scene.meshes.get(i.mesh))
            .map(|m| (m.indices.len() / 3) as u64)
            .sum()
    }

    /// Builds the hierarchy over `scene`'s casting instances (about a second a million
    /// triangles).
    pub fn of(scene: &Scene) -> Self {
        let mut tris = Vec::new();
        let mut masks = TraceMasks::default();
        // Per material, its slot once made.
        let mut material_slot: Vec<Option<u32>> = vec![None; scene.materials.len()];
        let mut any_mask = false;
        for inst in &scene.instances {
            let (Some(mesh), Some(mat)) = (scene.meshes.get(inst.mesh), scene.materials.get(inst.material)) else {
                continue;
            };
            let slot = match mat.alpha_mode {
                AlphaMode::Blend => continue,
                AlphaMode::Opaque => NO_MASK,
                AlphaMode::Mask { cutoff } => {
                    any_mask = true;
                    *material_slot[inst.material].get_or_insert_with(|| {
                        let base = mat.base_color[3];
                        match mat
                            .base_color_texture
                            .as_ref()
                            .and_then(|t| scene.textures.get(t.texture).map(|x| (t, x)))
                        {
                            Some((tr, tex)) => masks.masks.add(
                                (tex.width, tex.height),
                                (mask_wrap(tr.sampler.wrap_u), mask_wrap(tr.sampler.wrap_v)),
                                |x, y| {
                                    let a = tex.rgba8[((y * tex.width + x) * 4 + 3) as usize];
                                    base * f32::from(a) / 255.0 >= cutoff
                                },
                            ),
                            // No texture: blocks everywhere (an opaque slot) or nowhere.
                            None if base >= cutoff => NO_MASK,
                            None => masks.masks.add((0, 0), (MaskWrap::Repeat, MaskWrap::Repeat), |_, _| false),
                        }
                    })
                }
            };
            let world: Vec<Vec3> =
                mesh.positions.iter().map(|p| inst.transform.transform_point3(Vec3::from_array(*p))).collect();
            let set = mat.base_color_texture.as_ref().map(|t| (mesh.uv_set(t.tex_coord), &t.transform));
            for tri in mesh.indices.chunks_exact(3) {
                let (Some(a), Some(b), Some(c)) =
                    (world.get(tri[0] as usize), world.get(tri[1] as usize), world.get(tri[2] as usize))
                else {
                    continue;
                };
                tris.push([*a, *b, *c]);
                masks.slots.push(slot);
                let uv = |i: u32| match (slot, set) {
                    (NO_MASK, _) | (_, None) => Vec2::ZERO,
                    (_, Some((uvs, transform))) => {
                        Vec2::from_array(transform.apply(uvs.get(i as usize).copied().unwrap_or([0.0, 0.0])))
                    }
                };
                masks.uvs.push([uv(tri[0]), uv(tri[1]), uv(tri[2])]);
            }
        }
        let scale = tiledlight_cull::trace::scene_scale(&tris);
        let bvh = Triangles::new(tris);
        let flat = FlatBvh::new(&bvh);
        Self { bvh, flat, masks: any_mask.then_some(masks), scale }
    }

    /// Whether world triangle `id` blocks at barycentrics `(u, v)` (always, without masks).
    pub fn blocks(&self, id: u32, u: f32, v: f32) -> bool {
        self.masks.as_ref().is_none_or(|m| m.blocks(id, u, v))
    }

    /// The shadow ray's offset at `p` in this scene (`tiledlight_cull::trace::surface_eps`).
    pub fn eps(&self, p: Vec3) -> f32 {
        tiledlight_cull::trace::surface_eps(p, self.scale)
    }

    /// The f64 reference's answer for the segment, masks honoured.
    pub fn occluded(&self, from: Vec3, to: Vec3, eps: f32) -> bool {
        self.bvh.occluded_where(from, to, eps, &|i, u, v| self.blocks(i as u32, u, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_scene;

    /// The courtyard: blended glass is left out, everything else is in, and a segment
    /// through a pillar is blocked while one above the roofs is not.
    #[test]
    fn the_courtyard_casts_what_shadow_maps_draw() {
        let opts = crate::DefaultSceneOptions { grid_objects: 8, transparent_objects: 2, ..Default::default() };
        let scene = default_scene(&opts).expect("the courtyard builds");
        let g = TraceGeometry::of(&scene);
        let blended: u64 = scene
            .instances
            .iter()
            .filter(|i| matches!(scene.materials[i.material].alpha_mode, AlphaMode::Blend))
            .map(|i| scene.meshes[i.mesh].indices.len() as u64 / 3)
            .sum();
        assert!(blended > 0, "two glass grid objects");
        assert_eq!(g.bvh.len() as u64 + blended, scene.world_triangles().len() as u64);
        assert_eq!(g.flat.triangles.len(), g.bvh.len());
        // Counted without building: the same number.
        assert_eq!(TraceGeometry::casting_triangles(&scene), g.bvh.len() as u64);
        let b = scene.bounds;
        let (lo, hi) = (b.min, b.max);
        let above = hi.y + 1.0;
        assert!(!g.occluded(Vec3::new(lo.x, above, lo.z), Vec3::new(hi.x, above, hi.z), 0.0));
        // Straight through the whole scene at mid height, corner to corner: walls block.
        let mid = lo.y * 0.5 + hi.y * 0.5;
        assert!(g.occluded(Vec3::new(lo.x - 1.0, mid, lo.z - 1.0), Vec3::new(hi.x + 1.0, mid, hi.z + 1.0), 0.0));
    }
}
