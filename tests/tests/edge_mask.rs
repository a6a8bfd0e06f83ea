//! The visibility method's MSAA edge classification, checked exactly (issue 43, class 9;
//! issue 45's `surface-edges` row): the edge pixels its material pass queues (`is_edge` in
//! `shaders/common/visibility_surface.wgsl`, read back as the frame's edge list) against
//! the CPU's definition computed from the raster's per-sample IDs read back from the
//! multisampled ID target, under both rules:
//!
//! - `surface-edges` off: **a pixel is an edge iff its samples do not all hold the same
//!   ID**; two coplanar adjacent triangles (a quad's diagonal, two abutting panels) make an
//!   edge like a silhouette does.
//! - `surface-edges` on (the default): two IDs make an edge only where their surfaces
//!   differ by the edge test (another material, off sample 0's plane or turned from its
//!   normal beyond the thresholds). This scene's surfaces are flat faces that are either
//!   exactly coplanar (same material, same plane and normal) or far beyond both thresholds
//!   (creases of 30 degrees and more, silhouettes against other materials or the sky), so
//!   the CPU's rule needs no thresholds: **an edge iff the samples do not all lie on one
//!   face** (a box's face, the floor, the two panels' common plane; the sky is a face of
//!   its own).
//!
//! At 4x (what lavapipe has besides 1x), hardware raster (the compute raster draws one
//! sample), a scene without textures (one material dispatch, so each edge pixel is queued
//! exactly once) with silhouettes against the sky and against other objects, creases
//! between a box's faces (interior edges of one mesh), the diagonals of flat quads and two
//! coplanar panels meeting edge to edge. A failure means the edge mask differs from the
//! rule at some pixel: an edge shaded once at its centre (a wrong colour at a silhouette
//! that FLIP forgives) or a flat pixel shaded per sample (wasted work), or a pixel queued
//! twice.

use glam::{Mat4, Vec3};
use tiledlight_cull::visibility::NO_TRIANGLE;
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::{FrameRenderer, FrameSettings, Method, VisibilityFrame};
use tiledlight_gpu::features::Raster;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::GpuContext;
use tiledlight_scene::{Aabb, Instance, Scene};
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::gpu;
use tiledlight_tests::scenes::{cube, material, quad};

const W: u32 = 160;
const H: u32 = 90;
const SAMPLES: u32 = 4;

/// A floor, boxes (one upright, one turned, one tilted so its faces meet at creases seen
/// from the camera), two upright coplanar panels meeting edge to edge and a third, parallel
/// one in front of them; no textures.
fn scene() -> Scene {
    let mut panel = material("panel", [0.3, 0.8, 0.4, 1.0], 0.4, 0.0);
    panel.double_sided = true;
    let materials = vec![
        material("floor", [0.7, 0.7, 0.7, 1.0], 0.8, 0.0),
        material("box", [0.8, 0.3, 0.25, 1.0], 0.5, 0.0),
        panel,
    ];
    let meshes = vec![quad("floor", 12.0), cube("cube"), quad("panel", 1.5)];
    let inst = |mesh, material, transform| Instance { mesh, material, transform };
    let upright = Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let instances = vec![
        inst(0, 0, Mat4::IDENTITY),
        inst(1, 1, Mat4::from_translation(Vec3::new(-1.5, 0.6, 0.0)) * Mat4::from_scale(Vec3::splat(1.2))),
        inst(1, 1, Mat4::from_translation(Vec3::new(1.2, 0.5, -1.0)) * Mat4::from_rotation_y(0.7)),
        inst(
            1,
            1,
            Mat4::from_translation(Vec3::new(0.3, 1.4, 1.2)) * Mat4::from_euler(glam::EulerRot::XYZ, 0.5, 0.4, 0.3),
        ),
        // Coplanar panels: the same plane z = -2.5, abutting at x = 0.75.
        inst(2, 2, Mat4::from_translation(Vec3::new(0.0, 1.5, -2.5)) * upright),
        inst(2, 2, Mat4::from_translation(Vec3::new(1.5, 1.5, -2.5)) * upright),
        // A parallel panel half a metre in front, overlapping both: one material, one
        // normal, another plane (an edge only the plane test finds).
        inst(2, 2, Mat4::from_translation(Vec3::new(0.75, 1.0, -2.0)) * upright),
    ];
    let mut s = Scene {
        name: "edges".into(),
        meshes,
        materials,
        textures: vec![],
        instances,
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    s.bounds = s.compute_bounds();
    s.bounds.max.y = s.bounds.max.y.max(4.0);
    s.validate().expect("valid scene");
    s
}

fn camera() -> Camera {
    Camera::perspective(
        Vec3::new(2.5, 3.0, 6.0),
        Vec3::new(0.0, 0.8, -0.5),
        Vec3::Y,
        50f32.to_radians(),
        W as f32 / H as f32,
        0.1,
        None,
    )
    .expect("camera")
}

const READ_SAMPLES: &str = r#"
@group(0) @binding(0) var ids: texture_multisampled_2d<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(ids);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let n = textureNumSamples(ids);
    for (var s = 0u; s < n; s++) {
        out[(gid.y * size.x + gid.x) * n + s] = textureLoad(ids, gid.xy, i32(s)).x;
    }
}
"#;

