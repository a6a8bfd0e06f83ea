//! Material textures as a few 2D-array textures, so that one bind group serves every
//! material and one dispatch or draw can shade any number of them (issue 46).
//!
//! 1. **Classes.** Every image a material slot reads, in the colour space the slot reads it
//!    in (base colour and emissive sRGB, the data slots linear), is a use
//!    ([`ImageUse`]). Uses of one size and colour space form a class.
//! 2. **Merging.** The shaders bind [`MATERIAL_ARRAYS`] arrays (a fixed number, so the
//!    kernels' variants do not grow with the scene). While the classes (each split into
//!    arrays of at most the adapter's `max_texture_array_layers` layers) need more arrays,
//!    the two classes of one colour space whose merge adds the fewest bytes are merged:
//!    the merged layer is as wide and as tall as the larger of each, and a smaller image
//!    sits in its layer's top-left corner at every mip level. Scenes with at most
//!    [`MATERIAL_ARRAYS`] classes (most glTF scenes: power-of-two images of a few sizes)
//!    pay no padding; [`ArrayPlan::padding_bytes`] says what merging cost.
//! 3. **Sampling.** The shaders read texels with `textureLoad` and filter them themselves
//!    (`shaders/common/material_textures.wgsl`; CPU twin
//!    [`tiledlight_cull::texture`]): wrap modes on integer texel coordinates within the
//!    image's own size (so a padded image repeats, mirrors and clamps exactly as it would
//!    alone), the mip level from the gradients, and the glTF sampler's filters. No sampler
//!    is bound and no array index is non-uniform: a `switch` picks the array binding, the
//!    layer is a coordinate. This works on every adapter (lavapipe and WebGPU have no
//!    non-uniform texture indexing) and gives the same texel weights on all of them.
//!
//! Pure planning ([`ArrayPlan::new`]) plus the upload ([`upload`]). Depends on wgpu, image
//! (mip levels), tiledlight-scene and this crate's error and memory types.

use std::collections::BTreeMap;

use tiledlight_cull::texture::Sampling;

use crate::error::GpuError;
use crate::memory::MemoryReport;

/// The number of array textures the material bind group holds (bindings 0 to 7 of group 2):
/// fixed, so no shader variant depends on a scene's images.
pub const MATERIAL_ARRAYS: usize = 8;

/// One image as material slots read it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ImageUse {
    /// Read as sRGB colour (decoded to linear when loaded) rather than linear data.
    pub srgb: bool,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// One array texture of the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ArraySpec {
    /// sRGB or linear texels.
    pub srgb: bool,
    /// Layer width (the widest image it holds).
    pub width: u32,
    /// Layer height (the tallest image it holds).
    pub height: u32,
    /// Layers (one per image).
    pub layers: u32,
}

impl ArraySpec {
    /// Bytes of the array with its full mip chain (RGBA8).
    pub fn bytes(&self) -> u64 {
        layer_bytes(self.width, self.height) * u64::from(self.layers)
    }
}

/// Where one image use lives: its array and layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placement {
    /// Index into [`ArrayPlan::arrays`] (the binding).
    pub array: u32,
    /// Layer within it.
    pub layer: u32,
}

/// Which array and layer each image use goes to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArrayPlan {
    /// The arrays, at most [`MATERIAL_ARRAYS`].
    pub arrays: Vec<ArraySpec>,
    /// Per use given to [`ArrayPlan::new`], in its order.
    pub placements: Vec<Placement>,
    /// Bytes of the uses' own mip chains (what one texture per image would take).
    pub image_bytes: u64,
}

pub use tiledlight_cull::texture::mip_count;

/// Bytes of one RGBA8 image with its full mip chain.
fn layer_bytes(width: u32, height: u32) -> u64 {
    (0..mip_count(width, height)).map(|k| u64::from((width >> k).max(1)) * u64::from((height >> k).max(1)) * 4).sum()
}

/// A class being merged: its layer size and its uses.
struct Class {
    srgb: bool,
    width: u32,
    height: u32,
    uses: Vec<usize>,
}

