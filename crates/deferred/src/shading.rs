//! Tiled Deferred's one compute pass (`shaders/deferred.wgsl`, with MSAA
//! `shaders/deferred_msaa.wgsl`): per tile, the same culling as Forward+
//! (`shaders/common/tile_cull.wgsl`, after the shared 64x64-cell pass when two-level
//! culling is on) into workgroup memory, then every pixel of the tile shaded from the
//! G-buffer with that list, into the HDR storage texture. With lists assigned
//! light-centrically before it, the pass is `shaders/deferred_assigned.wgsl`, which only
//! looks each pixel's list up. The variant is a [`DeferredKey`].
//!
//! With MSAA it also runs the edge test ([`EdgeTest`]): edge pixels are queued in workgroup
//! memory and their other samples shaded by all of the tile's threads into an oversized
//! sample texture, then [`DeferredShading::record`] resolves them with an indirect dispatch
//! (`shaders/deferred_resolve.wgsl`) sized by the shading pass. None of those resources exist
//! without MSAA. Bind group 1 holds everything; it is built once per screen.
//!
//! Every tile writes its lists to the light grid ([`LightGrid`], group 2): the heat map,
//! statistics and tests read them there, and a list longer than the workgroup list is
//! culled a second time into the grid and shaded from it, so no tile has a light ceiling.
//! Depends on tiledlight-gpu and [`crate::gbuffer`].

use tiledlight_cull::TileGrid;
use tiledlight_gpu::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use tiledlight_gpu::culling::{
    CoarseCulling, CullOptions, DropLight, LightAssign, CULL_WORKGROUP_BYTES, DEPTH_BINDING,
};
use tiledlight_gpu::define::Define;
use tiledlight_gpu::edge_samples::{light_entries, EdgeSamples, EdgeTest};
use tiledlight_gpu::handles::{Depth, Hdr};
use tiledlight_gpu::light_grid::{compute_bindings, GpuTileLists, LightGrid};
use tiledlight_gpu::lights_group::LightingInputs;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::util::{compute_pipeline, keyed_module, view_entry};
use tiledlight_gpu::variants::{DeferredKey, DeferredLists, ShaderKey, Shadowing};
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

use crate::gbuffer::GBuffer;

/// Workgroup memory the pass needs besides the light lists (bytes): the culling kernel's
/// (depth range, list counts, grid writer) and, with MSAA, the edge queue of
/// `tile_size`^2 pixels.
pub fn workgroup_bytes_besides_lists(tile_size: u32, samples: u32) -> u32 {
    CULL_WORKGROUP_BYTES + if samples > 1 { 8 + 4 * tile_size * tile_size } else { 0 }
}

/// The cull-and-shade pass.
pub struct DeferredShading {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    coarse: Option<CoarseCulling>,
    /// Light-centric assignment, run before the pass (which then only shades).
    assign: Option<LightAssign>,
    msaa: Option<EdgeSamples>,
    grid: TileGrid,
    /// The lists every tile was shaded with.
    pub light_grid: LightGrid,
    /// The pipeline constants the pass was built with ([`Self::constants`]).
    constants: Vec<(String, f64)>,
}

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// A G-buffer target read by the pass (multisampled with `MSAA`).
const fn gbuffer_binding(binding: u32) -> Binding {
    Binding::texture(binding, CS, wgpu::TextureSampleType::Float { filterable: false })
        .multisampled_when(Cond::Defined(Define::Msaa))
}

/// An HDR image the pass writes.
const fn hdr_storage_binding(binding: u32) -> Binding {
    Binding::storage_texture(binding, CS, HDR_FORMAT, wgpu::StorageTextureAccess::WriteOnly)
}

