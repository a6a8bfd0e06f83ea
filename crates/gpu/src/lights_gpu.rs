//! Light buffers on the GPU: culling data (bounding spheres) apart from shading data, and a
//! spot buffer that exists only when the scene has spot lights. Depends on wgpu and
//! tiledlight-cull.

use tiledlight_cull::light::{try_pack_lights, PackedLights};
use tiledlight_cull::Light;

use crate::error::GpuError;
use crate::memory::MemoryReport;
use crate::util::buffer_init;

/// Most lights accepted (1,048,576): far beyond what the tiled methods are meant for, and
/// a guard against absurd counts exhausting GPU memory.
pub const MAX_LIGHTS: usize = 1 << 20;

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
        if lights.len() > MAX_LIGHTS {
            return Err(GpuError::Config(format!(
                "{} lights requested; at most {MAX_LIGHTS} are supported",
                lights.len()
            )));
        }
        let packed = try_pack_lights(lights)?;
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
}
