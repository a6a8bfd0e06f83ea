//! tiledlight's light culling and light grid inside a renderer that is not tiledlight's:
//! this program brings its own mesh, camera, depth buffer, depth pipeline and shading
//! shader, as an engine would, and takes only the culling from `tiledlight-gpu`.
//!
//! 1. A wgpu device (`GpuContext::headless`: any device with compute shaders would do).
//! 2. The engine's own scene: a ground plane and a few boxes as raw vertex and index
//!    arrays, and a camera given as eye, target and field of view, turned into a
//!    `tiledlight_cull::Camera` (reversed-Z, infinite far plane).
//! 3. A few hundred random point lights (`tiledlight_cull::Light`) uploaded with
//!    `LightBuffers` (with its `Lighting` uniform: counts and ambient); the camera goes to
//!    the GPU as one slot of `Views` (`ViewUniforms`, group 0 with a dynamic offset).
//! 4. The engine's own depth-only pipeline draws the mesh into its own `Depth32Float`
//!    texture (reversed-Z: clear 0, compare `GreaterEqual`).
//! 5. `LightCulling` culls the lights against that depth buffer, tile by tile, into the
//!    light grid: per 16x16 tile `(first, count)` into one buffer of light indices.
//! 6. The engine's own fragment shader shades the mesh with the grid: it binds
//!    `light_grid` and `light_indices` as `shaders/forward.wgsl` does (its group 3,
//!    `shaders/common/lights_group.wgsl`) and reuses
//!    tiledlight's `common/light_grid_pixel.wgsl` (`pixel_list`) and `common/shade.wgsl`
//!    (`shade_light`: the shared BRDF and attenuation) through the WGSL preprocessor,
//!    with the entry file kept in this program ([`SHADER`]).
//! 7. The grid is read back: its header (`LightGrid::status`: pairs, dropped) and lists
//!    (`LightGrid::read_lists`); when the index buffer was too small the grid is grown and
//!    the frame drawn again (the contract of `tiledlight_gpu::light_grid`).
//! 8. The check: on the read-back depth, every light that the CPU reference culler
//!    (`tiledlight_cull::reference::cull_tiles`) lists for a tile is in the GPU's list for
//!    that tile (no false negatives), and a few pixels' lists contain every light that
//!    really reaches them. A failed check is an error (exit status 1).
//! 9. The lit image is written as PNG: the first argument, default
//!    `out/light_grid_example.png`.
//!
//! Run with `cargo run -p tiledlight-gpu --example light_grid [-- out.png]`; without a GPU
//! it runs on lavapipe (Mesa's CPU Vulkan) in a few seconds.

use std::collections::BTreeSet;
use std::path::PathBuf;
use tiledlight_gpu::handles::Depth;

