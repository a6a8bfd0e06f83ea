//! Per-frame uniforms shared by every pass (camera, screen and tile sizes, depth
//! parameters, light counts) and the bind group that holds them (group 0 of every
//! pipeline). Depends on wgpu and tiledlight-cull only (the culling options build their
//! [`FrameParams`]: `light_cull::CullOptions::frame_params`).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use tiledlight_cull::{Camera, TileGrid};

/// Per-frame constants.
///
/// Keep in sync with `shaders/common/frame.wgsl` (`Frame`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameUniforms {
    /// World to view.
    pub view: [[f32; 4]; 4],
    /// View to clip (reversed-Z).
    pub proj: [[f32; 4]; 4],
    /// World to clip.
    pub view_proj: [[f32; 4]; 4],
    /// View to world.
    pub inv_view: [[f32; 4]; 4],
    /// Eye position, world space.
    pub eye: [f32; 3],
    /// Exposure multiplier before tonemapping.
    pub exposure: f32,
    /// Screen size in pixels.
    pub screen: [u32; 2],
    /// Screen size in tiles.
    pub tiles: [u32; 2],
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Indices stored per tile list.
    pub capacity: u32,
    /// Number of lights.
    pub num_lights: u32,
    /// Number of point lights (they come first).
    pub num_point_lights: u32,
    /// Near plane distance.
    pub depth_near: f32,
    /// Far plane distance (infinity when infinite).
    pub depth_far: f32,
    /// near / far (0 when infinite).
    pub depth_k: f32,
    /// 1 for orthographic cameras.
    pub orthographic: u32,
    /// Ambient radiance multiplied by the base colour.
    pub ambient: [f32; 3],
    /// 2 with half-z, else 1.
    pub lists_per_tile: u32,
}

/// What a renderer's frame uniforms are built from besides the camera: fixed when the
/// renderer is built.
#[derive(Clone, Copy, Debug)]
pub struct FrameParams {
    /// Tile grid (screen size and tile size).
    pub grid: TileGrid,
    /// Per-list capacity.
    pub capacity: u32,
    /// Lists per tile (2 with half-z).
    pub lists_per_tile: u32,
    /// Total lights and point lights.
    pub num_lights: u32,
    /// Point lights (first in the light buffers).
    pub num_point_lights: u32,
    /// Exposure.
    pub exposure: f32,
    /// Ambient radiance.
    pub ambient: Vec3,
}

impl FrameUniforms {
    /// Builds the uniforms of a frame seen through `camera` (its aspect should match the
    /// screen).
    pub fn new(p: &FrameParams, camera: &Camera) -> Self {
        let dp = camera.depth_params();
        let m = |m: Mat4| m.to_cols_array_2d();
        Self {
            view: m(camera.view()),
            proj: m(camera.proj()),
            view_proj: m(camera.view_proj()),
            inv_view: m(camera.view().inverse()),
            eye: camera.eye().to_array(),
            exposure: p.exposure,
            screen: [p.grid.width, p.grid.height],
            tiles: [p.grid.tiles_x, p.grid.tiles_y],
            tile_size: p.grid.tile_size,
            capacity: p.capacity,
            num_lights: p.num_lights,
            num_point_lights: p.num_point_lights,
            depth_near: dp.near,
            depth_far: dp.far,
            depth_k: dp.k,
            orthographic: dp.orthographic as u32,
            ambient: p.ambient.to_array(),
            lists_per_tile: p.lists_per_tile,
        }
    }
}

/// The frame uniform buffer and its bind group (group 0).
pub struct FrameBinding {
    /// The uniform buffer.
    pub buffer: wgpu::Buffer,
    /// Layout of group 0.
    pub layout: wgpu::BindGroupLayout,
    /// Group 0.
    pub bind_group: wgpu::BindGroup,
}

impl FrameBinding {
    /// Creates the buffer and bind group once; [`Self::update`] writes it each frame.
    pub fn new(device: &wgpu::Device) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame.uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame.layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame.bind_group"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
        });
        Self { buffer, layout, bind_group }
    }

    /// Writes this frame's uniforms.
    pub fn update(&self, queue: &wgpu::Queue, u: &FrameUniforms) {
        queue.write_buffer(&self.buffer, 0, bytemuck::bytes_of(u));
    }
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(
        FrameUniforms,
        "Frame",
        "common/frame.wgsl",
        [
            view,
            proj,
            view_proj,
            inv_view,
            eye,
            exposure,
            screen,
            tiles,
            tile_size,
            capacity,
            num_lights,
            num_point_lights,
            depth_near,
            depth_far,
            depth_k,
            orthographic,
            ambient,
            lists_per_tile
        ]
    )]
}