/// Every sample's ID of the multisampled ID target `view` (pixel-major, then sample): a
/// test-side compute pass, since a multisampled texture cannot be copied to a buffer.
fn read_sample_ids(ctx: &GpuContext, view: &wgpu::TextureView) -> Vec<u32> {
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("read_sample_ids"),
        source: wgpu::ShaderSource::Wgsl(READ_SAMPLES.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("read_sample_ids"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let out = tiledlight_gpu::util::buffer_zeroed(device, "sample_ids", u64::from(W * H * SAMPLES) * 4, usage);
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("read_sample_ids"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
        ],
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("read_sample_ids") });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(W.div_ceil(8), H.div_ceil(8), 1);
    }
    ctx.queue.submit([enc.finish()]);
    tiledlight_gpu::readback::read_buffer(device, &ctx.queue, &out).expect("sample IDs")
}

/// The rule: pixel p is an edge iff its samples do not all hold sample 0's ID.
fn edge_mask_from_ids(ids: &[u32]) -> Vec<bool> {
    ids.chunks_exact(SAMPLES as usize).map(|s| s.iter().any(|&id| id != s[0])).collect()
}

/// Pixel coordinates (x, y).
type Pixels = Vec<(u32, u32)>;

/// The pixels where `gpu` (the queued edge list, possibly with repeats) and the rule's
/// `mask` differ, and the pixels queued more than once.
fn mask_differences(edges: &[(u32, u32)], mask: &[bool]) -> (Pixels, Pixels) {
    let mut queued = vec![0u32; mask.len()];
    for &(x, y) in edges {
        queued[(y * W + x) as usize] += 1;
    }
    let xy = |p: usize| (p as u32 % W, p as u32 / W);
    let differ = (0..mask.len()).filter(|&p| (queued[p] > 0) != mask[p]).map(xy).collect();
    let twice = (0..mask.len()).filter(|&p| queued[p] > 1).map(xy).collect();
    (differ, twice)
}

