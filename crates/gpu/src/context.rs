//! Instance, adapter and device creation, headless or for a surface. The adapter is chosen
//! by a case-insensitive substring of its name from `WGPU_ADAPTER_NAME` (e.g. `llvmpipe`
//! for lavapipe, `H100`), backends from `WGPU_BACKEND`. Only the features and limits the
//! renderer needs are requested; timestamp queries are used when the adapter has them.
//!
//! Headless programs call [`skip_display_gpu_probe`] first, so that Mesa's device-select
//! layer does not probe the window system (and print errors about it) to find the display's
//! GPU (see docs/RELIABILITY.md).
//!
//! Every device gets a device-lost callback ([`GpuContext::device_lost`]): a lost device
//! ends a run with [`GpuError::DeviceLost`] naming wgpu's reason instead of a cascade of
//! validation errors about invalid objects. Depends on wgpu.

use std::sync::{Arc, Mutex};

use crate::error::GpuError;

/// The wgpu features the visibility buffer's compute raster needs (64-bit integers and
/// 64-bit atomic max on storage buffers): requested with the device where the adapter has
/// them. Defined with the device it is asked of, so the context depends on no frame policy.
pub const COMPUTE_RASTER_FEATURES: wgpu::Features =
    wgpu::Features::SHADER_INT64.union(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX);

/// A device and queue with what the renderer learnt about the adapter.
pub struct GpuContext {
    /// The wgpu instance.
    pub instance: wgpu::Instance,
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter description, reported at start.
    pub info: wgpu::AdapterInfo,
    /// Whether GPU timestamps are available (per-pass timings).
    pub timestamps: bool,
    /// Set by the device-lost callback: wgpu's reason and message.
    lost: Arc<Mutex<Option<String>>>,
}

/// What the caller can ask of the device beyond the defaults.
#[derive(Clone, Copy, Debug, Default)]
pub struct ContextOptions {
    /// Disable timestamp queries even when supported.
    pub no_timestamps: bool,
    /// Ask for at most this much workgroup memory (bytes; at least WebGPU's 16 KiB is
    /// always asked for): to see what a GPU with less does (tests).
    pub workgroup_memory_cap: Option<u32>,
    /// Optional features the device is created without even where the adapter has them:
    /// to see the error a GPU without them gets (tests).
    pub without_features: wgpu::Features,
    /// Ask for at most this storage-buffer binding and buffer size (bytes): to see what a
    /// GPU with smaller buffers refuses (tests).
    pub storage_binding_cap: Option<u64>,
}

fn adapter_name_filter() -> Option<String> {
    std::env::var("WGPU_ADAPTER_NAME").ok().filter(|s| !s.trim().is_empty()).map(|s| s.to_lowercase())
}

impl GpuContext {
    /// A device with no surface, for rendering to textures (tests, `render`, `bench`).
    pub fn headless(options: ContextOptions) -> Result<Self, GpuError> {
        let instance = headless_instance();
        let adapter = pollster::block_on(select_adapter(&instance, desc_backends()))?;
        Self::with_adapter(instance, adapter, options)
    }

