//! The lights group (group 3) of the forward shading passes: Forward+, brute force and the
//! blended geometry's shading bind the same lights the same way (shading lights 0, spots 1,
//! light grid 2, its indices 3, tile ranges 4, lighting uniform 5, shadow atlas 15-17, VPLs
//! 19-23; the shadow and VPL numbers are Tiled Deferred's too), declared once in WGSL
//! (`shaders/common/lights_group.wgsl`) and once in Rust ([`LIGHTS_GROUP`]). Built
//! once; [`LightsGroup::rebind`] makes the group again when the light grid's index buffer
//! grew (a new buffer), the only thing in it that changes after creation. Also what every
//! lighting pass's constructor reads of its frame ([`LightingInputs`]). Depends on wgpu,
//! [`crate::light_buffers`], [`crate::light_grid`], [`crate::shadow_atlas`], and (for the
//! inputs) [`crate::features`] and [`crate::view`].

use crate::bindings::{Binding, Cond};
use crate::define::Define;
use crate::features::Features;
use crate::light_buffers::LightBuffers;
use crate::light_grid::LightGrid;
use crate::shadow_atlas::ShadowAtlas;
use crate::view::Views;

const FS: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT;

/// The bindings of group 3 (`shaders/common/lights_group.wgsl`): shading lights (0), the
/// lighting uniform (5), with `SPOT_LIGHTS` the spots (1), unless `BRUTE_FORCE` the light
/// grid (2) and its indices (3), with `HALF_Z` the tile ranges (4), with `SHADOWS` the
/// shadow atlas (15), its comparison sampler (16) and faces (17), and with `VPLS` the VPLs
/// (19), their shading uniform (20) and the generation's counter (23), and unless
/// `BRUTE_FORCE` their light grid (21) and its indices (22).
pub const LIGHTS_GROUP: &[Binding] = &[
    Binding::storage(0, FS),
    Binding::uniform(5, FS),
    Binding::storage(1, FS).when(Cond::Defined(Define::SpotLights)),
    Binding::storage(2, FS).when(Cond::NotDefined(Define::BruteForce)),
    Binding::storage(3, FS).when(Cond::NotDefined(Define::BruteForce)),
    Binding::storage(4, FS).when(Cond::All(&[Cond::Defined(Define::HalfZ), Cond::NotDefined(Define::BruteForce)])),
    Binding::depth_array(15, FS).when(Cond::Defined(Define::Shadows)),
    Binding::sampler(16, FS, wgpu::SamplerBindingType::Comparison).when(Cond::Defined(Define::Shadows)),
    Binding::storage(17, FS).when(Cond::Defined(Define::Shadows)),
    Binding::storage(19, FS).when(Cond::Defined(Define::Vpls)),
    Binding::uniform(20, FS).when(Cond::Defined(Define::Vpls)),
    Binding::storage(23, FS).when(Cond::Defined(Define::Vpls)),
    Binding::storage(21, FS).when(Cond::All(&[Cond::Defined(Define::Vpls), Cond::NotDefined(Define::BruteForce)])),
    Binding::storage(22, FS).when(Cond::All(&[Cond::Defined(Define::Vpls), Cond::NotDefined(Define::BruteForce)])),
];

/// The shadow atlas's sampled view, comparison sampler and face table.
type ShadowBindings = (wgpu::TextureView, wgpu::Sampler, wgpu::Buffer);

/// The virtual point lights a forward shading pass reads (`VPLS`, bindings 19, 20, 23):
/// their shading data, the shading uniform (cap, model, distance clamp) and the
/// generation's counter (tiledlight-vpl); in a tiled pass also their light grid and its
/// indices (21, 22). Tiled Deferred binds the same at the same numbers of its group 1.
#[derive(Clone, Debug)]
pub struct VplBindings {
    /// `array<Vpl>`.
    pub vpls: wgpu::Buffer,
    /// `VplShading` uniform.
    pub shading: wgpu::Buffer,
    /// The candidates' counter (`min(count, cap)` VPLs exist).
    pub count: wgpu::Buffer,
    /// The VPLs' light grid and its index buffer (tiled passes).
    pub lists: Option<(wgpu::Buffer, wgpu::Buffer)>,
}