use anyhow::{anyhow, bail, ensure, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::reference::{lights_reaching, pixel_view_position};
use tiledlight_cull::{cull_tiles, Camera, CullConfig, Light, Projection, TileGrid};
use tiledlight_gpu::culling::{CullOptions, GpuTileLists, LightCulling, CULL_WORKGROUP_BYTES};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::readback::{read_depth, read_texture};
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::view::{ViewUniforms, Views, MAIN_VIEW};
use tiledlight_gpu::{shader, wgpu, ContextOptions, GpuContext};
use wgpu::util::DeviceExt as _;

/// Small, so that it runs in seconds on lavapipe (CI has no GPU).
const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
const NUM_LIGHTS: usize = 300;
/// The culler needs the depth buffer to be reversed-Z `Depth32Float`.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The shader writes tonemapped linear colour; the sRGB format encodes it for the PNG.
const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// The engine's mesh and shading shader. It is the entry file of a preprocessor run
/// ([`shader_module`]): its `#include`s come from tiledlight's embedded `shaders/`.
/// `vs_main` serves both the depth pipeline and the shading pipeline, from one module, so
/// that both compute bit-identical depths and the shading pass can test depth `Equal`.
const SHADER: &str = r#"
// shade_light (the shared BRDF and windowed attenuation) and, through it, the View uniform
// at group 0 (the camera and the screen).
#include "common/shade.wgsl"

// What common/shade.wgsl and common/light_grid_pixel.wgsl expect the including file to
// declare: the lights' shading data and the light grid (common/light_grid.wgsl), bound
// like the forward shading entries bind them (there at group 3: shaders/common/lights_group.wgsl).
@group(1) @binding(0) var<storage, read> shading_lights: array<ShadingLight>;
@group(1) @binding(1) var<storage, read> light_grid: LightGrid;
@group(1) @binding(2) var<storage, read> light_indices: array<u32>;
@group(1) @binding(3) var<uniform> lighting: Lighting;
#include "common/light_grid_pixel.wgsl"

// This example's own tonemap constant (tiledlight's renderers have a tonemap pass).
const EXPOSURE: f32 = 1.0;

struct MeshVertex {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
}

struct MeshOut {
    // Invariant: the depth and shading pipelines must produce the same depth bits.
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
}

@vertex
fn vs_main(v: MeshVertex) -> MeshOut {
    // The mesh is in world space already (no model matrix in this example).
    return MeshOut(view.world_to_clip * vec4<f32>(v.position, 1.0), v.position, v.normal, v.albedo);
}

@fragment
fn fs_main(in: MeshOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let v = view_vector(in.world_pos);
    let surface = Surface(in.albedo, 0.4, 0.0);
    var color = lighting.ambient * in.albedo;
    // The pixel's list: its tile's (first, count), clipped to what the grid stored.
    let list = pixel_list(vec2<u32>(in.clip.xy), view_distance(in.clip.z));
    for (var i = 0u; i < list.count; i++) {
        color += shade_light(light_indices[list.first + i], in.world_pos, n, v, surface);
    }
    // A simple exponential tonemap; the sRGB target does the encoding.
    return vec4<f32>(vec3<f32>(1.0) - exp(-EXPOSURE * color), 1.0);
}
"#;

/// The name the preprocessor gives [`SHADER`] (in its error messages and line map).
const SHADER_NAME: &str = "examples/light_grid.rs (SHADER)";

fn main() -> Result<()> {
    let out: PathBuf = std::env::args_os().nth(1).map_or_else(|| "out/light_grid_example.png".into(), PathBuf::from);

    // 1. The device. Timestamps off: the example times nothing, and a disabled timer makes
    //    `LightCulling::record` record no queries.
    let ctx = GpuContext::headless(ContextOptions { no_timestamps: true, ..Default::default() })?;
    let (device, queue) = (&ctx.device, &ctx.queue);
    println!("adapter: {}", ctx.describe());

    // 2. The engine's scene and camera.
    let mesh = Mesh::scene();
    let camera = engine_camera(Vec3::new(0.0, 5.0, 11.0), Vec3::new(0.0, 0.0, -5.0), 55.0)?;

    // 3. Lights, culling options, the view.
    let lights = random_lights(NUM_LIGHTS, 0x5eed)?;
    let lights = LightBuffers::new(device, &lights)?;
    let grid = TileGrid::new(WIDTH, HEIGHT, 16)?;
    let options = CullOptions {
        tile_size: grid.tile_size,
        // A workgroup list that holds every light, so no list needs the slower second pass.
        capacity: CullOptions::capacity_for(lights.len(), false, CULL_WORKGROUP_BYTES, &device.limits()),
        // The view-space AABB test on top of the planes: fewer false positives.
        aabb: true,
        ..CullOptions::default()
    };
    let lighting = lights.lighting(device, Vec3::splat(0.03));
    let views = Views::new(device, 1);
    views.write(queue, MAIN_VIEW, &ViewUniforms::new(&camera, WIDTH, HEIGHT));

    // 4. The engine's targets and pipelines. The depth texture is also sampled by the
    //    culling pass and copied out for the CPU check.
    let depth = texture(
        device,
        "example.depth",
        DEPTH_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let depth_view =
        depth.create_view(&wgpu::TextureViewDescriptor { label: Some("example.depth.view"), ..Default::default() });
    let color = texture(
        device,
        "example.color",
        COLOR_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let color_view =
        color.create_view(&wgpu::TextureViewDescriptor { label: Some("example.color.view"), ..Default::default() });
    let module = shader_module(device)?;
    let pipelines = Pipelines::new(device, &views, &module);
    let gpu_mesh = GpuMesh::new(device, &mesh);

    // 5. The culling pass reads the engine's depth view; it owns the light grid.
    let mut culling =
        LightCulling::new(device, &views, Depth { view: &depth_view, samples: 1 }, &lights, &lighting, grid, options)?;
    let timer = GpuTimer::new(&ctx)?;

    // 4-6. One frame in one submission: the engine's depth pass, tiledlight's culling,
    //      the engine's shading pass. 7. Then the grid's header: a frame whose index
    //      buffer was too small (the automatic budget starts at 32 indices a tile) is
    //      drawn again with a grown one, as tiledlight's renderers do between frames.
    let mut attempts = 0;
    let status = loop {
        attempts += 1;
        // The shading group holds the index buffer, which growing re-creates.
        let shading_group = pipelines.shading_group(device, (&lights, &lighting), &culling);
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("example.frame") });
        pipelines.draw_depth(&mut encoder, &views, &gpu_mesh, &depth_view);
        culling.record(&mut encoder, &timer, (&views, MAIN_VIEW), "example.cull");
        pipelines.draw_shaded(&mut encoder, &views, &shading_group, &gpu_mesh, &depth_view, &color_view);
        queue.submit([encoder.finish()]);
        let status = culling.grid.status(device, queue)?;
        match culling.grid.growth(status.needed()) {
            Some(indices) if !status.complete() && attempts == 1 => {
                println!("grid too small ({status}): growing to {indices} indices and drawing again");
                culling.grid.grow(device, queue, indices);
            }
            _ => break status,
        }
    };
    ensure!(status.complete(), "the light grid dropped lights: {status}");

    // 7. The lists the shading pass read, and their statistics.
    let gpu = culling.read_lists(device, queue)?;
    let longest = gpu.counts.iter().copied().max().unwrap_or(0);
    let nonempty = gpu.counts.iter().filter(|&&c| c > 0).count();
    println!(
        "{} lights, grid {}x{} tiles of {} px: {} (tile, light) pairs in {} non-empty lists \
         (mean {:.1}, longest {longest}); index buffer {} indices; dropped {}",
        lights.len(),
        grid.tiles_x,
        grid.tiles_y,
        grid.tile_size,
        status.header.pairs,
        nonempty,
        status.header.pairs as f64 / nonempty.max(1) as f64,
        culling.grid.capacity(),
        status.header.dropped_pairs,
    );

    // 8. The check against the CPU reference, on the depth the GPU culled.
    let depth_values = read_depth(device, queue, &depth)?;
    check_lists(&depth_values, &camera, &lights.packed, &options, &gpu)?;

    // 9. The image.
    let rgba = read_texture(device, queue, &color, wgpu::TextureAspect::All, 4)?;
    let lit = rgba.chunks_exact(4).filter(|p| p[..3].iter().any(|&c| c > 128)).count();
    ensure!(lit > 0, "no pixel is lit: the image shows nothing");
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let image = image::RgbaImage::from_raw(WIDTH, HEIGHT, rgba).ok_or_else(|| anyhow!("image size mismatch"))?;
    image.save(&out)?;
    println!("wrote {} ({WIDTH}x{HEIGHT}, {lit} brightly lit pixels)", out.display());
    Ok(())
}

/// The engine's camera as tiledlight's culler needs it. An engine would pass its own view
/// matrix; the projection must be the reversed-Z one `Camera` builds (depth 1 at the near
/// plane, 0 at infinity), since the depth buffer is drawn with `Camera::view_proj` and
/// the culler turns depths back into distances with the same parameters.
fn engine_camera(eye: Vec3, target: Vec3, fov_y_deg: f32) -> Result<Camera> {
    let view = Mat4::look_at_rh(eye, target, Vec3::Y);
    let projection = Projection::Perspective {
        fov_y: fov_y_deg.to_radians(),
        aspect: WIDTH as f32 / HEIGHT as f32,
        near: 0.1,
        far: None,
    };
    Ok(Camera::from_view(view, projection)?)
}

/// `n` point lights scattered above the ground, seeded so every run draws the same.
fn random_lights(n: usize, seed: u64) -> Result<Vec<Light>> {
    // A tiny generator (SplitMix64) instead of a dependency: any random source will do.
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut lights = Vec::with_capacity(n);
    for _ in 0..n {
        let position = Vec3::new(-14.0 + 28.0 * next(), 0.15 + 1.2 * next(), -24.0 + 30.0 * next());
        let color = Vec3::new(next(), next(), next()) + Vec3::splat(0.05);
        // Brightest channel 1: the radius follows from intensity and threshold alone.
        let color = color / color.max_element();
        // Radius sqrt(intensity / threshold): 2 to 3 m.
        lights.push(Light::point(position, color, 0.2 + 0.25 * next(), 0.05)?);
    }
    Ok(lights)
}

/// Every light the CPU reference lists for a tile must be in the GPU's list (no false
/// negatives), and a few pixels' lists must hold every light that really reaches them.
fn check_lists(
    depth: &[f32],
    camera: &Camera,
    lights: &PackedLights,
    options: &CullOptions,
    gpu: &GpuTileLists,
) -> Result<()> {
    // The CPU runs the GPU's tests (same options), with every light shrunk by 1e-4 of its
    // radius plus distance: CPU and GPU round differently, so a light touching a tile
    // within float error (~1e-5 of that) may be decided either way; the shrunk CPU lists
    // leave those out, and any other missing light is a real false negative.
    let config = CullConfig { inflate: -1e-4, ..options.to_config(!lights.spots.is_empty()) };
    let cpu = cull_tiles(depth, WIDTH, HEIGHT, camera, lights, &config)?;
    let mut pairs = 0;
    // One list per tile here (no half-z), in the same order on both sides.
    for (list, cpu_list) in cpu.lists.iter().enumerate() {
        let gpu_list: BTreeSet<u32> = gpu.lists[list].iter().copied().collect();
        if let Some(missing) = cpu_list.iter().find(|l| !gpu_list.contains(*l)) {
            bail!("list {list}: the CPU reference lists light {missing}, the GPU does not (GPU {gpu_list:?}, CPU {cpu_list:?})");
        }
        pairs += cpu_list.len();
    }
    ensure!(pairs > 0, "the CPU reference lists no light at all: the check proves nothing");
    println!(
        "check: all {pairs} (tile, light) pairs of the CPU reference (lights shrunk by 1e-4) are in the \
         GPU grid's {} pairs: no false negatives",
        gpu.pairs
    );

    // A few pixels: the lights whose radius contains the pixel's surface point (with a
    // margin of 0.1% of the radius, again for float error) all are in its list.
    let grid = cpu.grid;
    for (x, y) in [(40, 170), (160, 150), (160, 110), (250, 120), (104, 50)] {
        let tile = grid.tile_of_pixel(x, y);
        let d = depth[(y * WIDTH + x) as usize];
        let Some(p) = pixel_view_position(camera, WIDTH, HEIGHT, x, y, d) else {
            println!("  pixel ({x:3}, {y:3}): sky, no list read");
            continue;
        };
        let reaching = lights_reaching(&camera.view(), lights, p, 1e-3);
        if let Some(l) = reaching.iter().find(|l| !gpu.lists[tile].contains(*l)) {
            bail!("light {l} reaches pixel ({x}, {y}) but is not in its tile's list");
        }
        println!(
            "  pixel ({x:3}, {y:3}): tile {tile:3}, GPU list {:3} lights, CPU list {:3}, {:2} reach the pixel: all listed",
            gpu.lists[tile].len(),
            cpu.lists[tile].len(),
            reaching.len()
        );
    }
    Ok(())
}

/// One vertex of the engine's mesh (world space).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    albedo: [f32; 3],
}

