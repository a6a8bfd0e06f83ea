//! Views: a camera and the screen it renders to, the only contents of group 0 of every
//! scene and culling pipeline (`shaders/common/view.wgsl`).
//!
//! The uniforms of all views live in one buffer, one slot each, and the bind group is
//! bound with the slot's dynamic offset (as Bevy binds its view uniform), so any scene
//! pipeline can draw any view: the main camera (slot [`MAIN_VIEW`]), shadow faces and RSM
//! faces, without new pipelines or bind groups. Culling parameters live with the
//! light grid ([`crate::light_grid`]), the light counts and ambient with the lights
//! ([`crate::light_buffers::LightingUniforms`]), the exposure with the tonemap pass.
//! Depends on wgpu, tiledlight-cull and [`crate::bindings`].

use bytemuck::{Pod, Zeroable};
use glam::Mat4;
use tiledlight_cull::Camera;

use crate::bindings::{create_layout, Binding};

/// The slot of the main camera.
pub const MAIN_VIEW: u32 = 0;

/// One view's uniforms.
///
/// Keep in sync with `shaders/common/view.wgsl` (`View`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ViewUniforms {
    /// World to view.
    pub world_to_view: [[f32; 4]; 4],
    /// View to clip (reversed-Z).
    pub view_to_clip: [[f32; 4]; 4],
    /// World to clip.
    pub world_to_clip: [[f32; 4]; 4],
    /// View to world.
    pub view_to_world: [[f32; 4]; 4],
    /// Eye position, world space.
    pub eye: [f32; 3],
    /// 1 for orthographic cameras.
    pub orthographic: u32,
    /// Screen size in pixels.
    pub screen: [u32; 2],
    /// Near plane distance.
    pub depth_near: f32,
    /// Far plane distance (infinity when infinite).
    pub depth_far: f32,
    /// near / far (0 when infinite).
    pub depth_k: f32,
    /// Padding to a multiple of 16 bytes.
    pub _pad0: u32,
    /// Padding.
    pub _pad1: u32,
    /// Padding.
    pub _pad2: u32,
}

impl ViewUniforms {
    /// The uniforms of `camera` rendering a `width` x `height` screen (the camera's aspect
    /// should match it).
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let dp = camera.depth_params();
        let m = |m: Mat4| m.to_cols_array_2d();
        Self {
            world_to_view: m(camera.view()),
            view_to_clip: m(camera.proj()),
            world_to_clip: m(camera.view_proj()),
            view_to_world: m(camera.view().inverse()),
            eye: camera.eye().to_array(),
            orthographic: dp.orthographic as u32,
            screen: [width, height],
            depth_near: dp.near,
            depth_far: dp.far,
            depth_k: dp.k,
            ..Default::default()
        }
    }
}

impl ViewUniforms {
    /// The uniforms of a view with world-to-view `view` and reversed-Z, infinite-far
    /// projection `proj` of near plane `near` (a shadow face), rendering `size` texels.
    pub fn from_matrices(view: Mat4, proj: Mat4, near: f32, size: (u32, u32)) -> Self {
        let m = |m: Mat4| m.to_cols_array_2d();
        let to_world = view.inverse();
        Self {
            world_to_view: m(view),
            view_to_clip: m(proj),
            world_to_clip: m(proj * view),
            view_to_world: m(to_world),
            eye: to_world.w_axis.truncate().to_array(),
            orthographic: 0,
            screen: [size.0, size.1],
            depth_near: near,
            depth_far: f32::INFINITY,
            depth_k: 0.0,
            ..Default::default()
        }
    }
}

/// Group 0 of every scene and culling pipeline: the view uniform, bound at a slot's
/// dynamic offset (`shaders/common/view.wgsl`).
pub const BINDINGS: &[Binding] =
    &[Binding::uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT.union(wgpu::ShaderStages::COMPUTE))
        .dynamic_offset(std::mem::size_of::<ViewUniforms>() as u64)];

/// The views' uniform buffer and the group-0 bind group that addresses one slot of it.
pub struct Views {
    buffer: wgpu::Buffer,
    /// Layout of group 0 (one uniform with a dynamic offset).
    pub layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    stride: u64,
    slots: u32,
}

impl Views {
    /// A buffer of `slots` views (at least 1), created once.
    pub fn new(device: &wgpu::Device, slots: u32) -> Self {
        let slots = slots.max(1);
        let size = std::mem::size_of::<ViewUniforms>() as u64;
        let align = device.limits().min_uniform_buffer_offset_alignment as u64;
        let stride = size.div_ceil(align) * align;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("views.uniforms"),
            size: stride * slots as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = create_layout(device, "views.layout", BINDINGS, &[]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("views.bind_group"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(size),
                }),
            }],
        });
        Self { buffer, layout, bind_group, stride, slots }
    }

    /// Writes slot `slot`'s uniforms (before the passes that read it are submitted).
    pub fn write(&self, queue: &wgpu::Queue, slot: u32, u: &ViewUniforms) {
        assert!(slot < self.slots, "view slot {slot} of {}", self.slots);
        queue.write_buffer(&self.buffer, self.stride * slot as u64, bytemuck::bytes_of(u));
    }

    /// The group-0 bind group; bind it with [`Self::offsets`] of the slot to draw.
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// The dynamic offset of slot `slot`.
    pub fn offsets(&self, slot: u32) -> [u32; 1] {
        [(self.stride * slot.min(self.slots - 1) as u64) as u32]
    }

    /// Number of slots.
    pub fn slots(&self) -> u32 {
        self.slots
    }
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(
        ViewUniforms,
        "View",
        "common/view.wgsl",
        [
            world_to_view,
            view_to_clip,
            world_to_clip,
            view_to_world,
            eye,
            orthographic,
            screen,
            depth_near,
            depth_far,
            depth_k,
            _pad0,
            _pad1,
            _pad2
        ]
    )]
}