impl Class {
    fn arrays(&self, max_layers: u32) -> usize {
        self.uses.len().div_ceil(max_layers as usize)
    }
    fn bytes(&self) -> u64 {
        layer_bytes(self.width, self.height) * self.uses.len() as u64
    }
}

impl ArrayPlan {
    /// Places `uses` in at most `max_arrays` arrays of at most `max_layers` layers each
    /// (module doc, steps 1 and 2). Fails, naming the limit, when even merging everything
    /// of a colour space cannot fit them (more than `max_arrays` x `max_layers` images).
    pub fn new(uses: &[ImageUse], max_arrays: usize, max_layers: u32) -> Result<Self, GpuError> {
        let max_layers = max_layers.max(1);
        let mut by_class: BTreeMap<ImageUse, Vec<usize>> = BTreeMap::new();
        for (i, u) in uses.iter().enumerate() {
            by_class.entry(*u).or_default().push(i);
        }
        let mut classes: Vec<Class> = by_class
            .into_iter()
            .map(|(u, uses)| Class { srgb: u.srgb, width: u.width, height: u.height, uses })
            .collect();
        let needed = |c: &[Class]| c.iter().map(|c| c.arrays(max_layers)).sum::<usize>();
        while needed(&classes) > max_arrays {
            // The merge that saves an array for the fewest added bytes.
            let mut best: Option<(u64, usize, usize)> = None;
            for i in 0..classes.len() {
                for j in i + 1..classes.len() {
                    let (a, b) = (&classes[i], &classes[j]);
                    if a.srgb != b.srgb {
                        continue;
                    }
                    let merged = Class {
                        srgb: a.srgb,
                        width: a.width.max(b.width),
                        height: a.height.max(b.height),
                        uses: [a.uses.as_slice(), b.uses.as_slice()].concat(),
                    };
                    if merged.arrays(max_layers) >= a.arrays(max_layers) + b.arrays(max_layers) {
                        continue;
                    }
                    let added = merged.bytes() - a.bytes() - b.bytes();
                    if best.is_none_or(|(cost, _, _)| added < cost) {
                        best = Some((added, i, j));
                    }
                }
            }
            let Some((_, i, j)) = best else {
                return Err(GpuError::Limit {
                    what: format!(
                        "the scene's {} material texture images (each colour space in at most {max_arrays} \
                         texture arrays)",
                        uses.len()
                    ),
                    name: "max_texture_array_layers",
                    limit: u64::from(max_layers),
                    asked: format!("{} arrays of {max_layers} layers", needed(&classes)),
                });
            };
            let b = classes.remove(j);
            let a = &mut classes[i];
            a.width = a.width.max(b.width);
            a.height = a.height.max(b.height);
            a.uses.extend(b.uses);
        }
        let mut arrays = Vec::new();
        let mut placements = vec![Placement { array: 0, layer: 0 }; uses.len()];
        for c in &classes {
            for chunk in c.uses.chunks(max_layers as usize) {
                let array = arrays.len() as u32;
                for (layer, &u) in chunk.iter().enumerate() {
                    placements[u] = Placement { array, layer: layer as u32 };
                }
                arrays.push(ArraySpec { srgb: c.srgb, width: c.width, height: c.height, layers: chunk.len() as u32 });
            }
        }
        let image_bytes = uses.iter().map(|u| layer_bytes(u.width, u.height)).sum();
        Ok(Self { arrays, placements, image_bytes })
    }

    /// Bytes of every array.
    pub fn bytes(&self) -> u64 {
        self.arrays.iter().map(ArraySpec::bytes).sum()
    }

    /// What merging classes cost: the arrays' bytes beyond the images' own.
    pub fn padding_bytes(&self) -> u64 {
        self.bytes() - self.image_bytes
    }
}

/// A slot's texture for the shaders (`TextureSlot` in `shaders/common/scene.wgsl`): where
/// it lives, its size and its sampler, packed.
///
/// - `place`: array index (bits 0-3), layer (bits 4-31);
/// - `size`: width (bits 0-15), height (bits 16-31);
/// - `sampling`: wrap u (bits 0-1), wrap v (2-3: 0 repeat, 1 mirrored repeat, 2 clamp),
///   magnification filter (bit 4: 1 linear), minification filter (bit 5), mipmap filter
///   (bits 6-7: 0 none, 1 nearest, 2 linear), the image's mip count (bits 8-12).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuTextureSlot {
    /// Array and layer.
    pub place: u32,
    /// Width and height.
    pub size: u32,
    /// Sampler bits and mip count.
    pub sampling: u32,
    /// Padding to 16 bytes.
    pub _pad: u32,
}