    /// A device that can present to the surface made by `make_surface` (the viewer's
    /// window): the instance is created with the window system's `display` handle, the
    /// surface from it, and the adapter must support that surface (`WGPU_ADAPTER_NAME`
    /// still picks it by name). Returns the context and the unconfigured surface.
    pub fn for_surface<'w>(
        options: ContextOptions,
        display: Box<dyn wgpu::wgt::WgpuHasDisplayHandle>,
        make_surface: impl FnOnce(&wgpu::Instance) -> Result<wgpu::Surface<'w>, wgpu::CreateSurfaceError>,
    ) -> Result<(Self, wgpu::Surface<'w>), GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(display);
        if std::env::var("WGPU_BACKEND").is_err() {
            desc.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(desc);
        let surface =
            make_surface(&instance).map_err(|e| GpuError::Config(format!("cannot create a window surface: {e}")))?;
        let adapter = pollster::block_on(select_adapter_for(&instance, desc_backends(), Some(&surface)))?;
        let ctx = Self::with_adapter(instance, adapter, options)?;
        Ok((ctx, surface))
    }

    /// A device on a chosen adapter.
    pub fn with_adapter(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        options: ContextOptions,
    ) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        let features = adapter.features();
        let timestamps = !options.no_timestamps && features.contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut required_features = wgpu::Features::empty();
        if timestamps {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        // MSAA 2x and 8x: WebGPU guarantees only 1x and 4x; the adapter's own sample counts
        // are usable only with this feature (targets::check_msaa asks it per format).
        if features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES) {
            required_features |= wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
        }
        // Tiled Deferred's emission target in 4 bytes instead of 8 (tiledlight_deferred::gbuffer
        // emission_format); without it the target stays Rgba16Float.
        if features.contains(wgpu::Features::RG11B10UFLOAT_RENDERABLE) {
            required_features |= wgpu::Features::RG11B10UFLOAT_RENDERABLE;
        }
        // The visibility buffer's raster pass writes @builtin(primitive_index); without it
        // that method is refused by name (tiledlight_frame::visibility).
        if features.contains(wgpu::Features::PRIMITIVE_INDEX) {
            required_features |= wgpu::Features::PRIMITIVE_INDEX;
        }
        // The visibility buffer's compute rasteriser (issue 29): 64-bit integers and 64-bit
        // atomic max, where the adapter has both (lavapipe and the H200 do).
        let int64 = COMPUTE_RASTER_FEATURES;
        if features.contains(int64) {
            required_features |= int64;
        }
        required_features = required_features.difference(options.without_features);
        let supported = adapter.limits();
        // WebGPU defaults, plus large storage buffers: per-tile lists at 4K with big
        // capacities and 1M lights exceed the default 128 MiB binding.
        let required_limits = wgpu::Limits {
            max_storage_buffer_binding_size: supported
                .max_storage_buffer_binding_size
                .min(options.storage_binding_cap.unwrap_or(u64::MAX)),
            max_buffer_size: supported.max_buffer_size.min(options.storage_binding_cap.unwrap_or(u64::MAX)),
            max_texture_dimension_2d: supported.max_texture_dimension_2d.min(16384),
            // Tiled Deferred's stress knob: 5 G-buffer targets are 40 bytes a sample, over
            // WebGPU's default 32. Raised only as far as that needs and the adapter allows.
            max_color_attachment_bytes_per_sample: supported.max_color_attachment_bytes_per_sample.min(64),
            // Per-tile light lists live in workgroup memory: WebGPU's 16 KiB holds 2048
            // indices, half that per list with half-z, less once Tiled Deferred's MSAA edge
            // queue takes its share. 32 KiB where the adapter has it (most desktop GPUs).
            // Tiled Deferred with shadows, MSAA, spots and two-level culling binds 9 storage
            // buffers in its compute stage (WebGPU guarantees 8).
            // The visibility buffer's pass adds the scene's instances, materials, indices and
            // up to five vertex streams: 21 with everything on.
            max_storage_buffers_per_shader_stage: supported.max_storage_buffers_per_shader_stage.min(24),
            max_compute_workgroup_storage_size: supported
                .max_compute_workgroup_storage_size
                .min(options.workgroup_memory_cap.unwrap_or(32768).clamp(16384, 32768)),
            ..wgpu::Limits::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("tiledlight.device"),
            required_features,
            required_limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device { adapter: info.name.clone(), reason: e.to_string() })?;
        let lost = Arc::new(Mutex::new(None));
        let sink = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            let why = match reason {
                wgpu::DeviceLostReason::Destroyed => "destroyed by the program".to_string(),
                wgpu::DeviceLostReason::Unknown => "reason unknown".to_string(),
            };
            let text = if message.trim().is_empty() { why } else { format!("{why}: {}", message.trim()) };
            log::debug!("GPU device lost: {text}");
            if let Ok(mut l) = sink.lock() {
                l.get_or_insert(text);
            }
        });
        Ok(Self { instance, adapter, device, queue, info, timestamps, lost })
    }

    /// [`GpuError::DeviceLost`] once the device was lost (wgpu calls the callback from a
    /// poll or submit after the loss), else None.
    pub fn device_lost(&self) -> Option<GpuError> {
        let reason = self.lost.lock().ok()?.clone()?;
        Some(GpuError::DeviceLost { reason })
    }

    /// One line naming the adapter, backend and driver.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {}){}",
            self.info.name,
            self.info.backend,
            self.info.device_type,
            self.info.driver,
            self.info.driver_info,
            if self.timestamps { "" } else { ", no GPU timestamps" }
        )
    }

    /// Runs `f` and turns any wgpu validation or out-of-memory error it raised into
    /// [`GpuError::Wgpu`] instead of wgpu's default panic.
    pub fn checked<T>(&self, context: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let scope_oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let scope_val = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let val = pollster::block_on(scope_val.pop());
        let oom = pollster::block_on(scope_oom.pop());
        if let Some(lost) = self.device_lost() {
            // Every call on a lost device fails validation: the loss is the news.
            return Err(lost);
        }
        if oom.is_some() {
            return Err(GpuError::OutOfMemory { context: context.to_string() });
        }
        if let Some(e) = val {
            return Err(GpuError::Wgpu { context: context.to_string(), message: e.to_string() });
        }
        Ok(out)
    }
}

