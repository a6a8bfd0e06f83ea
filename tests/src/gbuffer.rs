//! Reading Tiled Deferred's G-buffer back for tests: the packed surface of every pixel,
//! decoded as the shading decodes it ([`read_gbuffer`]), and the per-pixel allowance a
//! comparison with a reference gives for what its quantisation may move
//! ([`surface_allowance`]). Depends on tiledlight-frame, tiledlight-deferred and
//! tiledlight-cull.

use glam::Vec3;
use tiledlight_cull::brdf::{brdf_cos, windowed_attenuation, Surface};
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::Camera;
use tiledlight_frame::{DeferredFrame, FrameRenderer};
use tiledlight_gpu::readback::read_buffer;
use tiledlight_gpu::GpuContext;

/// Reads a single-sampled G-buffer's packed surface texels and decodes them with the CPU
/// twin ([`tiledlight_cull::gbuffer::unpack`]; the GPU's decoder is tested against it in
/// `gbuffer_texel.rs`), the base colour as the shading decodes it, through the G-buffer's
/// sRGB table read by the texture unit: 8 floats a pixel, albedo rgb, metallic, normal
/// xyz, roughness. The
/// G-buffer textures cannot be copied (no `COPY_SRC`: they never leave the GPU in
/// production), so a small compute kernel copies them, built per call (a test path).
pub fn read_gbuffer(ctx: &GpuContext, r: &FrameRenderer, (w, h): (u32, u32)) -> Vec<f32> {
    const SRC: &str = "
        @group(0) @binding(0) var surface: texture_2d<u32>;
        @group(0) @binding(1) var<storage, read_write> out: array<vec4<u32>>;
        @group(0) @binding(2) var srgb_lut: texture_2d<f32>;
        @compute @workgroup_size(8, 8)
        fn main(@builtin(global_invocation_id) id: vec3<u32>) {
            let size = textureDimensions(surface);
            if id.x >= size.x || id.y >= size.y { return; }
            let p = textureLoad(surface, id.xy, 0);
            let i = 2u * (id.y * size.x + id.x);
            out[i] = p;
            let codes = vec3<u32>(p.z >> 8u, p.z, p.w >> 8u) & vec3<u32>(0xffu);
            out[i + 1u] = bitcast<vec4<u32>>(vec4<f32>(textureLoad(srgb_lut, vec2<u32>(codes.r, 0u), 0).r,
                textureLoad(srgb_lut, vec2<u32>(codes.g, 0u), 0).r, textureLoad(srgb_lut, vec2<u32>(codes.b, 0u), 0).r, 0.0));
        }";
    let device = &ctx.device;
    let g = r.passes::<DeferredFrame>().expect("Tiled Deferred").gbuffer();
    assert_eq!(g.samples(), 1, "read_gbuffer reads single-sampled G-buffers");
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("test.read_gbuffer"),
        source: wgpu::ShaderSource::Wgsl(SRC.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("test.read_gbuffer"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("test.read_gbuffer.out"),
        size: u64::from(w) * u64::from(h) * 32,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("test.read_gbuffer"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(g.surface_view()) },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(g.srgb_lut_view()) },
        ],
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test.read_gbuffer") });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("test.read_gbuffer"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
    ctx.queue.submit([enc.finish()]);
    let texels: Vec<u32> = read_buffer(device, &ctx.queue, &out).unwrap();
    texels
        .chunks_exact(8)
        .flat_map(|c| {
            let t = tiledlight_cull::gbuffer::unpack([c[0], c[1], c[2], c[3]]);
            let base = [c[4], c[5], c[6]].map(f32::from_bits);
            [base[0], base[1], base[2], t.metallic, t.normal.x, t.normal.y, t.normal.z, t.roughness]
        })
        .collect()
}

/// Per pixel, how far the packed G-buffer's rounding may move Tiled Deferred's lights from
/// the unquantised surface's (largest channel), from the surface it holds (`gbuffer`, as
/// [`read_gbuffer`] returns it): the CPU BRDF twin (`tiledlight_cull::brdf`) summed over the
/// lights reaching the pixel (radiance x windowed attenuation x `brdf_cos`, spot cones left
/// at 1, their largest), with the normal turned by the encoding's bound
/// ([`tiledlight_cull::gbuffer::max_normal_error`]) about 8 axes, the roughness moved by
/// half its step and the metallic by half its (1/30: four bits; a glTF metallic image's
/// 8-bit values are not on that grid: measured on the many-material scene, a dark pixel of
/// a metallic-roughness-mapped box moves 8.4% on lavapipe), the largest change kept. Unlike [`crate::compare::Frame::allow_gbuffer_normals`]
/// (diffuse light only, no surface needed) it covers the specular lobe, whose change under
/// a turned normal is `brdf x` the turn for a light at grazing incidence: measured on
/// lavapipe, a courtyard column pixel (roughness 0.35) whose brightest light arrives at
/// `n.l` = 0.0033 moves by up to 7% under a 2.64e-4 rad turn. A missing light is a whole
/// light's contribution, far outside it except at such pixels.
pub fn surface_allowance(gbuffer: &[f32], depth: &[f32], w: u32, camera: &Camera, lights: &PackedLights) -> Vec<f32> {
    let h = (depth.len() / w as usize) as u32;
    let inv_view = camera.view().inverse();
    let e = tiledlight_cull::gbuffer::max_normal_error() as f32;
    let dr = tiledlight_cull::gbuffer::max_roughness_error();
    let dm = tiledlight_cull::gbuffer::max_metallic_error();
    (0..depth.len())
        .map(|i| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let Some(pv) = pixel_view_position(camera, w, h, x, y, depth[i]) else { return 0.0 };
            let p = (inv_view * pv.extend(1.0)).truncate();
            let g = &gbuffer[i * 8..i * 8 + 8];
            let s = Surface { albedo: Vec3::new(g[0], g[1], g[2]), roughness: g[7], metallic: g[3] };
            let n = Vec3::new(g[4], g[5], g[6]);
            let v = (camera.eye() - p).normalize();
            let near: Vec<(Vec3, Vec3)> = lights
                .shading
                .iter()
                .filter_map(|l| {
                    let to = Vec3::from(l.position) - p;
                    let d2 = to.length_squared();
                    (d2 < l.radius * l.radius)
                        .then(|| (Vec3::from(l.radiance) * windowed_attenuation(d2, l.radius), to / d2.sqrt()))
                })
                .collect();
            let shade = |n: Vec3, s: &Surface| near.iter().map(|&(r, l)| r * brdf_cos(n, v, l, s)).sum::<Vec3>();
            let base = shade(n, &s);
            let t = n.any_orthonormal_vector();
            let b = n.cross(t);
            let mut worst = 0.0f32;
            for k in 0..8 {
                let a = k as f32 * std::f32::consts::TAU / 8.0;
                let m = (n + e * (t * a.cos() + b * a.sin())).normalize();
                worst = worst.max((shade(m, &s) - base).abs().max_element());
            }
            for r in [s.roughness - dr, s.roughness + dr] {
                worst = worst.max((shade(n, &Surface { roughness: r, ..s }) - base).abs().max_element());
            }
            // The shading is linear in metallic (diffuse x (1 - m), F0 mixed by m): the
            // rounding's two ends bound it.
            for m in [s.metallic - dm, s.metallic + dm] {
                worst = worst.max((shade(n, &Surface { metallic: m.clamp(0.0, 1.0), ..s }) - base).abs().max_element());
            }
            worst
        })
        .collect()
}
