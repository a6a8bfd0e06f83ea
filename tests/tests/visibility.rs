//! The visibility buffer's reconstruction on the GPU (issue 28, step 1): the WGSL of
//! `shaders/common/visibility.wgsl` (`vis_barycentrics`) against its CPU twin
//! (`tiledlight_cull::visibility::barycentrics`) and the twin's f64 reference, over random
//! cameras, targets, triangles (ordinary, crossing the eye plane, small and far) and
//! pixels: the arithmetic of the material pass (`shaders/common/visibility_surface.wgsl`,
//! whose images `visibility_method.rs` compares with brute force), and the measurement of which derivatives it must take so that `textureSampleGrad`
//! picks the level the hardware's implicit derivatives pick
//! (`explicit_gradients_choose_the_hardware_mip_level`: on lavapipe those of the 2x2
//! quad's first pixel, exactly; the pixel's own differences are up to 0.39 of a level off).
//!
//! Tolerance: the GPU may contract `a * b + c` into a fused multiply-add where the CPU
//! rounds twice, and Vulkan lets its division be 2.5 ulp off, so the two f32 results are
//! not bit-equal. Both are held to the f64 reference within the formula's own rounding
//! bound for the case (`tiledlight_cull::visibility::rounding_bound`, which allows for
//! both), not a fixed number: tight where the triangle is well conditioned, loose where
//! f32 cannot do better.

use glam::{DVec3, Vec2, Vec3, Vec4};
use tiledlight_cull::visibility::{barycentrics, barycentrics_f64, pixel_ndc, rounding_bound, Barycentrics};
use tiledlight_cull::Camera;
use tiledlight_tests::gpu;
use tiledlight_tests::kernels::{run_cases, test_module, Rng};

/// One case: the triangle's clip-space vertices, the pixel centre's NDC, the target size.
struct Case {
    clip: [Vec4; 3],
    ndc: Vec2,
    size: (u32, u32),
}

fn cases() -> Vec<Case> {
    let mut rng = Rng(0x9e37_79b9);
    let mut out = Vec::new();
    while out.len() < 2_000 {
        let kind = out.len() % 4;
        let eye = Vec3::new(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), rng.range(-50.0, 50.0));
        let look = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::X);
        let near = rng.log(1e-3, 1.0);
        let far = if rng.unit() < 0.5 { None } else { Some(near * rng.log(1e2, 1e6)) };
        let aspect = rng.log(0.3, 3.0);
        let Ok(camera) =
            Camera::perspective(eye, eye + look, Vec3::Y, rng.range(10.0, 150.0).to_radians(), aspect, near, far)
        else {
            continue;
        };
        let size = (rng.log(1.0, 4096.0) as u32, rng.log(1.0, 4096.0) as u32);
        let pixel = ((rng.unit() * size.0 as f32) as u32, (rng.unit() * size.1 as f32) as u32);
        let ndc = pixel_ndc(pixel, size);
        // A point on the pixel's ray, and a triangle around it in view space.
        let dist = match kind {
            3 => rng.log(1e3, 1e5).min(far.unwrap_or(f32::MAX) * 0.5),
            _ => rng.log(near * 2.0, near * 1e3).min(far.unwrap_or(f32::MAX) * 0.5),
        };
        let centre = camera.view_point_at(ndc.x, ndc.y, dist);
        let scale = match kind {
            2 => dist * 1e-4,
            _ => dist * rng.log(1e-2, 1.0),
        };
        let mut v: [Vec3; 3] = std::array::from_fn(|_| {
            centre + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale
        });
        if kind == 1 {
            // A vertex behind the eye (view z > 0): the triangle crosses the eye plane.
            v[0].z = dist * rng.log(1e-2, 1.0);
        }
        let inv = camera.view().inverse();
        let vp = camera.view_proj();
        let clip = v.map(|p| vp * inv.transform_point3(p).extend(1.0));
        out.push(Case { clip, ndc, size });
    }
    out
}