#[test]
fn msaa_edge_pixels_are_exactly_those_whose_samples_lie_on_different_surfaces_or_ids() {
    let ctx = gpu();
    assert!(
        tiledlight_tests::adapter_sample_counts(ctx).contains(&SAMPLES),
        "{}x MSAA is needed here (lavapipe and the H200 have it)",
        SAMPLES
    );
    let sc = scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &sc).unwrap();
    let lights = [Light::point(Vec3::new(0.0, 3.0, 1.0), Vec3::ONE, 4.0, 8.0).unwrap()];
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();
    let edge_list = |surface_edges| {
        let knobs = Knobs { raster: Raster::Hardware, surface_edges, ..Knobs::default() };
        let s = FrameSettings { method: Method::Visibility, msaa: SAMPLES, knobs, ..Default::default() };
        let mut r = FrameRenderer::new(ctx, &sg, &lb, W, H, s).unwrap();
        render_frame(ctx, &mut r, &sg, &camera());
        let vf = r.passes::<VisibilityFrame>().expect("visibility");
        let ids = read_sample_ids(ctx, &vf.raster().ids_view);
        let edges = vf.shading().read_edge_list(&ctx.device, &ctx.queue).unwrap();
        (ids, edges, vf.raster().layout)
    };
    let (ids, edges, layout) = edge_list(false);
    let mask = edge_mask_from_ids(&ids);

    // What the scene puts in the mask: each kind of edge is there.
    let (mut sky, mut between, mut within) = (0, 0, 0);
    for s in ids.chunks_exact(SAMPLES as usize).filter(|s| s.iter().any(|&id| id != s[0])) {
        let inst = |id: u32| layout.unpack(id).map(|(i, _)| i);
        if s.contains(&NO_TRIANGLE) {
            sky += 1;
        } else if s.iter().any(|&id| inst(id) != inst(s[0])) {
            between += 1;
        } else {
            within += 1;
        }
    }
    // Coplanar: two IDs of the same instance on one face (the floor's and the panels'
    // diagonals, a box face's), or the two coplanar panels' shared edge.
    let coplanar = |p: usize| {
        let s = &ids[p * SAMPLES as usize..(p + 1) * SAMPLES as usize];
        // The scene's instance of an ID's slot (the GPU scene orders instances its own way).
        let face = |id: u32| {
            layout.unpack(id).map(|(slot, t)| match sg.instance_order[slot as usize] {
                0 => (0, 0),
                4 | 5 => (4, 0),
                i => (i, t / 2),
            })
        };
        mask[p] && s.iter().all(|&id| face(id).is_some() && face(id) == face(s[0]))
    };
    let coplanar_pixels = (0..mask.len()).filter(|&p| coplanar(p)).count();
    eprintln!(
        "{} edge pixels by the rule ({sky} at the sky, {between} between instances, {within} within one; \
         {coplanar_pixels} between coplanar triangles); {} queued",
        mask.iter().filter(|&&m| m).count(),
        edges.len()
    );
    assert!(sky > 20 && between > 20 && within > 20 && coplanar_pixels > 20, "the scene must show every kind of edge");

    let (differ, twice) = mask_differences(&edges, &mask);
    assert!(
        twice.is_empty(),
        "pixels queued more than once (one material dispatch): {:?}",
        &twice[..twice.len().min(8)]
    );
    assert!(
        differ.is_empty(),
        "{} pixels where the edge list and the rule disagree (x, y): {:?}",
        differ.len(),
        &differ[..differ.len().min(12)]
    );

    // The comparison's teeth: the rule read from samples 0 and 1 only, or from samples 0
    // to 2, gives another mask that must fail, as must one pixel removed from the list.
    for n in [2usize, 3] {
        let partial: Vec<bool> =
            ids.chunks_exact(SAMPLES as usize).map(|s| s[..n].iter().any(|&id| id != s[0])).collect();
        assert!(!mask_differences(&edges, &partial).0.is_empty(), "the rule over {n} samples must differ here");
    }
    let mut short = edges.clone();
    short.pop();
    assert!(!mask_differences(&short, &mask).0.is_empty(), "a missing edge pixel must fail");

    // The surface rule (the default): the same raster, the pixels whose samples do not all
    // lie on one face.
    let (ids_on, edges_on, _) = edge_list(true);
    assert_eq!(ids_on, ids, "the rule changes the shading pass only");
    let face_of = |id: u32| {
        layout.unpack(id).map(|(slot, t)| match sg.instance_order[slot as usize] {
            0 => (0, 0),
            4 | 5 => (4, 0),
            i => (i, t / 2),
        })
    };
    let by_face: Vec<bool> =
        ids.chunks_exact(SAMPLES as usize).map(|s| s.iter().any(|&id| face_of(id) != face_of(s[0]))).collect();
    let count = |m: &[bool]| m.iter().filter(|&&e| e).count();
    eprintln!(
        "surface rule: {} edge pixels ({} by IDs; {coplanar_pixels} coplanar ones no longer edges); {} queued",
        count(&by_face),
        count(&mask),
        edges_on.len()
    );
    assert_eq!(count(&mask) - count(&by_face), coplanar_pixels, "exactly the coplanar pixels leave the mask");
    let (differ, twice) = mask_differences(&edges_on, &by_face);
    assert!(twice.is_empty(), "pixels queued twice: {:?}", &twice[..twice.len().min(8)]);
    assert!(
        differ.is_empty(),
        "{} pixels where the edge list and the surface rule disagree (x, y): {:?}",
        differ.len(),
        &differ[..differ.len().min(12)]
    );
    // The teeth: the ID rule's list fails the surface rule here, and the surface rule's the
    // ID rule.
    assert!(!mask_differences(&edges, &by_face).0.is_empty() && !mask_differences(&edges_on, &mask).0.is_empty());
}