/// The instance of a headless run: `WGPU_BACKEND`'s backends, else Vulkan, Metal and DX12
/// (the GL backend lacks compute features we need).
fn headless_instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if std::env::var("WGPU_BACKEND").is_err() {
        desc.backends = wgpu::Backends::PRIMARY;
    }
    wgpu::Instance::new(desc)
}

/// Makes the headless runs of this process skip Mesa's device-select layer
/// (`VK_LAYER_MESA_device_select`, an implicit Vulkan layer): wgpu enables the Vulkan
/// window-system extensions whenever the driver has them, and the layer, seeing
/// `VK_KHR_wayland_surface` enabled, connects to the Wayland compositor (and the X server)
/// to find the display's GPU; without `XDG_RUNTIME_DIR`, libwayland prints
/// `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` for every instance.
/// A headless run presents nothing and picks its adapter itself (`WGPU_ADAPTER_NAME`, or
/// the high-performance one), so the layer's choice is not needed. Sets the layer's own
/// switch, `NODEVICE_SELECT=1`, unless the user set it or chose a device through the
/// layer (`MESA_VK_DEVICE_SELECT`). Returns whether it set it.
///
/// Call it at the start of `main`, before any other thread exists (it changes the
/// process's environment, which the Vulkan loader reads when the instance is created).
/// Leaving out the extensions instead would need wgpu-hal's unsafe instance callback, and
/// the workspace forbids unsafe code.
pub fn skip_display_gpu_probe() -> bool {
    let user_chose = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT"].iter().any(|v| std::env::var_os(v).is_some());
    if user_chose {
        return false;
    }
    std::env::set_var("NODEVICE_SELECT", "1");
    true
}

fn desc_backends() -> wgpu::Backends {
    wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY)
}

/// Picks the adapter named by `WGPU_ADAPTER_NAME`, else the high-performance default.
pub async fn select_adapter(instance: &wgpu::Instance, backends: wgpu::Backends) -> Result<wgpu::Adapter, GpuError> {
    select_adapter_for(instance, backends, None).await
}

/// [`select_adapter`] among the adapters that can present to `surface` (all of them when
/// `None`).
pub async fn select_adapter_for(
    instance: &wgpu::Instance,
    backends: wgpu::Backends,
    surface: Option<&wgpu::Surface<'_>>,
) -> Result<wgpu::Adapter, GpuError> {
    let mut adapters = instance.enumerate_adapters(backends).await;
    if let Some(s) = surface {
        adapters.retain(|a| a.is_surface_supported(s));
    }
    let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
    if let Some(filter) = adapter_name_filter() {
        return adapters.into_iter().find(|a| a.get_info().name.to_lowercase().contains(&filter)).ok_or_else(|| {
            GpuError::NoAdapter(format!(
                "WGPU_ADAPTER_NAME='{filter}' matches none of the adapters found: [{}]{}",
                names.join(", "),
                if names.is_empty() {
                    " (on Debian, `apt-get install mesa-vulkan-drivers` provides lavapipe)"
                } else {
                    ""
                }
            ))
        });
    }
    instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            apply_limit_buckets: false,
        })
        .await
        .map_err(|e| {
            GpuError::NoAdapter(format!("{e} (on Debian, `apt-get install mesa-vulkan-drivers` provides lavapipe)"))
        })
}