impl GpuTextureSlot {
    /// The slot of an image of `width` x `height` at `at`, read through `sampling`.
    pub fn new(at: Placement, width: u32, height: u32, sampling: &Sampling) -> Self {
        Self {
            place: at.array | (at.layer << 4),
            size: width | (height << 16),
            sampling: sampling.bits() | (mip_count(width, height) << 8),
            _pad: 0,
        }
    }
}

/// Uploads the arrays of `plan`, each use's image (RGBA8 texels of `uses[i]`'s size, from
/// `texels(i)`) with its mip chain into its layer's top-left corner; the bindings the plan
/// does not use share one 1x1 array. Returns the textures and the [`MATERIAL_ARRAYS`]
/// views.
pub fn upload<'a>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    plan: &ArrayPlan,
    uses: &[ImageUse],
    texels: impl Fn(usize) -> &'a [u8],
    memory: &mut MemoryReport,
) -> (Vec<wgpu::Texture>, Vec<wgpu::TextureView>) {
    let format = |srgb| if srgb { wgpu::TextureFormat::Rgba8UnormSrgb } else { wgpu::TextureFormat::Rgba8Unorm };
    let mut textures: Vec<wgpu::Texture> = plan
        .arrays
        .iter()
        .enumerate()
        .map(|(k, a)| {
            let space = if a.srgb { "srgb" } else { "linear" };
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(&format!("scene.texture_array.{k}.{}x{}.{space}", a.width, a.height)),
                size: wgpu::Extent3d { width: a.width, height: a.height, depth_or_array_layers: a.layers },
                mip_level_count: mip_count(a.width, a.height),
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: format(a.srgb),
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })
        .collect();
    memory.add("scene.textures", plan.image_bytes);
    if plan.padding_bytes() > 0 {
        memory.add("scene.textures.padding", plan.padding_bytes());
        memory.note(
            "scene.textures.padding",
            format!(
                "images of more than {MATERIAL_ARRAYS} sizes share arrays: smaller ones sit in a larger layer's corner"
            ),
        );
    }
    for (i, (u, at)) in uses.iter().zip(&plan.placements).enumerate() {
        let levels = tiledlight_cull::texture::mip_chain(u.width, u.height, texels(i), u.srgb);
        for (level, (lw, lh, data)) in levels.iter().enumerate() {
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &textures[at.array as usize],
                    mip_level: level as u32,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: at.layer },
                    aspect: wgpu::TextureAspect::All,
                },
                data,
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(lw * 4), rows_per_image: Some(*lh) },
                wgpu::Extent3d { width: *lw, height: *lh, depth_or_array_layers: 1 },
            );
        }
    }
    // One 1x1 array stands in for every binding the scene does not need.
    let used = textures.len();
    if used < MATERIAL_ARRAYS {
        textures.push(device.create_texture(&wgpu::TextureDescriptor {
            label: Some("scene.texture_array.unused"),
            size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        }));
    }
    let views = (0..MATERIAL_ARRAYS)
        .map(|k| {
            textures[k.min(used)].create_view(&wgpu::TextureViewDescriptor {
                label: Some("scene.texture_array.view"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        })
        .collect();
    (textures, views)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(srgb: bool, width: u32, height: u32) -> ImageUse {
        ImageUse { srgb, width, height }
    }

    #[test]
    fn few_sizes_get_one_array_each_and_no_padding() {
        let uses = [u(true, 256, 256), u(false, 256, 256), u(true, 256, 256), u(true, 100, 60)];
        let plan = ArrayPlan::new(&uses, MATERIAL_ARRAYS, 256).unwrap();
        assert_eq!(plan.arrays.len(), 3);
        assert_eq!(plan.padding_bytes(), 0);
        // The two sRGB 256s share an array, on layers 0 and 1.
        assert_eq!(plan.placements[0].array, plan.placements[2].array);
        assert_ne!(plan.placements[0].layer, plan.placements[2].layer);
        assert_ne!(plan.placements[0].array, plan.placements[1].array);
        for (p, use_) in plan.placements.iter().zip(&uses) {
            let a = plan.arrays[p.array as usize];
            assert_eq!((a.srgb, a.width, a.height), (use_.srgb, use_.width, use_.height));
            assert!(p.layer < a.layers);
        }
    }

    #[test]
    fn many_sizes_merge_into_the_cheapest_arrays() {
        // Ten sRGB sizes into 8 arrays: two merges, each the cheapest (a small image into
        // a slightly larger layer), every image fits its layer.
        let uses: Vec<ImageUse> = (0..10).map(|k| u(true, 16 << (k % 5), 16 + k)).collect();
        let plan = ArrayPlan::new(&uses, MATERIAL_ARRAYS, 256).unwrap();
        assert_eq!(plan.arrays.len(), MATERIAL_ARRAYS);
        assert!(plan.padding_bytes() > 0);
        for (p, use_) in plan.placements.iter().zip(&uses) {
            let a = plan.arrays[p.array as usize];
            assert!(a.width >= use_.width && a.height >= use_.height && a.srgb == use_.srgb);
        }
        // Merging the two largest instead would cost more than what was done.
        let worst = layer_bytes(256, 25) * 2 - layer_bytes(256, 20) - layer_bytes(256, 25);
        assert!(plan.padding_bytes() < worst * 2, "{} bytes of padding", plan.padding_bytes());
    }

    #[test]
    fn merges_keep_colour_spaces_apart_and_take_the_larger_layer() {
        // Six sizes in each colour space: twelve classes into eight arrays; no array mixes
        // sRGB and linear images, and each merged layer holds its largest image.
        let uses: Vec<ImageUse> = (0..12).map(|k| u(k % 2 == 0, 8 << (k / 2 % 3), 8 + 4 * (k / 2) as u32)).collect();
        let plan = ArrayPlan::new(&uses, MATERIAL_ARRAYS, 256).unwrap();
        for (p, use_) in plan.placements.iter().zip(&uses) {
            let a = plan.arrays[p.array as usize];
            assert_eq!(a.srgb, use_.srgb, "{use_:?} in {a:?}");
            assert!(a.width >= use_.width && a.height >= use_.height, "{use_:?} in {a:?}");
        }
        // Two sizes into one array: the layer is the larger of each side.
        let plan = ArrayPlan::new(&[u(true, 8, 32), u(true, 16, 4)], 1, 256).unwrap();
        assert_eq!((plan.arrays[0].width, plan.arrays[0].height), (16, 32));
    }

    #[test]
    fn the_layer_limit_splits_a_class_and_too_many_images_are_refused_by_name() {
        let uses = vec![u(false, 8, 8); 5];
        let plan = ArrayPlan::new(&uses, MATERIAL_ARRAYS, 2).unwrap();
        assert_eq!(plan.arrays.iter().map(|a| a.layers).collect::<Vec<_>>(), vec![2, 2, 1]);
        let uses = vec![u(false, 8, 8); 17];
        let e = ArrayPlan::new(&uses, MATERIAL_ARRAYS, 2).unwrap_err().to_string();
        assert!(e.contains("max_texture_array_layers") && e.contains("17"), "{e}");
    }

    #[test]
    fn slots_pack_their_fields() {
        use tiledlight_cull::texture as t;
        let s = Sampling { wrap: [t::WRAP_MIRROR, t::WRAP_CLAMP], mag_linear: false, min_linear: true, mipmap: 2 };
        let g = GpuTextureSlot::new(Placement { array: 5, layer: 300 }, 100, 60, &s);
        assert_eq!((g.place & 15, g.place >> 4), (5, 300));
        assert_eq!((g.size & 0xffff, g.size >> 16), (100, 60));
        assert_eq!(Sampling::from_bits(g.sampling & 0xff), s);
        assert_eq!(g.sampling >> 8, 7);
        assert_eq!(mip_count(1, 1), 1);
        assert_eq!(mip_count(256, 1), 9);
    }
}
