//! Light buffers on the GPU: culling data (bounding spheres) apart from shading data, a
//! spot buffer that exists only when the scene has spot lights, and the small `Lighting`
//! uniform (light counts, ambient) that culling and shading read next to them. Depends on
//! wgpu and tiledlight-cull.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use tiledlight_cull::light::{try_pack_lights_ranked, CasterRank, PackedLights};
use tiledlight_cull::Light;

use crate::error::GpuError;
use crate::memory::MemoryReport;
use crate::util::buffer_init;

/// Most lights accepted (1,048,576): far beyond what the tiled methods are meant for, and
/// a guard against absurd counts exhausting GPU memory.
pub const MAX_LIGHTS: usize = 1 << 20;

/// The light counts and the ambient term, bound as `lighting` next to the light buffers.
///
/// Keep in sync with `shaders/common/lights.wgsl` (`Lighting`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightingUniforms {
    /// Ambient radiance multiplied by the base colour.
    pub ambient: [f32; 3],
    /// Number of lights.
    pub num_lights: u32,
    /// Number of point lights (they come first).
    pub num_point_lights: u32,
    /// Shadow-casting point lights (the first lights).
    pub num_shadow_points: u32,
    /// Shadow-casting spot lights (the first spots).
    pub num_shadow_spots: u32,
    /// Added to the shadow lookup's reference depth (the atlas format's quanta).
    pub shadow_depth_bias: f32,
    /// One atlas texel, in atlas coordinates.
    pub shadow_texel_uv: [f32; 2],
    /// One atlas tile, in atlas coordinates.
    pub shadow_tile_uv: [f32; 2],
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(
        LightingUniforms,
        "Lighting",
        "common/lights.wgsl",
        [
            ambient,
            num_lights,
            num_point_lights,
            num_shadow_points,
            num_shadow_spots,
            shadow_depth_bias,
            shadow_texel_uv,
            shadow_tile_uv
        ]
    )]
}

/// The scene's lights in GPU buffers, points first.
pub struct LightBuffers {
    /// Bounding spheres (culling kernel input).
    pub cull: wgpu::Buffer,
    /// Shading data.
    pub shading: wgpu::Buffer,
    /// Spot data, only when there are spot lights.
    pub spots: Option<wgpu::Buffer>,
    /// The packed lights as uploaded (the CPU reference culls exactly these).
    pub packed: PackedLights,
    /// Bytes allocated.
    pub memory: MemoryReport,
}

impl LightBuffers {
    /// Validates, orders (points first), packs and uploads `lights`. A light with a NaN,
    /// infinite or out-of-range field (its fields are public) is an error naming its index
    /// in `lights` and the field ([`tiledlight_cull::light::validate_lights`]), not NaN data
    /// that the culling kernel would silently drop.
    pub fn new(device: &wgpu::Device, lights: &[Light]) -> Result<Self, GpuError> {
        Self::with_casters(device, lights, (0, 0))
    }

    /// As [`Self::new`], with `casters` = (point, spot) shadow-casting lights: the brightest
    /// of each kind, placed first within it
    /// ([`tiledlight_cull::light::try_pack_lights_with_casters`]). More casters than lights
    /// of a kind is an error naming both numbers.
    pub fn with_casters(device: &wgpu::Device, lights: &[Light], casters: (u32, u32)) -> Result<Self, GpuError> {
        Self::ranked(device, lights, casters, CasterRank::Brightest)
    }

    /// As [`Self::with_casters`], the casters of each kind chosen by `rank`
    /// ([`tiledlight_cull::light::try_pack_lights_ranked`]).
    pub fn ranked(
        device: &wgpu::Device,
        lights: &[Light],
        casters: (u32, u32),
        rank: CasterRank<'_>,
    ) -> Result<Self, GpuError> {
        if lights.len() > MAX_LIGHTS {
            return Err(GpuError::Config(format!(
                "{} lights requested; at most {MAX_LIGHTS} are supported",
                lights.len()
            )));
        }
        let packed = try_pack_lights_ranked(lights, casters, rank)?;
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        // A light-less scene still binds one zeroed element: bindings must cover the
        // shader's struct size, and the loops never read it (num_lights is 0).
        let one_if_empty = |n: usize| if n == 0 { 1 } else { 0 };
        let mut cull_data = packed.cull.clone();
        cull_data.resize(cull_data.len() + one_if_empty(packed.cull.len()), Default::default());
        let mut shading_data = packed.shading.clone();
        shading_data.resize(shading_data.len() + one_if_empty(packed.shading.len()), Default::default());
        let cull = buffer_init(device, "lights.cull", bytemuck::cast_slice(&cull_data), usage);
        let shading = buffer_init(device, "lights.shading", bytemuck::cast_slice(&shading_data), usage);
        let spots = (!packed.spots.is_empty())
            .then(|| buffer_init(device, "lights.spots", bytemuck::cast_slice(&packed.spots), usage));
        let mut memory = MemoryReport::default();
        memory.add("lights.cull", cull.size());
        memory.add("lights.shading", shading.size());
        if let Some(s) = &spots {
            memory.add("lights.spots", s.size());
        }
        Ok(Self { cull, shading, spots, packed, memory })
    }

    /// Number of lights.
    pub fn len(&self) -> u32 {
        self.packed.len() as u32
    }

    /// True when there are no lights.
    pub fn is_empty(&self) -> bool {
        self.packed.is_empty()
    }

    /// Number of point lights (the first ones).
    pub fn num_point(&self) -> u32 {
        self.packed.num_point
    }

    /// True when the spot buffer exists.
    pub fn has_spots(&self) -> bool {
        self.spots.is_some()
    }

    /// A renderer's `Lighting` uniform over these lights with `ambient` (a renderer
    /// setting, so each renderer owns its own), without shadows.
    pub fn lighting(&self, device: &wgpu::Device, ambient: Vec3) -> wgpu::Buffer {
        Self::upload_lighting(device, &self.lighting_uniforms(ambient))
    }

    /// The `Lighting` values of these lights with `ambient`; the shadow fields are the
    /// casters' counts, the atlas fields zero (the frame sets them when it has an atlas).
    pub fn lighting_uniforms(&self, ambient: Vec3) -> LightingUniforms {
        LightingUniforms {
            ambient: ambient.to_array(),
            num_lights: self.len(),
            num_point_lights: self.num_point(),
            num_shadow_points: self.packed.shadow_points,
            num_shadow_spots: self.packed.shadow_spots,
            ..Default::default()
        }
    }

    /// Uploads a `Lighting` uniform.
    pub fn upload_lighting(device: &wgpu::Device, u: &LightingUniforms) -> wgpu::Buffer {
        buffer_init(device, "lighting.uniforms", bytemuck::bytes_of(u), wgpu::BufferUsages::UNIFORM)
    }
}