/// Group 1 of every Tiled Deferred kernel: depth (0), bounding spheres (1), the lighting
/// uniform (2), the packed surface (3, `Rgba16Uint`) and its sRGB table (4), shading lights (6), the HDR output (9); the extra
/// targets (5, 10, 11) with `EXTRA_RTS` (those past the knob's count bound to the first,
/// unread: the count is the constant `EXTRA_TARGETS`); spots (7) with `SPOT_LIGHTS` (or
/// `SPOT_CONE`, which the pass sets only with spots); cells (8) with `COARSE`; with `MSAA`
/// the sample texture (12), edge list (13) and resolve arguments (14); with `SHADOWS` the
/// shadow atlas (15), its comparison sampler (16) and faces (17); with `EMISSION` the
/// G-buffer's emission target (18); with `VPLS` the VPLs (19), their shading uniform (20),
/// their light grid (21) and its indices (22). The shadow and VPL numbers are those of the
/// forward passes' lights group (`tiledlight_gpu::lights_group::LIGHTS_GROUP`).
pub const DEFERRED_GROUP: &[Binding] = &[
    DEPTH_BINDING,
    Binding::storage(1, CS),
    Binding::uniform(2, CS),
    Binding::texture(3, CS, wgpu::TextureSampleType::Uint).multisampled_when(Cond::Defined(Define::Msaa)),
    Binding::texture(4, CS, wgpu::TextureSampleType::Float { filterable: false }),
    Binding::storage(6, CS),
    hdr_storage_binding(9),
    gbuffer_binding(5).when(Cond::Defined(Define::ExtraRts)),
    gbuffer_binding(10).when(Cond::Defined(Define::ExtraRts)),
    gbuffer_binding(11).when(Cond::Defined(Define::ExtraRts)),
    Binding::storage(7, CS).when(Cond::Any(&[Cond::Defined(Define::SpotLights), Cond::Defined(Define::SpotCone)])),
    Binding::storage(8, CS).when(Cond::Defined(Define::Coarse)),
    hdr_storage_binding(12).when(Cond::Defined(Define::Msaa)),
    Binding::storage_rw(13, CS).when(Cond::Defined(Define::Msaa)),
    Binding::storage_rw(14, CS).when(Cond::Defined(Define::Msaa)),
    Binding::depth_array(15, CS).when(Cond::Defined(Define::Shadows)),
    Binding::sampler(16, CS, wgpu::SamplerBindingType::Comparison).when(Cond::Defined(Define::Shadows)),
    Binding::storage(17, CS).when(Cond::Defined(Define::Shadows)),
    gbuffer_binding(18).when(Cond::Defined(Define::Emission)),
    Binding::storage(19, CS).when(Cond::Defined(Define::Vpls)),
    Binding::uniform(20, CS).when(Cond::Defined(Define::Vpls)),
    Binding::storage(21, CS).when(Cond::Defined(Define::Vpls)),
    Binding::storage(22, CS).when(Cond::Defined(Define::Vpls)),
];

/// The bindings of [`DeferredShading`]'s cull-and-shade kernel (`shaders/deferred.wgsl`):
/// group 1 as [`DEFERRED_GROUP`], group 2 the light grid it writes (no tile ranges).
pub const DEFERRED_BINDINGS: PassBindings = PassBindings {
    entry: "deferred.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, tiledlight_gpu::view::BINDINGS),
        PassGroup::new(1, DEFERRED_GROUP),
        PassGroup::new(2, &compute_bindings(Cond::Never)),
    ],
};

/// [`DEFERRED_BINDINGS`] for the MSAA cull-and-shade kernel (`shaders/deferred_msaa.wgsl`).
pub const DEFERRED_MSAA_BINDINGS: PassBindings = PassBindings { entry: "deferred_msaa.wgsl", ..DEFERRED_BINDINGS };

/// The bindings of the kernel shading lists assigned before it
/// (`shaders/deferred_assigned.wgsl`): group 1 as [`DEFERRED_GROUP`], group 2 the light
/// grid with its tile ranges (read per pixel).
pub const DEFERRED_ASSIGNED_BINDINGS: PassBindings = PassBindings {
    entry: "deferred_assigned.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, tiledlight_gpu::view::BINDINGS),
        PassGroup::new(1, DEFERRED_GROUP),
        PassGroup::new(2, &compute_bindings(Cond::Always)),
    ],
};

/// Bindings of the extra G-buffer targets, in order (as declared in [`DEFERRED_GROUP`],
/// which `cargo xtask validate-shaders` checks against the kernels).
const EXTRA_BINDINGS: [u32; 3] = [5, 10, 11];