/// Whether a result (`got`) is within `bound` (the f32 formula's rounding bound for the
/// case, `visibility::rounding_bound`) of the f64 `reference`, plus 1e-9 of the value for
/// the reference's own rounding; an infinite bound (a derivative unbounded by design)
/// asks only for a finite value.
fn agrees(got: Vec3, bound: Vec3, reference: DVec3) -> bool {
    let slack = 1e-9 * reference.abs().max_element().max(1.0);
    let within = (got.as_dvec3() - reference).abs().cmple(bound.as_dvec3() * 1.0001 + slack).all();
    got.is_finite() && (within || !bound.is_finite())
}

const SHADER: &str = r#"
#include "common/visibility.wgsl"
struct Case { c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, ndc: vec2<f32>, size: vec2<f32> }
@group(0) @binding(0) var<storage, read> cases: array<Case>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&cases)) { return; }
    let c = cases[id.x];
    let b = vis_barycentrics(c.c0, c.c1, c.c2, c.ndc, c.size);
    let valid = select(0.0, 1.0, b.valid);
    out[3u * id.x] = vec4<f32>(b.lambda, valid);
    out[3u * id.x + 1u] = vec4<f32>(b.ddx, 0.0);
    out[3u * id.x + 2u] = vec4<f32>(b.ddy, 0.0);
}
"#;

/// Runs `vis_barycentrics` on the GPU for every case: (lambda, ddx, ddy, valid).
fn run_gpu(cases: &[Case]) -> Vec<(Vec3, Vec3, Vec3, bool)> {
    let mut floats: Vec<f32> = Vec::new();
    for c in cases {
        for v in c.clip {
            floats.extend(v.to_array());
        }
        floats.extend([c.ndc.x, c.ndc.y, c.size.0 as f32, c.size.1 as f32]);
    }
    let input = bytemuck::cast_slice(&floats);
    let got = run_cases(gpu(), "test_visibility.wgsl", SHADER, input, cases.len() as u32, cases.len() as u64 * 48);
    (0..cases.len())
        .map(|i| {
            let v = |k: usize| Vec3::new(got[12 * i + 4 * k], got[12 * i + 4 * k + 1], got[12 * i + 4 * k + 2]);
            (v(0), v(1), v(2), got[12 * i + 3] == 1.0)
        })
        .collect()
}

#[test]
fn wgsl_barycentrics_equal_the_twin() {
    let cases = cases();
    let got = run_gpu(&cases);
    let mut compared = [0usize; 2];
    for (i, (c, g)) in cases.iter().zip(&got).enumerate() {
        let twin = barycentrics(c.clip, c.ndc, c.size);
        let reference = barycentrics_f64(c.clip.map(|v| v.as_dvec4()), c.ndc.as_dvec2(), c.size);
        let bound = rounding_bound(c.clip, c.ndc, c.size);
        let (Some(Barycentrics { lambda, ddx, ddy }), Some((l, dx, dy)), Some(b)) = (twin, reference, bound) else {
            // The pixel's ray lies in the triangle's plane as far as f32 can tell: nothing
            // to compare but that neither side claims a NaN.
            assert!(!g.3 || (g.0.is_finite() && g.1.is_finite() && g.2.is_finite()), "case {i}: {g:?}");
            continue;
        };
        assert!(g.3, "case {i}: the GPU found no barycentrics, the twin {lambda}");
        // Both the twin and the GPU are held to the same bound against the reference.
        for (what, got, twin, bound, reference) in
            [("lambda", g.0, lambda, b.lambda, l), ("ddx", g.1, ddx, b.ddx, dx), ("ddy", g.2, ddy, b.ddy, dy)]
        {
            assert!(
                agrees(twin, bound, reference),
                "case {i}: the twin's {what} {twin} vs f64 {reference}, bound {bound}"
            );
            assert!(
                agrees(got, bound, reference),
                "case {i}: {what} {got} vs f64 {reference} (twin {twin}), bound {bound}"
            );
        }
        compared[(c.clip.iter().any(|v| v.w <= 0.0)) as usize] += 1;
    }
    // Both triangles in front and triangles crossing the eye plane were compared.
    assert!(compared[0] > 1_000 && compared[1] > 300, "compared {compared:?}");
}