/// The engine's own geometry: raw vertex and index arrays, nothing of tiledlight-scene.
struct Mesh {
    vertices: Vec<Vertex>,
    indices: Vec<u32>,
}

impl Mesh {
    /// A 40 m ground plane and a few boxes, so that tiles see depth edges and occluders.
    fn scene() -> Self {
        let mut mesh = Mesh { vertices: Vec::new(), indices: Vec::new() };
        mesh.quad(Vec3::new(0.0, 0.0, -8.0), Vec3::Y, Vec3::Z * 20.0, Vec3::X * 20.0, [0.55, 0.55, 0.55]);
        let boxes = [
            (Vec3::new(-4.0, 1.0, -2.0), Vec3::new(1.0, 1.0, 1.0), [0.8, 0.3, 0.2]),
            (Vec3::new(3.5, 1.5, -6.0), Vec3::new(1.5, 1.5, 1.0), [0.2, 0.5, 0.8]),
            (Vec3::new(0.0, 0.5, 1.5), Vec3::new(2.5, 0.5, 0.5), [0.7, 0.7, 0.3]),
            (Vec3::new(-7.0, 3.0, -12.0), Vec3::new(1.0, 3.0, 1.0), [0.4, 0.8, 0.4]),
            (Vec3::new(8.0, 2.0, -14.0), Vec3::new(2.0, 2.0, 2.0), [0.8, 0.8, 0.8]),
        ];
        for (center, half, albedo) in boxes {
            for i in 0..3 {
                for n in [Vec3::AXES[i], -Vec3::AXES[i]] {
                    // u x (n x u) = n: the face's corners go counter-clockwise seen from outside.
                    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                    let (u, v) = (Vec3::AXES[j], n.cross(Vec3::AXES[j]));
                    mesh.quad(center + n * half[i], n, u * half[j], v * half[k], albedo);
                }
            }
        }
        mesh
    }