impl DeferredShading {
    /// Builds the pipeline and bindings for `grid`, reading `depth` and `gbuffer` (both of
    /// `gbuffer.samples()` samples), writing `hdr`. `drop` is the test-only hook that
    /// leaves one light out of one tile's list (`None` in production).
    pub fn new(
        inputs: &LightingInputs<'_>,
        (depth, gbuffer, hdr): (Depth<'_>, &GBuffer, Hdr<'_>),
        (grid, options, edge): (TileGrid, CullOptions, EdgeTest),
        drop: Option<DropLight>,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let LightingInputs { device, views, lights, lighting, features, atlas, vpls } = *inputs;
        if depth.samples != gbuffer.samples() {
            return Err(GpuError::Config(format!(
                "Tiled Deferred: a depth buffer of {} samples a pixel, a G-buffer of {}",
                depth.samples,
                gbuffer.samples()
            )));
        }
        let (depth, hdr) = (depth.view, hdr.view);
        if features.vpl != vpls.is_some_and(|v| v.lists.is_some()) {
            return Err(GpuError::Config(
                "the VPL buffers and their light grid must be given exactly when the features have VPLs".into(),
            ));
        }
        // 2.5D lists are always assigned light-centrically here: the cull-and-shade kernel
        // has no 2.5D variant (its variants are at the validator's limit), and assignment
        // finds the same lists.
        let options = CullOptions { scatter: options.scatter || options.depth_mask, ..options };
        let samples = gbuffer.samples();
        if features.shadows.is_some() != atlas.is_some() {
            return Err(GpuError::Config("the shadow atlas must exist exactly when the features have shadows".into()));
        }
        // With every option on, the pass reads 9 storage buffers (WebGPU guarantees 8).
        let storage_limit = device.limits().max_storage_buffers_per_shader_stage;
        if atlas.is_some() && storage_limit < 9 {
            return Err(GpuError::Limit {
                what: "Tiled Deferred with shadows".into(),
                name: "max_storage_buffers_per_shader_stage",
                limit: storage_limit.into(),
                asked: "9 storage buffers in one compute stage".into(),
            });
        }
        // VPLs add three storage buffers (VPLs, their grid and its indices) to the nine.
        if vpls.is_some() && storage_limit < 12 {
            return Err(GpuError::Limit {
                what: "Tiled Deferred with VPLs".into(),
                name: "max_storage_buffers_per_shader_stage",
                limit: storage_limit.into(),
                asked: "12 storage buffers in one compute stage".into(),
            });
        }
        if options.samples != samples {
            return Err(GpuError::Config(format!(
                "culling reads {} depth samples but the G-buffer has {samples}",
                options.samples
            )));
        }
        edge.validate()?;
        options.validate(&grid, workgroup_bytes_besides_lists(options.tile_size, samples), &device.limits())?;
        if let Some(d) = &drop {
            d.check(&grid, lights.len())?;
        }
        // No tile ranges when culling here: the pass picks a pixel's half-z list from its
        // own tile's range (assignment keeps them: grid_layout).
        let light_grid = LightGrid::new(
            device,
            "deferred.light_grid",
            options.grid_layout(grid, false)?,
            lights.len(),
            options.grid_pairs,
        )?;
        memory.extend(&light_grid.memory());
        let assigned = options.assigned();
        if assigned && drop.is_some() {
            return Err(GpuError::Config("the test hook drops lights in tile-centric culling only".into()));
        }
        let assign = if assigned {
            Some(LightAssign::new(device, views, depth, (lights, lighting), &light_grid, &options, memory)?)
        } else {
            None
        };
        let lists = if assigned {
            // The pass only looks lists up: the layout's defines, none of the tests'.
            DeferredLists::Assigned {
                half_z: options.clusters.is_none() && options.half_z,
                clustered: options.clusters.is_some(),
            }
        } else {
            DeferredLists::Culled { tests: options.tests(features.spot_lights), drop_light: DropLight::variant(drop).0 }
        };
        let key = DeferredKey {
            lists,
            spots: features.spot_lights,
            shadowing: Shadowing::of(features.shadows.is_some(), features.vpl)
                .ok_or_else(|| GpuError::Config("VPLs need shadow casters".into()))?,
            msaa: options.depth_variant().0,
            extra_targets: gbuffer.extra_views().len() as u32,
            emission: gbuffer.emission_view().is_some(),
        };
        let mut bind = vec![
            view_entry(0, depth),
            wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: lighting.as_entire_binding() },
            view_entry(3, gbuffer.surface_view()),
            view_entry(4, gbuffer.srgb_lut_view()),
            wgpu::BindGroupEntry { binding: 6, resource: lights.shading.as_entire_binding() },
            view_entry(9, hdr),
        ];
        let extra = gbuffer.extra_views();
        if !extra.is_empty() {
            for (k, binding) in EXTRA_BINDINGS.into_iter().enumerate() {
                bind.push(view_entry(binding, &extra[k.min(extra.len() - 1)]));
            }
        }
        if let Some(view) = gbuffer.emission_view() {
            bind.push(view_entry(18, view));
        }
        bind.extend(light_entries(lights, features, atlas, vpls));
        let coarse = if options.coarse && !assigned {
            Some(CoarseCulling::new(device, views, depth, lights, lighting, &grid, &options, memory)?)
        } else {
            None
        };
        if let Some(c) = &coarse {
            bind.push(wgpu::BindGroupEntry { binding: 8, resource: c.lists.as_entire_binding() });
        }
        let msaa =
            (samples > 1).then(|| EdgeSamples::new(device, "deferred", &grid, samples, hdr, memory)).transpose()?;
        if let Some(m) = &msaa {
            bind.extend(m.entries());
        }
        let layout = create_layout(device, "deferred.layout", DEFERRED_GROUP, &key.defines());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deferred.bind_group"),
            layout: &layout,
            entries: &bind,
        });
        let module = keyed_module(device, &key)?;
        let mut constants = if assigned {
            let mut c = vec![("TILE_SIZE", options.tile_size as f64), ("WG", options.tile_size.min(16) as f64)];
            c.extend(options.depth_variant().1);
            c
        } else {
            options.cull_constants(coarse.as_ref(), drop, (&light_grid, lights.len()))
        };
        constants.extend(features.light_constants());
        constants.push(("EXTRA_TARGETS", extra.len() as f64));
        if samples > 1 {
            constants.extend(EdgeSamples::constants(samples, edge, options.tile_size));
        }
        let pipeline = compute_pipeline(
            device,
            "deferred.shade",
            &[&views.layout, &layout, light_grid.layout()],
            &module,
            &constants,
        );
        let constants = constants.iter().map(|&(k, v)| (k.to_string(), v)).collect();
        Ok(Self { pipeline, bind_group, coarse, assign, msaa, grid, light_grid, constants })
    }

    /// The pipeline constants the cull-and-shade pipeline was built with (tests: a setting
    /// that must not change the image, the early-outs' ablation, took effect).
    pub fn constants(&self) -> &[(String, f64)] {
        &self.constants
    }

    /// Records the cell pass (two-level culling) and the cull-and-shade dispatch (the MSAA
    /// resolve is [`Self::record_resolve`], its own step of the frame plan).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, (views, view): (&Views, u32)) {
        if let Some(a) = &self.assign {
            a.record(encoder, timer, (views, view), &self.light_grid, "deferred.assign");
        } else {
            self.light_grid.record_clear(encoder);
        }
        if let Some(c) = &self.coarse {
            let t = timer.begin("deferred.cull_cells", encoder);
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("deferred.cull_cells"),
                    timestamp_writes: t.compute_writes(),
                });
                pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
                c.dispatch(&mut pass);
            }
            timer.end(encoder, t);
        }
        if let Some(m) = &self.msaa {
            m.record_clear(encoder);
        }
        let t = timer.begin("deferred.shade", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("deferred.shade"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
            pass.set_bind_group(1, &self.bind_group, &[]);
            pass.set_bind_group(2, self.light_grid.bind_group(), &[]);
            pass.dispatch_workgroups(self.grid.tiles_x, self.grid.tiles_y, 1);
        }
        timer.end(encoder, t);
        if self.assign.is_none() {
            self.light_grid.record_readback(encoder);
        }
    }

    /// Records the MSAA resolve of the last shading pass's edge pixels (an indirect
    /// dispatch sized by that pass; nothing without MSAA).
    pub fn record_resolve(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer) {
        if let Some(m) = &self.msaa {
            m.record_resolve(encoder, timer);
        }
    }

    /// The light lists the last frame was shaded with (stalls the GPU).
    pub fn read_lists(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<GpuTileLists, GpuError> {
        self.light_grid.read_lists(device, queue)
    }

    /// Edge pixels of the last frame (MSAA only; stalls the GPU).
    pub fn read_edge_pixels(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<u32>, GpuError> {
        self.msaa.as_ref().map(|m| m.read_edge_pixels(device, queue)).transpose()
    }

    /// The last frame's edge pixels (MSAA only; stalls the GPU), in no particular order.
    pub fn read_edge_list(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<(u32, u32)>, GpuError> {
        self.msaa.as_ref().map_or(Ok(Vec::new()), |m| m.read_edge_list(device, queue))
    }
}