#[test]
fn the_agreement_rejects_a_wrong_weight() {
    // Negative test of `agrees`: a weight moved by 1e-3 (a neighbouring triangle's, or an
    // off-by-one vertex) is outside the bound of a well-conditioned case; NaN never agrees.
    let reference = DVec3::new(0.25, 0.5, 0.25);
    let twin = Vec3::new(0.25, 0.5, 0.25);
    let bound = Vec3::splat(1e-6);
    assert!(agrees(twin, bound, reference));
    assert!(!agrees(twin + Vec3::new(1e-3, 0.0, -1e-3), bound, reference));
    assert!(!agrees(Vec3::new(f32::NAN, 0.5, 0.25), bound, reference));
    assert!(!agrees(Vec3::new(f32::INFINITY, 0.5, 0.25), Vec3::INFINITY, reference));
}

// ---- Mip level: explicit gradients against the hardware's implicit choice ----

/// f16 bits of a small non-negative integer (exact in f16).
fn f16_int(n: u32) -> u16 {
    if n == 0 {
        return 0;
    }
    let e = 31 - n.leading_zeros();
    let mantissa = ((n << (10 - e.min(10))) & 0x3ff) as u16;
    (((e + 15) as u16) << 10) | mantissa
}

const MIP_SHADER: &str = r#"
#include "common/visibility.wgsl"
struct Vert { clip: vec4<f32>, uv: vec4<f32> }
@group(0) @binding(0) var<storage, read> verts: array<Vert, 6>;
@group(0) @binding(1) var tex: texture_2d<f32>;
@group(0) @binding(2) var samp: sampler;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;

struct VOut { @builtin(position) clip: vec4<f32>, @location(0) uv: vec2<f32> }

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VOut {
    return VOut(verts[i].clip, verts[i].uv.xy);
}

// The hardware's level: every level of the texture holds its own index, sampled
// trilinearly, so the value read is the level of detail the sampler chose.
@fragment
fn fs_main(in: VOut) -> @location(0) vec4<f32> {
    return vec4<f32>(textureSample(tex, samp, in.uv).r, 0.0, 0.0, 1.0);
}

// The material pass's level: barycentrics and their derivatives from the clip-space
// vertices, the UV gradients from them, textureSampleGrad; with the derivatives taken
// three ways: the pixel's own forward differences, and those a 2x2 quad's coarse and fine
// derivatives take (from the quad's first pixel; from the pixel's row and column pair).
// out[2i]: the three levels and the smallest weight (distance from an edge);
// out[2i + 1].x: the triangle (-1 none).
fn level_at(t: u32, ndc_dx: vec2<f32>, ndc_dy: vec2<f32>, uv: vec2<f32>, size: vec2<f32>) -> f32 {
    let a = verts[3u * t];
    let b = verts[3u * t + 1u];
    let c = verts[3u * t + 2u];
    let bx = vis_barycentrics(a.clip, b.clip, c.clip, ndc_dx, size);
    let by = vis_barycentrics(a.clip, b.clip, c.clip, ndc_dy, size);
    let gx = a.uv.xy * bx.ddx.x + b.uv.xy * bx.ddx.y + c.uv.xy * bx.ddx.z;
    let gy = a.uv.xy * by.ddy.x + b.uv.xy * by.ddy.y + c.uv.xy * by.ddy.z;
    return textureSampleGrad(tex, samp, uv, gx, gy).r;
}

