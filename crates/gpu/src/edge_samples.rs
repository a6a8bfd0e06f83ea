//! The machinery the compute shading passes share (Tiled Deferred and the visibility
//! buffer; neither crate depends on the other for it): the MSAA edge test's thresholds
//! ([`EdgeTest`]), the per-sample resources of edge pixels and their resolve
//! ([`EdgeSamples`], `shaders/deferred_resolve.wgsl`), and the lights' entries of their
//! group 1 ([`light_entries`]). Depends on the crate's bindings, buffers, targets, timer
//! and readback modules.

use tiledlight_cull::TileGrid;

use crate::bindings::{create_layout, Binding, PassBindings, PassGroup};
use crate::features::Features;
use crate::knobs::Knobs;
use crate::light_buffers::LightBuffers;
use crate::lights_group::VplBindings;
use crate::memory::MemoryReport;
use crate::readback::read_buffer;
use crate::shadow_atlas::ShadowAtlas;
use crate::targets::texture_2d;
use crate::timer::GpuTimer;
use crate::tonemap::HDR_FORMAT;
use crate::util::{buffer_zeroed, compute_pipeline, shader_module, view_entry};
use crate::GpuError;

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// The MSAA edge test's thresholds. A pixel is shaded per sample when one of its samples
/// lies off sample 0's tangent plane by more than `distance` times the view distance, or
/// when its normal turns more than `normal_deg` from sample 0's, or when sky meets surface.
///
/// Scale-independent: the tangent plane (from the G-buffer normal) gives the surface's depth
/// slope across the pixel, the job Lauritzen's screen-space depth derivatives do, and the
/// tolerance is relative to the view distance, so neither scene units nor a tilted surface
/// change the verdict. AMD's sample uses a fixed 50-unit depth range instead, which depends
/// on the scene's scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeTest {
    /// Off-plane distance as a fraction of the view distance (0.002: 2 mm at 1 m).
    pub distance: f32,
    /// Normal angle in degrees (AMD's sample: 10).
    pub normal_deg: f32,
}

impl Default for EdgeTest {
    /// The pass settings' defaults (rows `edge-distance` and `edge-normal-deg`).
    fn default() -> Self {
        Self::of(&Knobs::default())
    }
}

impl EdgeTest {
    /// The thresholds the pass settings' rows `edge-distance` and `edge-normal-deg` state.
    pub fn of(knobs: &Knobs) -> Self {
        Self { distance: knobs.edge_distance, normal_deg: knobs.edge_normal_deg }
    }

    /// Checks the thresholds are finite and in range.
    pub fn validate(&self) -> Result<(), GpuError> {
        if !(self.distance.is_finite() && self.distance >= 0.0) {
            return Err(GpuError::Config(format!("edge distance threshold {} must be finite and >= 0", self.distance)));
        }
        if !(0.0..=180.0).contains(&self.normal_deg) {
            return Err(GpuError::Config(format!("edge normal angle {} must be in 0..=180 degrees", self.normal_deg)));
        }
        Ok(())
    }
}

/// Texels across (x) and down (y) that one pixel's samples take in the oversized sample
/// texture: 2x1, 2x2, 4x2.
pub fn sample_grid(samples: u32) -> (u32, u32) {
    let x = if samples >= 8 { 4 } else { samples.min(2) };
    (x, samples / x)
}

/// MSAA-only resources of a compute pass that shades edge pixels per sample (Tiled
/// Deferred, the visibility buffer): the oversized sample texture (12), the frame's edge
/// list (13) and the resolve's indirect arguments with the edge count (14), and the resolve
/// (`shaders/deferred_resolve.wgsl`) that averages each listed pixel's samples into the HDR
/// image.
pub struct EdgeSamples {
    /// Kept with the views and bind groups that read and write it.
    _samples_texture: wgpu::Texture,
    samples_view: wgpu::TextureView,
    edge_list: wgpu::Buffer,
    edge_args: wgpu::Buffer,
    resolve: wgpu::ComputePipeline,
    resolve_group: wgpu::BindGroup,
    label: &'static str,
}