    /// A rectangle around `center` facing `normal`, with half-extent vectors `u` and `v`
    /// such that `u x v` points along `normal`: its corners `-u-v, +u-v, +u+v, -u+v` are
    /// then counter-clockwise seen from the side it faces (the front face).
    fn quad(&mut self, center: Vec3, normal: Vec3, u: Vec3, v: Vec3, albedo: [f32; 3]) {
        let base = self.vertices.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let p = center + u * su + v * sv;
            self.vertices.push(Vertex { position: p.to_array(), normal: normal.to_array(), albedo });
        }
        self.indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
}

/// The mesh's GPU buffers.
struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

impl GpuMesh {
    fn new(device: &wgpu::Device, mesh: &Mesh) -> Self {
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("example.mesh.vertices"),
            contents: bytemuck::cast_slice(&mesh.vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("example.mesh.indices"),
            contents: bytemuck::cast_slice(&mesh.indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        Self { vertices, indices, index_count: mesh.indices.len() as u32 }
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
    }
}

/// A labelled `WIDTH` x `HEIGHT` texture.
fn texture(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: WIDTH, height: HEIGHT, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// [`SHADER`] with its includes resolved from tiledlight's embedded `shaders/`.
fn shader_module(device: &wgpu::Device) -> Result<wgpu::ShaderModule> {
    let files = |path: &str| {
        if path == SHADER_NAME {
            Some(SHADER.to_owned())
        } else {
            shader::embedded(path).map(str::to_owned)
        }
    };
    // No defines: no half-z, no spot lights (their variants need more bindings).
    let source = shader::preprocess_with(&files, SHADER_NAME, &[])?;
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("example.mesh.shader"),
        source: wgpu::ShaderSource::Wgsl(source.text.into()),
    }))
}