fn ndc_of(p: vec2<u32>, size: vec2<f32>) -> vec2<f32> {
    return vec2<f32>((f32(p.x) + 0.5) / size.x * 2.0 - 1.0, 1.0 - (f32(p.y) + 0.5) / size.y * 2.0);
}

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<f32>(TARGET_SIZE);
    if (f32(id.x) >= size.x || f32(id.y) >= size.y) { return; }
    let p = id.xy;
    let q = p & vec2<u32>(~1u);
    let ndc = ndc_of(p, size);
    var r = vec4<f32>(-1.0);
    var tri = -1.0;
    for (var t = 0u; t < 2u; t++) {
        let a = verts[3u * t];
        let b = verts[3u * t + 1u];
        let c = verts[3u * t + 2u];
        let bary = vis_barycentrics(a.clip, b.clip, c.clip, ndc, size);
        let m = min(bary.lambda.x, min(bary.lambda.y, bary.lambda.z));
        if bary.valid && m >= 0.0 {
            let uv = a.uv.xy * bary.lambda.x + b.uv.xy * bary.lambda.y + c.uv.xy * bary.lambda.z;
            let own = level_at(t, ndc, ndc, uv, size);
            let coarse = level_at(t, ndc_of(q, size), ndc_of(q, size), uv, size);
            let fine = level_at(t, ndc_of(vec2<u32>(q.x, p.y), size), ndc_of(vec2<u32>(p.x, q.y), size), uv, size);
            r = vec4<f32>(own, coarse, fine, m);
            tri = f32(t);
        }
    }
    let i = id.y * u32(size.x) + id.x;
    out[2u * i] = r;
    out[2u * i + 1u] = vec4<f32>(tri, 0.0, 0.0, 0.0);
}
"#;