impl EdgeSamples {
    /// The resources for a `grid`-sized screen of `samples` samples a pixel resolving into
    /// `hdr`, labelled and reported under `prefix` (`deferred`, `visibility`).
    pub fn new(
        device: &wgpu::Device,
        prefix: &'static str,
        grid: &TileGrid,
        samples: u32,
        hdr: &wgpu::TextureView,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let (sx, sy) = sample_grid(samples);
        let (w, h) = (grid.width, grid.height);
        use wgpu::TextureUsages as U;
        let tex = texture_2d(
            device,
            &format!("{prefix}.msaa_samples"),
            (w * sx, h * sy),
            HDR_FORMAT,
            U::STORAGE_BINDING | U::TEXTURE_BINDING,
        );
        let pixels = w as u64 * h as u64;
        // COPY_SRC: tests and statistics read the edge pixels back.
        let edge_list = buffer_zeroed(
            device,
            &format!("{prefix}.edge_list"),
            pixels * 4,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let edge_args = buffer_zeroed(
            device,
            &format!("{prefix}.edge_args"),
            16,
            wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        );
        memory.add(&format!("{prefix}.msaa_samples"), pixels * samples as u64 * 8);
        memory.add(&format!("{prefix}.edge_list"), edge_list.size() + edge_args.size());
        let samples_view = tex.create_view(&wgpu::TextureViewDescriptor {
            label: Some(&format!("{prefix}.msaa_samples.view")),
            ..Default::default()
        });
        let (resolve, resolve_group) = resolve_pipeline(device, samples, &samples_view, &edge_list, &edge_args, hdr)?;
        let label = if prefix == "deferred" { "deferred.resolve" } else { "visibility.resolve" };
        Ok(Self { _samples_texture: tex, samples_view, edge_list, edge_args, resolve, resolve_group, label })
    }

    /// The shading pass's group-1 entries: sample texture (12), edge list (13), arguments (14).
    pub fn entries(&self) -> [wgpu::BindGroupEntry<'_>; 3] {
        [
            view_entry(12, &self.samples_view),
            wgpu::BindGroupEntry { binding: 13, resource: self.edge_list.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 14, resource: self.edge_args.as_entire_binding() },
        ]
    }

    /// The shading kernel's constants for the edge machinery.
    pub fn constants(samples: u32, edge: EdgeTest, tile_size: u32) -> [(&'static str, f64); 4] {
        [
            ("SAMPLES_X", sample_grid(samples).0 as f64),
            ("EDGE_DISTANCE", edge.distance as f64),
            ("EDGE_COS", (edge.normal_deg as f64).to_radians().cos()),
            ("TILE_PIXELS", (tile_size * tile_size) as f64),
        ]
    }

    /// Zeroes the edge count and the resolve's dispatch (before the shading pass).
    pub fn record_clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.edge_args, 0, None);
    }

    /// Records the resolve of the shading pass's edge pixels (an indirect dispatch sized by
    /// that pass).
    pub fn record_resolve(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer) {
        let t = timer.begin(self.label, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(self.label),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_pipeline(&self.resolve);
            pass.set_bind_group(0, &self.resolve_group, &[]);
            pass.dispatch_workgroups_indirect(&self.edge_args, 0);
        }
        timer.end(encoder, t);
    }

    /// Edge pixels of the last frame (stalls the GPU).
    pub fn read_edge_pixels(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<u32, GpuError> {
        let args: Vec<u32> = read_buffer(device, queue, &self.edge_args)?;
        Ok(args[3])
    }

    /// The last frame's edge pixels (stalls the GPU), in no particular order.
    pub fn read_edge_list(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<(u32, u32)>, GpuError> {
        let n = self.read_edge_pixels(device, queue)? as usize;
        let list: Vec<u32> = read_buffer(device, queue, &self.edge_list)?;
        Ok(list[..n.min(list.len())].iter().map(|&p| (p & 0xffff, p >> 16)).collect())
    }
}

/// The bindings of the MSAA resolve (`shaders/deferred_resolve.wgsl`): group 0, the
/// sample texture (0), edge list (1), edge count and dispatch arguments (2), HDR output (3).
pub const RESOLVE_BINDINGS: PassBindings = PassBindings {
    entry: "deferred_resolve.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, CS, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::storage(1, CS),
            Binding::storage(2, CS),
            Binding::storage_texture(3, CS, HDR_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
        ],
    )],
};

