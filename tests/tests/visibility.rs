//! The visibility buffer's reconstruction on the GPU (issue 28, step 1): the WGSL of
//! `shaders/common/visibility.wgsl` (`vis_barycentrics`) against its CPU twin
//! (`tiledlight_cull::visibility::barycentrics`) and the twin's f64 reference, over random
//! cameras, targets, triangles (ordinary, crossing the eye plane, small and far) and
//! pixels. The material pass that will use it is not built yet; this is its arithmetic.
//!
//! Tolerance: the GPU may contract `a * b + c` into a fused multiply-add where the CPU
//! rounds twice, so the two f32 results are not bit-equal; each is held to the f64
//! reference within four times the CPU twin's own error there plus 1e-5 of the value
//! (the twin's error is what f32 allows for that case; a GPU that reorders sums within
//! it stays inside).

use glam::{DVec3, Vec2, Vec3, Vec4};
use tiledlight_cull::visibility::{barycentrics, barycentrics_f64, pixel_ndc, Barycentrics};
use tiledlight_cull::Camera;
use tiledlight_tests::gpu;

/// One case: the triangle's clip-space vertices, the pixel centre's NDC, the target size.
struct Case {
    clip: [Vec4; 3],
    ndc: Vec2,
    size: (u32, u32),
}

/// A xorshift generator in [0, 1) (no dependency on the cull crate's test helpers).
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
    fn log(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.next()).exp()
    }
}

fn cases() -> Vec<Case> {
    let mut rng = Rng(0x9e37_79b9);
    let mut out = Vec::new();
    while out.len() < 2_000 {
        let kind = out.len() % 4;
        let eye = Vec3::new(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), rng.range(-50.0, 50.0));
        let look = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::X);
        let near = rng.log(1e-3, 1.0);
        let far = if rng.next() < 0.5 { None } else { Some(near * rng.log(1e2, 1e6)) };
        let aspect = rng.log(0.3, 3.0);
        let Ok(camera) =
            Camera::perspective(eye, eye + look, Vec3::Y, rng.range(10.0, 150.0).to_radians(), aspect, near, far)
        else {
            continue;
        };
        let size = (rng.log(1.0, 4096.0) as u32, rng.log(1.0, 4096.0) as u32);
        let pixel = ((rng.next() * size.0 as f32) as u32, (rng.next() * size.1 as f32) as u32);
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

/// Whether a result (`got`) is within the tolerance of the module doc: four times the
/// CPU twin's error against the f64 reference (`reference`) plus 1e-5 of the value.
fn agrees(got: Vec3, twin: Vec3, reference: DVec3) -> bool {
    let twin_err = (twin.as_dvec3() - reference).abs();
    let tol = twin_err * 4.0 + reference.abs().max(DVec3::ONE) * 1e-5;
    (got.as_dvec3() - reference).abs().cmple(tol).all() && got.is_finite()
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
    let ctx = gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let files = |p: &str| {
        if p == "test_visibility.wgsl" {
            Some(SHADER.to_string())
        } else {
            tiledlight_gpu::shader::embedded(p).map(str::to_owned)
        }
    };
    let text = tiledlight_gpu::shader::preprocess_with(&files, "test_visibility.wgsl", &[]).expect("preprocess").text;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("test.visibility"),
        source: wgpu::ShaderSource::Wgsl(text.into()),
    });
    let mut floats: Vec<f32> = Vec::new();
    for c in cases {
        for v in c.clip {
            floats.extend(v.to_array());
        }
        floats.extend([c.ndc.x, c.ndc.y, c.size.0 as f32, c.size.1 as f32]);
    }
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input =
        tiledlight_gpu::util::buffer_init(device, "test.visibility.cases", bytemuck::cast_slice(&floats), usage);
    let output = tiledlight_gpu::util::buffer_zeroed(device, "test.visibility.out", cases.len() as u64 * 48, usage);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("test.visibility"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("test.visibility"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: output.as_entire_binding() },
        ],
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test.visibility") });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("test.visibility"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((cases.len() as u32).div_ceil(64), 1, 1);
    }
    queue.submit([enc.finish()]);
    let got: Vec<f32> = tiledlight_gpu::readback::read_buffer(device, queue, &output).expect("readback");
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
        let (Some(Barycentrics { lambda, ddx, ddy }), Some((l, dx, dy))) = (twin, reference) else {
            // The twin gives up only where the weights' sum is exactly zero; so does the GPU.
            assert_eq!(g.3, twin.is_some(), "case {i}: valid {} vs the twin's {twin:?}", g.3);
            continue;
        };
        assert!(g.3, "case {i}: the GPU found no barycentrics, the twin {lambda}");
        assert!(agrees(g.0, lambda, l), "case {i}: lambda {} vs twin {lambda}, f64 {l}", g.0);
        assert!(agrees(g.1, ddx, dx), "case {i}: ddx {} vs twin {ddx}, f64 {dx}", g.1);
        assert!(agrees(g.2, ddy, dy), "case {i}: ddy {} vs twin {ddy}, f64 {dy}", g.2);
        compared[(c.clip.iter().any(|v| v.w <= 0.0)) as usize] += 1;
    }
    // Both triangles in front and triangles crossing the eye plane were compared.
    assert!(compared[0] > 1_000 && compared[1] > 300, "compared {compared:?}");
}

#[test]
fn the_agreement_rejects_a_wrong_weight() {
    // Negative test of `agrees`: a weight moved by 1e-3 (a neighbouring triangle's, or an
    // off-by-one vertex) is outside the tolerance of a case the twin gets right.
    let reference = DVec3::new(0.25, 0.5, 0.25);
    let twin = Vec3::new(0.25, 0.5, 0.25);
    assert!(agrees(twin, twin, reference));
    assert!(!agrees(twin + Vec3::new(1e-3, 0.0, -1e-3), twin, reference));
    assert!(!agrees(Vec3::new(f32::NAN, 0.5, 0.25), twin, reference));
}