#[test]
fn explicit_gradients_choose_the_hardware_mip_level() {
    let ctx = gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let (w, h) = (128u32, 96u32);
    // A floor receding from under the camera to 200 m away, its UVs repeating every 2.5 m
    // across and along (a 256-texel texture: levels 0 to 8 over the image).
    let camera = Camera::perspective(
        Vec3::new(0.0, 1.5, 0.0),
        Vec3::new(0.3, 0.0, -10.0),
        Vec3::Y,
        70f32.to_radians(),
        w as f32 / h as f32,
        0.1,
        None,
    )
    .unwrap();
    let corners = [
        Vec3::new(-40.0, 0.0, 2.0),
        Vec3::new(40.0, 0.0, 2.0),
        Vec3::new(40.0, 0.0, -200.0),
        Vec3::new(-40.0, 0.0, -200.0),
    ];
    let uv = |p: Vec3| Vec2::new(p.x / 2.5, p.z / 2.5);
    let tris = [[0usize, 1, 2], [0, 2, 3]];
    let vp = camera.view_proj();
    let verts: Vec<(Vec4, Vec2)> =
        tris.iter().flatten().map(|&i| (vp * corners[i].extend(1.0), uv(corners[i]))).collect();
    let floats: Vec<f32> = verts.iter().flat_map(|(c, t)| [c.x, c.y, c.z, c.w, t.x, t.y, 0.0, 0.0]).collect();
    let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let vbuf = tiledlight_gpu::util::buffer_init(device, "test.mip.verts", bytemuck::cast_slice(&floats), storage);

    // The texture: level k holds k everywhere.
    let levels = 9u32;
    let tex = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test.mip.texture"),
        size: wgpu::Extent3d { width: 256, height: 256, depth_or_array_layers: 1 },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R16Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for k in 0..levels {
        let side = 256 >> k;
        let texels = vec![f16_int(k); (side * side) as usize];
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: k,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(2 * side), rows_per_image: Some(side) },
            wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 },
        );
    }
    let view = tex.create_view(&wgpu::TextureViewDescriptor { label: Some("test.mip.view"), ..Default::default() });
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("test.mip.sampler"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    });
    // The hardware path's target, which also gives the compute pass its size.
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test.mip.target"),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let target_view = target.create_view(&wgpu::TextureViewDescriptor::default());
    let shader = MIP_SHADER.replace("TARGET_SIZE", &format!("vec2<u32>({w}u, {h}u)"));
    let module = test_module(ctx, "test_mip.wgsl", &shader);
    let out = tiledlight_gpu::util::buffer_zeroed(device, "test.mip.out", (w * h * 32) as u64, storage);
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("test.mip.layout"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 3,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        ],
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("test.mip.bind"),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: vbuf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
            wgpu::BindGroupEntry { binding: 3, resource: out.as_entire_binding() },
        ],
    });
    let pl = tiledlight_gpu::util::pipeline_layout(device, "test.mip.pipeline_layout", &[&layout]);
    let render = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("test.mip.render"),
        layout: Some(&pl),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: wgpu::TextureFormat::R32Float,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    let compute = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("test.mip.compute"),
        layout: Some(&pl),
        module: &module,
        entry_point: Some("cs_main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test.mip") });
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("test.mip.render"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r: -1.0, g: 0.0, b: 0.0, a: 0.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&render);
        pass.set_bind_group(0, &bind, &[]);
        pass.draw(0..6, 0..1);
    }
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("test.mip.compute"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&compute);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
    queue.submit([enc.finish()]);
    let hw: Vec<f32> = bytemuck::pod_collect_to_vec(
        &tiledlight_gpu::readback::read_texture(device, queue, &target, wgpu::TextureAspect::All, 4)
            .expect("hardware levels"),
    );
    let grad: Vec<[f32; 4]> = tiledlight_gpu::readback::read_buffer(device, queue, &out).expect("gradient levels");

    // Compared away from the triangles' shared edge and the image border (a 2x2 quad
    // there spans both triangles or the outside), and where no level is clamped (0 or
    // the last). Per derivative mode: the largest and mean |hardware - explicit|.
    let modes = ["pixel", "quad coarse", "quad fine"];
    let (mut n, mut worst, mut sum, mut worst_cpu) = (0u32, [0f32; 3], [0f64; 3], 0f32);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = (y * w + x) as usize;
            let (levels_got, tri) = (grad[2 * i], grad[2 * i + 1][0]);
            if tri < 0.0 || levels_got[3] < 0.02 || hw[i] < 0.0 {
                continue;
            }
            let inside = |l: f32| (0.05..(levels - 1) as f32 - 0.05).contains(&l);
            if !inside(hw[i]) || !levels_got[..3].iter().all(|&l| inside(l)) {
                continue;
            }
            for m in 0..3 {
                let d = (hw[i] - levels_got[m]).abs();
                worst[m] = worst[m].max(d);
                sum[m] += d as f64;
            }
            n += 1;
            // The CPU twin's level from the pixel's own barycentrics.
            let t = tri as usize;
            let clip = [verts[3 * t].0, verts[3 * t + 1].0, verts[3 * t + 2].0];
            let b = barycentrics(clip, pixel_ndc((x, y), (w, h)), (w, h)).expect("covered pixel");
            let (_, gx, gy) = b.interpolate([verts[3 * t].1, verts[3 * t + 1].1, verts[3 * t + 2].1]);
            let cpu = tiledlight_cull::visibility::mip_level(gx, gy, (256, 256));
            worst_cpu = worst_cpu.max((cpu - levels_got[0]).abs());
        }
    }
    assert!(n > (w * h / 4), "only {n} pixels compared");
    let best = (0..3).min_by(|&a, &b| worst[a].total_cmp(&worst[b])).unwrap();
    for m in 0..3 {
        println!(
            "mip levels on {}: {n} pixels, derivatives {:>11}: |hardware - explicit| max {:.4} mean {:.4}",
            ctx.describe(),
            modes[m],
            worst[m],
            sum[m] / n as f64
        );
    }
    println!("mip levels: the hardware's implicit level is matched best by {} derivatives; |CPU twin - explicit (pixel)| max {worst_cpu:.4}", modes[best]);
    // With the derivative mode the adapter's fragment stage uses, the same sampler turns
    // both into the same level up to its fixed-point fraction: 0.05 of a level.
    assert!(worst[best] <= 0.05, "no derivative mode gives the hardware's level: {worst:?}");
    // The comparison's own check: on a floor receding to the horizon the level changes by
    // a good part of a level per pixel, so derivatives taken at the wrong pixels are seen.
    assert!(worst.iter().any(|&w| w > 0.1), "the comparison cannot tell the modes apart: {worst:?}");
    // The twin computes rho exactly (Euclidean lengths); Vulkan lets the sampler
    // approximate it (within sqrt(2)), i.e. up to half a level apart.
    assert!(worst_cpu <= 0.5, "the CPU twin's level is {worst_cpu} from the sampler's");
}