/// The engine's two render pipelines and the shading group's layout.
struct Pipelines {
    depth: wgpu::RenderPipeline,
    shade: wgpu::RenderPipeline,
    shading_layout: wgpu::BindGroupLayout,
}

impl Pipelines {
    fn new(device: &wgpu::Device, views: &Views, module: &wgpu::ShaderModule) -> Self {
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let shading_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("example.shading.layout"),
            entries: &[
                storage(0),
                storage(1),
                storage(2),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let depth_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("example.depth.pipeline_layout"),
            bind_group_layouts: &[Some(&views.layout)],
            immediate_size: 0,
        });
        let shade_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("example.shade.pipeline_layout"),
            bind_group_layouts: &[Some(&views.layout), Some(&shading_layout)],
            immediate_size: 0,
        });
        let vertex_layout = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3],
        })];
        let pipeline = |label: &str, layout: &wgpu::PipelineLayout, shading: bool| {
            let targets = [Some(wgpu::ColorTargetState {
                format: COLOR_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &vertex_layout,
                },
                primitive: wgpu::PrimitiveState { cull_mode: Some(wgpu::Face::Back), ..Default::default() },
                // Reversed-Z: the depth pass keeps the nearest (largest) depth; the shading
                // pass shades only the surface the depth pass kept, once per pixel.
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(!shading),
                    depth_compare: Some(if shading {
                        wgpu::CompareFunction::Equal
                    } else {
                        wgpu::CompareFunction::GreaterEqual
                    }),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: shading.then(|| wgpu::FragmentState {
                    module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        Self {
            depth: pipeline("example.depth", &depth_layout, false),
            shade: pipeline("example.shade", &shade_layout, true),
            shading_layout,
        }
    }

    /// Group 1 of the shading pipeline: lights, light grid, light indices, lighting.
    fn shading_group(
        &self,
        device: &wgpu::Device,
        (lights, lighting): (&LightBuffers, &wgpu::Buffer),
        culling: &LightCulling,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("example.shading.group"),
            layout: &self.shading_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: lights.shading.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: culling.grid.grid.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: culling.grid.indices().as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: lighting.as_entire_binding() },
            ],
        })
    }

    fn draw_depth(&self, encoder: &mut wgpu::CommandEncoder, views: &Views, mesh: &GpuMesh, depth: &wgpu::TextureView) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("example.depth"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                // Reversed-Z clears to 0, which the culler reads as sky.
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.depth);
        pass.set_bind_group(0, views.bind_group(), &views.offsets(MAIN_VIEW));
        mesh.draw(&mut pass);
    }

    fn draw_shaded(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        views: &Views,
        shading_group: &wgpu::BindGroup,
        mesh: &GpuMesh,
        depth: &wgpu::TextureView,
        color: &wgpu::TextureView,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("example.shade"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r: 0.02, g: 0.03, b: 0.06, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.shade);
        pass.set_bind_group(0, views.bind_group(), &views.offsets(MAIN_VIEW));
        pass.set_bind_group(1, shading_group, &[]);
        mesh.draw(&mut pass);
    }
}
