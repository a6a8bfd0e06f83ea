//! Small helpers for creating labelled buffers and pipelines the same way everywhere.
//! Depends on wgpu, the shader loader and the variant keys.

use wgpu::util::DeviceExt;

use crate::error::GpuError;
use crate::shader;
use crate::variants::ShaderKey;

/// Whether a storage buffer of `bytes` can be made and bound on a device with `limits`:
/// an error naming the limit it exceeds (`max_storage_buffer_binding_size`, or
/// `max_buffer_size` when that is the smaller), its value and `bytes`, for `what` (called
/// only on failure, e.g. "the scene's indices (30000000 triangles)"). Checked before the
/// buffer is made: past the limit wgpu would fail the binding with a validation error.
pub fn check_storage_binding(limits: &wgpu::Limits, bytes: u64, what: impl FnOnce() -> String) -> Result<(), GpuError> {
    let (name, limit) = if limits.max_buffer_size < limits.max_storage_buffer_binding_size {
        ("max_buffer_size", limits.max_buffer_size)
    } else {
        ("max_storage_buffer_binding_size", limits.max_storage_buffer_binding_size)
    };
    if bytes > limit {
        return Err(GpuError::Limit { what: what(), name, limit, asked: format!("{bytes} bytes") });
    }
    Ok(())
}

/// A labelled buffer initialised with `contents`; an empty slice gets a 16-byte buffer
/// because wgpu rejects zero-sized bindings (callers avoid binding it when unused).
pub fn buffer_init(device: &wgpu::Device, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    if contents.is_empty() {
        return device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: 16,
            usage,
            mapped_at_creation: false,
        });
    }
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
}

/// A labelled zeroed buffer of `size` bytes (at least 16).
pub fn buffer_zeroed(device: &wgpu::Device, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage,
        mapped_at_creation: false,
    })
}

/// A shader module from an embedded entry file with `defines` (each declared by the file's
/// `// variants:` lines, or an error), validated by wgpu. Passes whose shader has variants
/// build through [`keyed_module`]; this is for entry files without any.
pub fn shader_module(device: &wgpu::Device, entry: &str, defines: &[&str]) -> Result<wgpu::ShaderModule, GpuError> {
    let src = shader::preprocess(entry, defines)?;
    let label = if defines.is_empty() { entry.to_string() } else { format!("{entry} [{}]", defines.join(" ")) };
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(&label),
        source: wgpu::ShaderSource::Wgsl(src.text.into()),
    }))
}

/// The shader module of variant `key` (its entry file and defines). A value outside the
/// key's space (one `cargo xtask validate-shaders` never validated) is an error.
pub fn keyed_module(device: &wgpu::Device, key: &dyn ShaderKey) -> Result<wgpu::ShaderModule, GpuError> {
    if !key.is_valid() {
        return Err(GpuError::Config(format!(
            "{key:?} is not a variant of shaders/{} (crates/gpu/src/variants.rs)",
            key.entry()
        )));
    }
    shader_module(device, key.entry(), &key.defines())
}

/// A bind group entry: all of buffer `buffer` at `binding`.
pub fn buffer_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
}

/// A bind group entry: texture view `view` at `binding`.
pub fn view_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) }
}

/// Pipeline-layout entry list helper: every group in order, `None` for none.
pub fn pipeline_layout(device: &wgpu::Device, label: &str, groups: &[&wgpu::BindGroupLayout]) -> wgpu::PipelineLayout {
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    })
}

/// A labelled compute pipeline running `main` of `module`, laid out as `groups` in order,
/// with the override `constants` set. Workgroup memory is not zeroed: every kernel writes
/// what it reads first, and zeroing costs a pass over it per workgroup.
pub fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    groups: &[&wgpu::BindGroupLayout],
    module: &wgpu::ShaderModule,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    compute_pipeline_at(device, (label, "main"), groups, module, constants)
}

/// [`compute_pipeline`] for the entry point `entry` of a module with several.
pub fn compute_pipeline_at(
    device: &wgpu::Device,
    (label, entry): (&str, &str),
    groups: &[&wgpu::BindGroupLayout],
    module: &wgpu::ShaderModule,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout(device, &format!("{label}.pipeline_layout"), groups)),
        module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions { constants, zero_initialize_workgroup_memory: false },
        cache: None,
    })
}

/// A labelled single-sampled 2D texture.
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    size: (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    texture_2d_msaa(device, label, size, format, 1, usage)
}

/// A labelled 2D texture of `samples` samples per texel (a render target when > 1).
pub fn texture_2d_msaa(
    device: &wgpu::Device,
    label: &str,
    size: (u32, u32),
    format: wgpu::TextureFormat,
    samples: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    texture_2d_viewed_as(device, label, size, (format, samples), usage, &[])
}

/// A labelled 2D texture of `samples` samples per texel that views may also see as one of
/// `view_formats` (e.g. the sRGB twin of its format).
pub fn texture_2d_viewed_as(
    device: &wgpu::Device,
    label: &str,
    (w, h): (u32, u32),
    (format, samples): (wgpu::TextureFormat, u32),
    usage: wgpu::TextureUsages,
    view_formats: &[wgpu::TextureFormat],
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(binding: u64, buffer: u64) -> wgpu::Limits {
        wgpu::Limits { max_storage_buffer_binding_size: binding, max_buffer_size: buffer, ..wgpu::Limits::default() }
    }

    #[test]
    fn a_storage_binding_up_to_the_smaller_limit_passes() {
        assert!(check_storage_binding(&limits(1000, 2000), 1000, || unreachable!()).is_ok());
        assert!(check_storage_binding(&limits(2000, 1000), 1000, || unreachable!()).is_ok());
        assert!(check_storage_binding(&limits(1000, 1000), 0, || unreachable!()).is_ok());
    }

    #[test]
    fn a_storage_binding_past_a_limit_names_that_limit_its_value_and_the_bytes() {
        let e = check_storage_binding(&limits(1000, 2000), 1001, || "the thing".into()).unwrap_err().to_string();
        assert_eq!(e, "the thing: limit max_storage_buffer_binding_size = 1000, asked for 1001 bytes");
        let e = check_storage_binding(&limits(2000, 1000), 1001, || "the thing".into()).unwrap_err().to_string();
        assert_eq!(e, "the thing: limit max_buffer_size = 1000, asked for 1001 bytes");
    }
}