/// The group-1 entries of the lights every compute shading pass binds beside its surface
/// (Tiled Deferred, the visibility buffer): spots (7) when the features have them, the
/// shadow atlas, its sampler and faces (15-17), the VPLs, their uniform, grid and indices
/// (19-22), as both passes' group 1 numbers them (`tiledlight_deferred::shading::DEFERRED_GROUP`).
pub fn light_entries<'a>(
    lights: &'a LightBuffers,
    features: &Features,
    atlas: Option<&'a ShadowAtlas>,
    vpls: Option<&'a VplBindings>,
) -> Vec<wgpu::BindGroupEntry<'a>> {
    let mut bind = Vec::new();
    if let Some(spots) = lights.spots.as_ref().filter(|_| features.spot_lights) {
        bind.push(wgpu::BindGroupEntry { binding: 7, resource: spots.as_entire_binding() });
    }
    if let Some(v) = vpls {
        bind.push(wgpu::BindGroupEntry { binding: 19, resource: v.vpls.as_entire_binding() });
        bind.push(wgpu::BindGroupEntry { binding: 20, resource: v.shading.as_entire_binding() });
        if let Some((grid, indices)) = &v.lists {
            bind.push(wgpu::BindGroupEntry { binding: 21, resource: grid.as_entire_binding() });
            bind.push(wgpu::BindGroupEntry { binding: 22, resource: indices.as_entire_binding() });
        }
    }
    if let Some(a) = atlas {
        bind.push(view_entry(15, &a.sample_view));
        bind.push(wgpu::BindGroupEntry { binding: 16, resource: wgpu::BindingResource::Sampler(&a.sampler) });
        bind.push(wgpu::BindGroupEntry { binding: 17, resource: a.faces.as_entire_binding() });
    }
    bind
}

/// The resolve's pipeline and bind group: averages edge pixels' samples into `hdr`.
fn resolve_pipeline(
    device: &wgpu::Device,
    samples: u32,
    samples_view: &wgpu::TextureView,
    edge_list: &wgpu::Buffer,
    edge_args: &wgpu::Buffer,
    hdr: &wgpu::TextureView,
) -> Result<(wgpu::ComputePipeline, wgpu::BindGroup), GpuError> {
    let layout = create_layout(device, "deferred.resolve.layout", RESOLVE_BINDINGS.group(0), &[]);
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("deferred.resolve"),
        layout: &layout,
        entries: &[
            view_entry(0, samples_view),
            wgpu::BindGroupEntry { binding: 1, resource: edge_list.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: edge_args.as_entire_binding() },
            view_entry(3, hdr),
        ],
    });
    let module = shader_module(device, RESOLVE_BINDINGS.entry, &[])?;
    let pipeline = compute_pipeline(
        device,
        "deferred.resolve",
        &[&layout],
        &module,
        &[("SAMPLES", samples as f64), ("SAMPLES_X", sample_grid(samples).0 as f64)],
    );
    Ok((pipeline, group))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_grids_hold_every_sample() {
        for (s, want) in [(1, (1, 1)), (2, (2, 1)), (4, (2, 2)), (8, (4, 2))] {
            assert_eq!(sample_grid(s), want);
        }
    }

    #[test]
    fn edge_thresholds_are_checked() {
        assert!(EdgeTest::default().validate().is_ok());
        assert!(EdgeTest { distance: f32::NAN, ..Default::default() }.validate().is_err());
        assert!(EdgeTest { distance: -1.0, ..Default::default() }.validate().is_err());
        assert!(EdgeTest { normal_deg: 200.0, ..Default::default() }.validate().is_err());
    }
}
