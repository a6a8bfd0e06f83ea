//! Blocking readback of textures and buffers for tests, PNG output and statistics (never
//! on a per-frame path). Handles wgpu's 256-byte row alignment. Depends on wgpu.

use crate::error::GpuError;

fn map_blocking(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
    let data = slice.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
    buffer.unmap();
    Ok(data)
}

/// Copies `buffer` (must have COPY_SRC) to the CPU as `T`s.
pub fn read_buffer<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
) -> Result<Vec<T>, GpuError> {
    read_buffer_range(device, queue, buffer, 0, buffer.size())
}

/// Copies `size` bytes of `buffer` from `offset` (both multiples of 4) to the CPU as `T`s.
pub fn read_buffer_range<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<T>, GpuError> {
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback.buffer_range"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback.buffer_range") });
    enc.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
    queue.submit([enc.finish()]);
    let bytes = map_blocking(device, &staging)?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}

/// Copies a single-sampled 2D texture (mip 0, aspect `aspect`) to tightly packed rows of
/// `bytes_per_texel`-byte texels.
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    aspect: wgpu::TextureAspect,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, GpuError> {
    read_texture_layer(device, queue, (texture, 0), aspect, bytes_per_texel)
}

/// As [`read_texture`], for array layer `layer` of `texture`.
pub fn read_texture_layer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    (texture, layer): (&wgpu::Texture, u32),
    aspect: wgpu::TextureAspect,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, GpuError> {
    let (w, h) = (texture.width(), texture.height());
    let row = w * bytes_per_texel;
    let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback.texture"),
        size: (padded * h) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback.texture") });
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d { x: 0, y: 0, z: layer }, aspect },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(h) },
        },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    queue.submit([enc.finish()]);
    let bytes = map_blocking(device, &staging)?;
    let mut out = Vec::with_capacity((row * h) as usize);
    for y in 0..h as usize {
        out.extend_from_slice(&bytes[y * padded as usize..y * padded as usize + row as usize]);
    }
    Ok(out)
}

/// Reads a `Depth32Float` (or `R32Float`) texture as f32 values, row-major; a multisampled one gives
/// `sample_count` values per pixel, pixel-major (the layout of
/// `tiledlight_cull::CullConfig::samples`).
pub fn read_depth(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture) -> Result<Vec<f32>, GpuError> {
    if texture.sample_count() > 1 {
        return read_depth_samples(device, queue, texture);
    }
    // The compute raster's depth is an R32Float colour texture.
    let aspect = if texture.format().is_depth_stencil_format() {
        wgpu::TextureAspect::DepthOnly
    } else {
        wgpu::TextureAspect::All
    };
    let bytes = read_texture(device, queue, texture, aspect, 4)?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}

/// Multisampled textures cannot be copied to a buffer: a small compute kernel
/// (`shaders/depth_samples.wgsl`) copies every sample. Built per call: a debug path.
fn read_depth_samples(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<Vec<f32>, GpuError> {
    let (w, h, n) = (texture.width(), texture.height(), texture.sample_count());
    let out = crate::util::buffer_zeroed(
        device,
        "readback.depth_samples",
        w as u64 * h as u64 * n as u64 * 4,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let module = crate::util::shader_module(device, "depth_samples.wgsl", &[])?;
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("readback.depth_samples"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("readback.depth_samples.view"),
        aspect: wgpu::TextureAspect::DepthOnly,
        ..Default::default()
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("readback.depth_samples"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
        ],
    });
    let mut enc =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback.depth_samples") });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("readback.depth_samples"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
    queue.submit([enc.finish()]);
    let mut v: Vec<f32> = read_buffer(device, queue, &out)?;
    v.truncate(w as usize * h as usize * n as usize);
    Ok(v)
}

/// Reads an `Rgba16Float` texture as linear RGBA f32.
pub fn read_hdr(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<Vec<[f32; 4]>, GpuError> {
    let bytes = read_texture(device, queue, texture, wgpu::TextureAspect::All, 8)?;
    let halves: Vec<u16> = bytemuck::pod_collect_to_vec(&bytes);
    Ok(halves
        .chunks_exact(4)
        .map(|c| [f16_to_f32(c[0]), f16_to_f32(c[1]), f16_to_f32(c[2]), f16_to_f32(c[3])])
        .collect())
}

/// IEEE half to f32 (no dependency for one function).
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = ((h >> 15) & 1) as u32;
    let exp = ((h >> 10) & 0x1f) as u32;
    let frac = (h & 0x3ff) as u32;
    let bits = match (exp, frac) {
        (0, 0) => sign << 31,
        (0, f) => {
            // Subnormal: normalise.
            let mut e = 127 - 15 + 1;
            let mut f = f;
            while f & 0x400 == 0 {
                f <<= 1;
                e -= 1;
            }
            (sign << 31) | (e << 23) | ((f & 0x3ff) << 13)
        }
        (0x1f, f) => (sign << 31) | (0xff << 23) | (f << 13),
        (e, f) => (sign << 31) | ((e + 127 - 15) << 23) | (f << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::f16_to_f32;

    #[test]
    fn half_conversion() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert!(f16_to_f32(0x7c00).is_infinite());
    }
}