/// What every lighting pass's constructor reads of its frame (Forward+ and brute force,
/// Tiled Deferred, the visibility buffer and the traced reference): the device, the views'
/// layout, the lights with their lighting uniform, the features, the shadow atlas (exactly
/// when the features have shadows) and the VPLs' bindings (exactly with VPLs). Beside it a
/// constructor takes only what is its own (its handles, its grid, its light loop).
#[derive(Clone, Copy)]
pub struct LightingInputs<'a> {
    /// The device the pass is built on.
    pub device: &'a wgpu::Device,
    /// The views (group 0's layout).
    pub views: &'a Views,
    /// The frame's lights.
    pub lights: &'a LightBuffers,
    /// The lighting uniform (ambient, counts, shadow constants).
    pub lighting: &'a wgpu::Buffer,
    /// What the frame models.
    pub features: &'a Features,
    /// The shadow atlas, with shadow casters.
    pub atlas: Option<&'a ShadowAtlas>,
    /// The VPLs' bindings, with `--vpl`.
    pub vpls: Option<&'a VplBindings>,
}

/// Group 3 of a forward shading pass and what it was made of.
pub struct LightsGroup {
    parts: Parts,
    /// The group, to bind at index 3.
    pub group: wgpu::BindGroup,
}

/// What the group is made of (all but the grid, which is passed in when it is made).
struct Parts {
    layout: wgpu::BindGroupLayout,
    label: &'static str,
    shading: wgpu::Buffer,
    spots: Option<wgpu::Buffer>,
    lighting: wgpu::Buffer,
    shadows: Option<ShadowBindings>,
    vpls: Option<VplBindings>,
    /// Bind the grid's tile ranges (half-z lookups).
    ranges: bool,
}

impl LightsGroup {
    /// The group of `layout` (labelled `label`): `lights` and the lighting uniform, the
    /// spots when `spots`, the shadow `atlas` when there is one, and the light `grid` with
    /// its tile ranges when the pair's flag says so (tiled passes), and the VPLs when given.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        (layout, label): (wgpu::BindGroupLayout, &'static str),
        (lights, lighting): (&LightBuffers, &wgpu::Buffer),
        spots: bool,
        atlas: Option<&ShadowAtlas>,
        grid: Option<(&LightGrid, bool)>,
        vpls: Option<VplBindings>,
    ) -> Self {
        let parts = Parts {
            layout,
            label,
            shading: lights.shading.clone(),
            spots: lights.spots.clone().filter(|_| spots),
            lighting: lighting.clone(),
            shadows: atlas.map(|a| (a.sample_view.clone(), a.sampler.clone(), a.faces.clone())),
            ranges: grid.is_some_and(|g| g.1),
            vpls,
        };
        let group = parts.make(device, grid.map(|g| g.0));
        Self { parts, group }
    }

    /// Makes the group again around `grid`'s current index buffer (after it grew).
    pub fn rebind(&mut self, device: &wgpu::Device, grid: &LightGrid) {
        self.group = self.parts.make(device, Some(grid));
    }

    /// The group's layout (group 3 of the pass's pipelines).
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.parts.layout
    }
}

impl Parts {
    fn make(&self, device: &wgpu::Device, grid: Option<&LightGrid>) -> wgpu::BindGroup {
        let mut bind = vec![
            wgpu::BindGroupEntry { binding: 0, resource: self.shading.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: self.lighting.as_entire_binding() },
        ];
        if let Some(s) = &self.spots {
            bind.push(wgpu::BindGroupEntry { binding: 1, resource: s.as_entire_binding() });
        }
        if let Some((view, sampler, faces)) = &self.shadows {
            bind.push(wgpu::BindGroupEntry { binding: 15, resource: wgpu::BindingResource::TextureView(view) });
            bind.push(wgpu::BindGroupEntry { binding: 16, resource: wgpu::BindingResource::Sampler(sampler) });
            bind.push(wgpu::BindGroupEntry { binding: 17, resource: faces.as_entire_binding() });
        }
        if let Some(v) = &self.vpls {
            bind.push(wgpu::BindGroupEntry { binding: 19, resource: v.vpls.as_entire_binding() });
            bind.push(wgpu::BindGroupEntry { binding: 20, resource: v.shading.as_entire_binding() });
            bind.push(wgpu::BindGroupEntry { binding: 23, resource: v.count.as_entire_binding() });
            if let Some((grid, indices)) = &v.lists {
                bind.push(wgpu::BindGroupEntry { binding: 21, resource: grid.as_entire_binding() });
                bind.push(wgpu::BindGroupEntry { binding: 22, resource: indices.as_entire_binding() });
            }
        }
        if let Some(g) = grid {
            bind.push(wgpu::BindGroupEntry { binding: 2, resource: g.grid.as_entire_binding() });
            bind.push(wgpu::BindGroupEntry { binding: 3, resource: g.indices().as_entire_binding() });
            if let (true, Some(r)) = (self.ranges, &g.ranges) {
                bind.push(wgpu::BindGroupEntry { binding: 4, resource: r.as_entire_binding() });
            }
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.label),
            layout: &self.layout,
            entries: &bind,
        })
    }
}
