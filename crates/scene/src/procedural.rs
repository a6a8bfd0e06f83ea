//! The procedural scenes. The default scene: an atrium-like courtyard (Sponza-like:
//! floor, four walls, two storeys of columns and arches along the long sides, gallery
//! floors, balustrades, banners and clutter, no roof) plus TiledLighting11's grid objects,
//! the stress knob of instanced UV spheres, any number of them alpha-blended glass. The
//! shadow box scene ([`shadow_box_scene`]): a cube on or above a floor, small enough for
//! the shadow tests to ray-cast every pixel.
//! Deterministic: the same options give the same scene. Depends on glam, this crate's
//! model, geometry and error modules.
//!
//! Layout (metres): the open courtyard spans x in [-8, 8], z in [-18, 18], y in
//! [0, 13]; the outer walls are 0.5 m thick outside it. Column rows stand at x = +-6,
//! every 3 m from z = -15 to 15; galleries run between the columns and the walls.

use std::f32::consts::{FRAC_PI_2, PI};

use glam::{Mat4, Quat, Vec2, Vec3};

use crate::error::SceneError;
use crate::geometry::{add_arch_wall, add_banner, add_box, add_grid, add_lathe, add_uv_sphere, arc, MeshBuilder};
use crate::model::{Aabb, AlphaMode, CameraDesc, Instance, Material, Mesh, Scene, Texture, TextureRef};

/// The most grid objects the default scene lays out (TiledLighting11's slider maximum).
pub const MAX_GRID_OBJECTS: u32 = 280;

/// Tessellation of the grid objects, as in TiledLighting11.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GridDensity {
    /// 11 stacks, 22 slices: 484 triangles per object.
    Low,
    /// 21 stacks, 42 slices: 1764 triangles per object.
    #[default]
    Medium,
    /// 30 stacks, 60 slices: 3600 triangles per object.
    High,
}

impl GridDensity {
    /// The flag value: `low`, `medium` or `high`.
    pub const fn name(self) -> &'static str {
        match self {
            GridDensity::Low => "low",
            GridDensity::Medium => "medium",
            GridDensity::High => "high",
        }
    }

    /// Stacks of the UV sphere (it has twice as many slices).
    pub fn stacks(self) -> u32 {
        match self {
            GridDensity::Low => 11,
            GridDensity::Medium => 21,
            GridDensity::High => 30,
        }
    }

    /// Triangles of one grid object: `4 * stacks^2`.
    pub fn triangles_per_object(self) -> u64 {
        let s = u64::from(self.stacks());
        4 * s * s
    }
}

/// Options of [`default_scene`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DefaultSceneOptions {
    /// Number of grid objects, 0 to [`MAX_GRID_OBJECTS`].
    pub grid_objects: u32,
    /// Their tessellation.
    pub density: GridDensity,
    /// How many of the grid objects are glass (an alpha-blended material, see
    /// [`default_scene`]), 0 to `grid_objects`; spread evenly over the grid.
    pub transparent_objects: u32,
    /// The banners glow in their colour (an emissive factor equal to their base colour):
    /// a scene with emission, so Tiled Deferred's G-buffer gets its emission target and
    /// both methods their emission path, on the courtyard's geometry (the benchmark of that
    /// cost: the same frame with and without it).
    pub emissive_banners: bool,
}

impl Default for DefaultSceneOptions {
    /// No grid objects, medium density, none transparent, no emission.
    fn default() -> Self {
        Self { grid_objects: 0, density: GridDensity::Medium, transparent_objects: 0, emissive_banners: false }
    }
}

// Courtyard dimensions (metres).
const HALF_WIDTH: f32 = 8.0;
const HALF_LENGTH: f32 = 18.0;
const WALL_HEIGHT: f32 = 13.0;
const WALL_THICKNESS: f32 = 0.5;
const COLUMN_X: f32 = 6.0;
const BAY: f32 = 3.0;
/// Number of arch bays along each long side (36 m / 3 m).
const BAYS: i32 = 12;
const ARCH_INNER: f32 = 1.1;
const ARCH_OUTER: f32 = 1.5;
const ARCH_DEPTH: f32 = 0.6;
const LOWER_COLUMN_HEIGHT: f32 = 4.4;
const UPPER_COLUMN_HEIGHT: f32 = 4.0;
const SLAB_THICKNESS: f32 = 0.4;
const LOWER_SLAB_Y: f32 = LOWER_COLUMN_HEIGHT + ARCH_OUTER;
const UPPER_FLOOR_Y: f32 = LOWER_SLAB_Y + SLAB_THICKNESS;
const UPPER_SLAB_Y: f32 = UPPER_FLOOR_Y + UPPER_COLUMN_HEIGHT + ARCH_OUTER;
/// The gallery slabs reach this far into the courtyard (just past the arches' faces).
const SLAB_INNER_X: f32 = COLUMN_X - ARCH_DEPTH * 0.5;

// Tessellation.
const COLUMN_SEGMENTS: u32 = 32;
const ARCH_STEPS: u32 = 48;
const BALUSTER_SEGMENTS: u32 = 12;
const BALUSTERS_PER_BAY: u32 = 6;
const URN_SEGMENTS: u32 = 32;

// Grid objects: a regular lattice on the floor between the column rows, kept clear of
// the column plinths (x = +-5.55) and of the camera at the +z end.
const GRID_RADIUS: f32 = 0.4;
const GRID_MIN: Vec2 = Vec2::new(-5.2, -17.0);
const GRID_MAX: Vec2 = Vec2::new(5.2, 14.0);
const GRID_MAX_COLUMNS: u32 = 10;
const GRID_MAX_ROWS: u32 = 28;

// Material indices in the default scene.
const M_FLOOR: usize = 0;
const M_WALL: usize = 1;
const M_COLUMN: usize = 2;
const M_ARCH: usize = 3;
const M_SLAB: usize = 4;
const M_BRONZE: usize = 5;
const M_FABRIC_RED: usize = 6;
const M_FABRIC_BLUE: usize = 7;
const M_FABRIC_GREEN: usize = 8;
const M_TERRACOTTA: usize = 9;
const M_GOLD: usize = 10;
const M_GRID: usize = 11;
const M_WOOD: usize = 12;
/// Only present when some grid objects are transparent.
const M_GLASS: usize = 13;

fn material(name: &str, rgb: [f32; 3], roughness: f32, metallic: f32) -> Material {
    Material {
        name: name.to_owned(),
        base_color: [rgb[0], rgb[1], rgb[2], 1.0],
        roughness,
        metallic,
        ..Material::default()
    }
}

fn materials() -> Vec<Material> {
    let mut m = vec![
        Material { base_color_texture: Some(TextureRef::new(0)), ..material("stone floor", [1.0, 1.0, 1.0], 0.8, 0.0) },
        material("plaster walls", [0.70, 0.62, 0.50], 0.9, 0.0),
        material("marble columns", [0.80, 0.78, 0.74], 0.35, 0.0),
        material("sandstone arches", [0.62, 0.55, 0.46], 0.7, 0.0),
        material("gallery stone", [0.55, 0.50, 0.45], 0.75, 0.0),
        material("bronze", [0.80, 0.50, 0.25], 0.4, 1.0),
        material("red fabric", [0.60, 0.08, 0.06], 0.9, 0.0),
        material("blue fabric", [0.10, 0.20, 0.55], 0.9, 0.0),
        material("green fabric", [0.12, 0.40, 0.12], 0.85, 0.0),
        material("terracotta", [0.60, 0.30, 0.18], 0.6, 0.0),
        material("gold", [1.00, 0.78, 0.34], 0.3, 1.0),
        material("grid objects", [0.80, 0.80, 0.80], 0.5, 0.0),
        material("wood crates", [0.45, 0.30, 0.16], 0.75, 0.0),
    ];
    // Banners hang in the open and are seen from both sides.
    for i in [M_FABRIC_RED, M_FABRIC_BLUE, M_FABRIC_GREEN] {
        m[i].double_sided = true;
    }
    m
}

/// The transparent grid objects' material: clear glass with a faint blue-green tint,
/// alpha-blended at 35% opacity, smooth, both sides drawn (a sphere's far inner side shows
/// through its near side).
fn glass_material() -> Material {
    Material {
        base_color: [0.85, 0.95, 0.92, 0.35],
        alpha_mode: AlphaMode::Blend,
        double_sided: true,
        ..material("glass grid objects", [0.85, 0.95, 0.92], 0.05, 0.0)
    }
}

/// A 64x64 sRGB checker of two stone tones with 8-pixel squares, so the texture path
/// of every renderer is exercised without shipping an asset.
fn checker_texture() -> Texture {
    let (w, h) = (64u32, 64u32);
    let mut rgba8 = Vec::with_capacity((w * h * 4) as usize);
    for y in 0..h {
        for x in 0..w {
            let light = ((x / 8) + (y / 8)) % 2 == 0;
            let c: [u8; 4] = if light { [196, 186, 166, 255] } else { [140, 130, 116, 255] };
            rgba8.extend_from_slice(&c);
        }
    }
    Texture { name: "stone checker".to_owned(), width: w, height: h, rgba8 }
}

/// Column profile (radius, height) with plinth, torus, shaft with entasis, astragal,
/// flared capital and abacus, for a column `height` tall.
fn column_profile(height: f32) -> Vec<Vec2> {
    let mut p = vec![Vec2::new(0.0, 0.0), Vec2::new(0.45, 0.0), Vec2::new(0.45, 0.16), Vec2::new(0.38, 0.16)];
    p.extend(arc(Vec2::new(0.36, 0.24), 0.08, -90.0, 90.0, 10));
    p.push(Vec2::new(0.31, 0.32));
    p.push(Vec2::new(0.30, 0.36));
    let (shaft_bottom, shaft_top) = (0.40, height - 0.55);
    let steps = 14;
    for i in 0..=steps {
        let t = i as f32 / steps as f32;
        // Entasis: a slight swelling a third of the way up, tapering to the top.
        let r = 0.29 - 0.035 * t + 0.012 * (PI * t).sin();
        p.push(Vec2::new(r, shaft_bottom + t * (shaft_top - shaft_bottom)));
    }
    p.extend(arc(Vec2::new(0.26, height - 0.50), 0.04, -90.0, 90.0, 8));
    // Echinus: a convex cushion flaring out to the abacus.
    for i in 1..=10 {
        let a = FRAC_PI_2 * i as f32 / 10.0;
        p.push(Vec2::new(0.26 + 0.20 * a.sin(), height - 0.46 + 0.30 * (1.0 - a.cos())));
    }
    p.push(Vec2::new(0.48, height - 0.16));
    p.push(Vec2::new(0.48, height));
    p.push(Vec2::new(0.0, height));
    p
}

fn column_mesh(name: &str, height: f32) -> Mesh {
    let mut b = MeshBuilder::new();
    add_lathe(&mut b, Vec3::ZERO, &column_profile(height), COLUMN_SEGMENTS, 40.0);
    b.build(name)
}

fn arch_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    add_arch_wall(&mut b, ARCH_INNER, ARCH_OUTER, ARCH_DEPTH, ARCH_STEPS);
    b.build("arch")
}

/// One bay of balustrade between two upper columns, centred on z = 0 in the column
/// plane: a plinth, a top rail, and turned balusters.
fn balustrade_mesh() -> Mesh {
    let half = BAY * 0.5 - 0.32;
    let mut b = MeshBuilder::new();
    add_box(&mut b, Vec3::new(-0.1, 0.0, -half), Vec3::new(0.1, 0.1, half), 10.0);
    add_box(&mut b, Vec3::new(-0.11, 0.92, -half), Vec3::new(0.11, 1.02, half), 10.0);
    let profile: Vec<Vec2> = [
        (0.0, 0.0),
        (0.065, 0.0),
        (0.065, 0.06),
        (0.04, 0.10),
        (0.05, 0.18),
        (0.068, 0.30),
        (0.07, 0.40),
        (0.06, 0.50),
        (0.04, 0.60),
        (0.03, 0.66),
        (0.045, 0.70),
        (0.06, 0.74),
        (0.06, 0.82),
        (0.0, 0.82),
    ]
    .iter()
    .map(|&(r, y)| Vec2::new(r, y))
    .collect();
    let inner = half - 0.2;
    for i in 0..BALUSTERS_PER_BAY {
        let z = -inner + 2.0 * inner * i as f32 / (BALUSTERS_PER_BAY - 1) as f32;
        add_lathe(&mut b, Vec3::new(0.0, 0.1, z), &profile, BALUSTER_SEGMENTS, 50.0);
    }
    b.build("balustrade bay")
}

fn urn_mesh() -> Mesh {
    let mut p = vec![Vec2::new(0.0, 0.0), Vec2::new(0.22, 0.0), Vec2::new(0.22, 0.06), Vec2::new(0.12, 0.12)];
    // Body: a bulb from the foot to the shoulder.
    p.extend(arc(Vec2::new(0.0, 0.55), 0.42, -70.0, 60.0, 20).into_iter().skip(1));
    p.extend([Vec2::new(0.16, 0.98), Vec2::new(0.15, 1.08), Vec2::new(0.24, 1.14), Vec2::new(0.24, 1.18)]);
    // The rim turns inward and down into the mouth, so the urn reads as hollow.
    p.extend([Vec2::new(0.20, 1.18), Vec2::new(0.17, 1.05), Vec2::new(0.0, 1.05)]);
    let mut b = MeshBuilder::new();
    add_lathe(&mut b, Vec3::ZERO, &p, URN_SEGMENTS, 40.0);
    b.build("urn")
}

fn planter_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    add_box(&mut b, Vec3::new(-0.45, 0.0, -0.45), Vec3::new(0.45, 0.6, 0.45), 0.3);
    b.build("planter box")
}

fn bush_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    add_uv_sphere(&mut b, Vec3::ZERO, 0.5, 16, 32);
    b.build("bush")
}

fn ball_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    add_uv_sphere(&mut b, Vec3::ZERO, 0.25, 12, 24);
    b.build("gold ball")
}

/// Crates stacked in the lower galleries, merged into one mesh (they never move).
fn crates_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    let mut unit = MeshBuilder::new();
    add_box(&mut unit, Vec3::splat(-0.5), Vec3::splat(0.5), 0.25);
    let stacks: [(f32, f32, f32, f32); 8] = [
        // (x, z, size, yaw degrees)
        (7.1, -16.2, 0.9, 10.0),
        (7.3, -10.4, 0.7, -25.0),
        (-7.0, -7.6, 1.0, 5.0),
        (-7.2, 7.0, 0.8, 40.0),
        (7.0, 7.4, 1.0, -8.0),
        (7.2, 13.4, 0.6, 30.0),
        (-7.1, 16.0, 0.9, -15.0),
        (-7.3, -11.0, 0.7, 20.0),
    ];
    for (x, z, s, yaw) in stacks {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::splat(s),
            Quat::from_rotation_y(yaw.to_radians()),
            Vec3::new(x, s * 0.5, z),
        );
        b.append(&unit, m);
        // A smaller crate on top of the larger ones.
        if s >= 0.9 {
            let top = Mat4::from_scale_rotation_translation(
                Vec3::splat(s * 0.55),
                Quat::from_rotation_y((yaw + 35.0).to_radians()),
                Vec3::new(x, s + s * 0.275, z),
            );
            b.append(&unit, top);
        }
    }
    b.build("crates")
}

fn floor_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    let (w, l) = (2.0 * HALF_WIDTH, 2.0 * HALF_LENGTH);
    // Texture tiles every 2 m; 0.5 m cells give vertex-lit debugging views something to show.
    add_grid(
        &mut b,
        Vec3::new(-HALF_WIDTH, 0.0, HALF_LENGTH),
        Vec3::new(w, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -l),
        (w / 0.5) as u32,
        (l / 0.5) as u32,
        2.0,
    );
    b.build("floor")
}

fn walls_mesh() -> Mesh {
    let (hw, hl, t, h) = (HALF_WIDTH, HALF_LENGTH, WALL_THICKNESS, WALL_HEIGHT);
    let mut b = MeshBuilder::new();
    add_box(&mut b, Vec3::new(hw, 0.0, -hl - t), Vec3::new(hw + t, h, hl + t), 1.0);
    add_box(&mut b, Vec3::new(-hw - t, 0.0, -hl - t), Vec3::new(-hw, h, hl + t), 1.0);
    add_box(&mut b, Vec3::new(-hw, 0.0, hl), Vec3::new(hw, h, hl + t), 0.5);
    add_box(&mut b, Vec3::new(-hw, 0.0, -hl - t), Vec3::new(hw, h, -hl), 1.0);
    b.build("walls")
}

fn slabs_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    for y in [LOWER_SLAB_Y, UPPER_SLAB_Y] {
        for side in [-1.0f32, 1.0] {
            let (x0, x1) = (side * SLAB_INNER_X, side * HALF_WIDTH);
            add_box(
                &mut b,
                Vec3::new(x0.min(x1), y, -HALF_LENGTH),
                Vec3::new(x0.max(x1), y + SLAB_THICKNESS, HALF_LENGTH),
                1.0,
            );
        }
    }
    b.build("gallery slabs")
}

fn grid_mesh(density: GridDensity) -> Mesh {
    let s = density.stacks();
    let mut b = MeshBuilder::new();
    add_uv_sphere(&mut b, Vec3::ZERO, GRID_RADIUS, s, 2 * s);
    b.build("grid object")
}

/// Centres of `n` grid objects: the most square lattice of at most 10 columns and 28
/// rows that holds them, spread over the grid area, the last row centred.
fn grid_positions(n: u32) -> Vec<Vec3> {
    if n == 0 {
        return Vec::new();
    }
    let area = GRID_MAX - GRID_MIN;
    let cols = ((n as f32 * area.x / area.y).sqrt().ceil() as u32).clamp(1, GRID_MAX_COLUMNS);
    let cols = cols.max(n.div_ceil(GRID_MAX_ROWS));
    let rows = n.div_ceil(cols);
    let cell = Vec2::new(area.x / cols as f32, area.y / rows as f32);
    let mut out = Vec::with_capacity(n as usize);
    for r in 0..rows {
        let in_row = (n - r * cols).min(cols);
        // Centre a partial row: shift by half the missing cells.
        let shift = (cols - in_row) as f32 * 0.5;
        for c in 0..in_row {
            let x = GRID_MIN.x + (c as f32 + 0.5 + shift) * cell.x;
            let z = GRID_MIN.y + (r as f32 + 0.5) * cell.y;
            out.push(Vec3::new(x, GRID_RADIUS, z));
        }
    }
    out
}

/// Which of `n` grid objects (in [`grid_positions`] order) are transparent when `k` are:
/// the middle of each of `k` equal runs, so they spread evenly over the rows of the grid.
fn transparent_indices(n: u32, k: u32) -> impl Iterator<Item = u32> {
    (0..k).map(move |j| (2 * j + 1) * n / (2 * k))
}

/// Builds the courtyard with `opts.grid_objects` grid spheres. Lights are left empty
/// (generate them with [`crate::random_lights`] from the scene's bounds).
///
/// `opts.transparent_objects` of the grid objects, spread evenly over the grid (the same
/// ones for the same options), use a glass material: [`AlphaMode::Blend`], base colour
/// alpha 0.35, roughness 0.05, a faint blue-green tint, double-sided. The material is only
/// added to the scene when some grid object uses it, so a scene without transparent
/// objects has no blended material at all.
///
/// About 250,000 triangles before grid objects; each grid object adds
/// [`GridDensity::triangles_per_object`].
pub fn default_scene(opts: &DefaultSceneOptions) -> Result<Scene, SceneError> {
    if opts.grid_objects > MAX_GRID_OBJECTS {
        return Err(SceneError::TooManyGridObjects { requested: opts.grid_objects, max: MAX_GRID_OBJECTS });
    }
    if opts.transparent_objects > opts.grid_objects {
        return Err(SceneError::TooManyTransparentObjects {
            requested: opts.transparent_objects,
            grid_objects: opts.grid_objects,
        });
    }
    let mut meshes = Vec::new();
    let mut instances = Vec::new();
    let mut add_mesh = |mesh: Mesh| {
        meshes.push(mesh);
        meshes.len() - 1
    };
    let mut place =
        |mesh: usize, material: usize, transform: Mat4| instances.push(Instance { mesh, material, transform });

    let floor = add_mesh(floor_mesh());
    let walls = add_mesh(walls_mesh());
    let slabs = add_mesh(slabs_mesh());
    let lower_column = add_mesh(column_mesh("lower column", LOWER_COLUMN_HEIGHT));
    let upper_column = add_mesh(column_mesh("upper column", UPPER_COLUMN_HEIGHT));
    let arch = add_mesh(arch_mesh());
    let balustrade = add_mesh(balustrade_mesh());
    let banner = add_mesh({
        let mut b = MeshBuilder::new();
        add_banner(&mut b, 1.3, 4.2, 12, 40);
        b.build("banner")
    });
    let urn = add_mesh(urn_mesh());
    let planter = add_mesh(planter_mesh());
    let bush = add_mesh(bush_mesh());
    let ball = add_mesh(ball_mesh());
    let crates = add_mesh(crates_mesh());
    let grid = add_mesh(grid_mesh(opts.density));

    place(floor, M_FLOOR, Mat4::IDENTITY);
    place(walls, M_WALL, Mat4::IDENTITY);
    place(slabs, M_SLAB, Mat4::IDENTITY);
    place(crates, M_WOOD, Mat4::IDENTITY);

    let t = |x: f32, y: f32, z: f32| Mat4::from_translation(Vec3::new(x, y, z));
    for side in [-1.0f32, 1.0] {
        let x = side * COLUMN_X;
        // Columns between the bays; the bays at both ends rest on the end walls.
        for i in 1..BAYS {
            let z = -HALF_LENGTH + BAY * i as f32;
            place(lower_column, M_COLUMN, t(x, 0.0, z));
            place(upper_column, M_COLUMN, t(x, UPPER_FLOOR_Y, z));
        }
        for i in 0..BAYS {
            let z = -HALF_LENGTH + BAY * (i as f32 + 0.5);
            place(arch, M_ARCH, t(x, LOWER_COLUMN_HEIGHT, z));
            place(arch, M_ARCH, t(x, UPPER_FLOOR_Y + UPPER_COLUMN_HEIGHT, z));
            place(balustrade, M_BRONZE, t(x, UPPER_FLOOR_Y, z));
            // Banners hang from the upper gallery in every other bay, in front of the
            // arches, facing the courtyard (the mesh faces +X).
            if i % 2 == 1 {
                let fabric = [M_FABRIC_RED, M_FABRIC_BLUE, M_FABRIC_GREEN][(i as usize / 2) % 3];
                let facing = if side > 0.0 { Mat4::from_rotation_y(PI) } else { Mat4::IDENTITY };
                place(banner, fabric, t(side * (COLUMN_X - 0.55), UPPER_SLAB_Y - 0.2, z) * facing);
            }
        }
    }

    // Urns, planters with bushes and gold balls in the lower galleries.
    let gallery_x = 0.5 * (COLUMN_X + 0.45 + HALF_WIDTH);
    for (k, z) in [-13.5f32, -4.5, 1.5, 10.5].into_iter().enumerate() {
        for side in [-1.0f32, 1.0] {
            let yaw = Mat4::from_rotation_y(FRAC_PI_2 * k as f32 + side);
            place(urn, M_TERRACOTTA, t(side * gallery_x, 0.0, z) * yaw);
        }
    }
    for z in [-1.5f32, 4.5] {
        for side in [-1.0f32, 1.0] {
            let x = side * gallery_x;
            place(planter, M_TERRACOTTA, t(x, 0.0, z));
            place(bush, M_FABRIC_GREEN, t(x, 0.95, z));
        }
    }
    for (x, z) in [(7.0f32, -8.8f32), (-7.0, -3.0), (7.1, 3.0), (-7.0, 12.5), (7.2, -6.0), (-7.1, -6.2)] {
        place(ball, M_GOLD, t(x, 0.25, z));
    }

    let mut glass = transparent_indices(opts.grid_objects, opts.transparent_objects).peekable();
    for (i, p) in (0u32..).zip(grid_positions(opts.grid_objects)) {
        let material = if glass.next_if_eq(&i).is_some() { M_GLASS } else { M_GRID };
        place(grid, material, Mat4::from_translation(p));
    }
    let mut materials = materials();
    if opts.transparent_objects > 0 {
        materials.push(glass_material());
    }
    if opts.emissive_banners {
        for i in [M_FABRIC_RED, M_FABRIC_BLUE, M_FABRIC_GREEN] {
            let [r, g, b, _] = materials[i].base_color;
            materials[i].emissive = [r, g, b];
        }
    }

    let mut scene = Scene {
        name: "courtyard".to_owned(),
        meshes,
        materials,
        textures: vec![checker_texture()],
        instances,
        lights: Vec::new(),
        camera: Some(CameraDesc {
            eye: Vec3::new(0.0, 1.7, HALF_LENGTH - 1.5),
            target: Vec3::new(0.0, 2.6, -HALF_LENGTH),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: None,
        }),
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    Ok(scene)
}

// The shadow box scene (metres).
const SHADOW_FLOOR_HALF: f32 = 10.0;
/// Floor cells per side: 2.5 m cells, so the floor has vertices under and around the
/// cube's shadow instead of being two huge triangles.
const SHADOW_FLOOR_CELLS: u32 = 8;
const SHADOW_BOX_HALF: f32 = 1.0;

/// A scene for shadow tests: a 20 m x 20 m floor (y = 0, facing +Y, 8 x 8 cells of
/// 2.5 m, centred on the origin) and a closed 2 m cube over the origin, x and z in
/// [-1, 1], y in `[gap, gap + 2]` (outward normals, counter-clockwise front faces seen from
/// outside, 2 x 2 cells per face: 176 triangles in all). `gap` 0 rests the cube on the
/// floor (contact shadows); `gap > 0` makes it hover. The cube is one mesh placed by its
/// instance's translation, so the instance transform path is exercised too. No lights
/// (the tests add them) and no textures; the camera looks down at the cube from above
/// at an angle (from (9, 12, 15) m, 60 degree vertical field of view).
///
/// # Panics
///
/// When `gap` is negative, NaN or infinite.
pub fn shadow_box_scene(gap: f32) -> Scene {
    assert!(gap.is_finite() && gap >= 0.0, "shadow_box_scene: gap {gap} must be finite and >= 0");
    let half = SHADOW_FLOOR_HALF;
    let mut floor = MeshBuilder::new();
    // Corner (-10, 0, 10), edges +X and -Z: faces +Y (the winding of `floor_mesh`).
    add_grid(
        &mut floor,
        Vec3::new(-half, 0.0, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        SHADOW_FLOOR_CELLS,
        SHADOW_FLOOR_CELLS,
        2.0,
    );
    let mut cube = MeshBuilder::new();
    let h = SHADOW_BOX_HALF;
    add_box(&mut cube, Vec3::new(-h, 0.0, -h), Vec3::new(h, 2.0 * h, h), h);
    let mut scene = Scene {
        name: format!("shadow box (gap {gap} m)"),
        meshes: vec![floor.build("floor"), cube.build("cube")],
        materials: vec![material("floor", [0.8, 0.8, 0.8], 0.8, 0.0), material("cube", [0.7, 0.45, 0.25], 0.5, 0.0)],
        textures: Vec::new(),
        instances: vec![
            Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY },
            Instance { mesh: 1, material: 1, transform: Mat4::from_translation(Vec3::new(0.0, gap, 0.0)) },
        ],
        lights: Vec::new(),
        camera: Some(CameraDesc {
            eye: Vec3::new(9.0, 12.0, 15.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: None,
        }),
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tests::check_mesh;
    use tiledlight_cull::raycast::Triangles;

    #[test]
    fn shadow_box_scene_shape() {
        for gap in [0.0f32, 0.5] {
            let scene = shadow_box_scene(gap);
            scene.validate().unwrap();
            assert!(scene.lights.is_empty());
            assert_eq!(scene.triangle_count(), 8 * 8 * 2 + 6 * 2 * 2 * 2);
            for mesh in &scene.meshes {
                check_mesh(mesh);
            }
            let b = scene.bounds;
            assert_eq!(b, Aabb::new(Vec3::new(-10.0, 0.0, -10.0), Vec3::new(10.0, gap + 2.0, 10.0)));
            // Floor: every normal +Y at y = 0.
            let floor = &scene.meshes[scene.instances[0].mesh];
            assert!(floor.normals.iter().all(|n| *n == [0.0, 1.0, 0.0]));
            assert!(floor.positions.iter().all(|p| p[1] == 0.0));
            // Cube: normals point away from its centre (outward), in world space too.
            let cube = &scene.instances[1];
            let centre = Vec3::new(0.0, gap + 1.0, 0.0);
            let mesh = &scene.meshes[cube.mesh];
            for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
                let world = cube.transform.transform_point3(Vec3::from_array(*p));
                assert!(Vec3::from_array(*n).dot(world - centre) > 0.5, "{world}");
                assert!(world.y >= gap && world.y <= gap + 2.0 && world.x.abs() <= 1.0 && world.z.abs() <= 1.0);
            }
            // The camera is above, outside the cube, and looks down at it.
            let cam = scene.camera.unwrap();
            assert!(cam.eye.y > gap + 2.0 && (cam.target - cam.eye).y < 0.0);
        }
    }

    #[test]
    fn shadow_box_scene_casts_the_expected_shadows() {
        let light = Vec3::new(0.0, 8.0, 0.0);
        for gap in [0.0f32, 0.5] {
            let bvh = Triangles::new(shadow_box_scene(gap).world_triangles());
            assert_eq!(bvh.len(), 176);
            // Under the cube, and in its shadow just outside its footprint (the shadow of
            // a 2 m cube's top face from 8 m above reaches 1 * 8 / (6 - gap) m out).
            assert!(bvh.occluded(Vec3::new(0.0, 0.0, 0.0), light, 1e-4));
            assert!(bvh.occluded(Vec3::new(1.2, 0.0, 0.3), light, 1e-4));
            // Far from it, lit; the cube's own top is lit.
            assert!(!bvh.occluded(Vec3::new(5.0, 0.0, -5.0), light, 1e-4));
            assert!(!bvh.occluded(Vec3::new(0.3, gap + 2.0, 0.2), light, 1e-4));
            // The cube is closed: a ray from its centre escapes in no direction.
            let centre = Vec3::new(0.0, gap + 1.0, 0.0);
            for d in
                [Vec3::X, Vec3::NEG_Y, Vec3::new(1.0, 1.0, 1.0), Vec3::new(-0.3, -1.0, 0.7), Vec3::new(1.0, 0.0, 1.0)]
            {
                let t = bvh.first_hit(centre, d, f32::INFINITY).unwrap();
                assert!(t <= 3f32.sqrt() + 1e-5, "{d}: {t}");
            }
        }
        // Hovering, a light at floor level sees under the cube; resting, it does not.
        let side = Vec3::new(-6.0, 0.25, 0.0);
        let beyond = Vec3::new(6.0, 0.0, 0.0);
        assert!(!Triangles::new(shadow_box_scene(0.5).world_triangles()).occluded(side, beyond, 1e-4));
        assert!(Triangles::new(shadow_box_scene(0.0).world_triangles()).occluded(side, beyond, 1e-4));
    }

    #[test]
    #[should_panic(expected = "gap -1 must be finite")]
    fn shadow_box_scene_rejects_a_negative_gap() {
        shadow_box_scene(-1.0);
    }

    #[test]
    fn default_scene_triangles_in_range_and_valid() {
        let scene = default_scene(&DefaultSceneOptions::default()).unwrap();
        scene.validate().unwrap();
        let tris = scene.triangle_count();
        assert!((230_000..=270_000).contains(&tris), "{tris} triangles");
        for mesh in &scene.meshes {
            check_mesh(mesh);
        }
        // The courtyard plus its walls.
        let b = scene.bounds;
        assert!((b.min - Vec3::new(-8.5, 0.0, -18.5)).abs().max_element() < 1e-4, "{b:?}");
        assert!((b.max - Vec3::new(8.5, 13.0, 18.5)).abs().max_element() < 1e-4, "{b:?}");
        assert!(scene.lights.is_empty());
        let cam = scene.camera.unwrap();
        assert_eq!(cam.far, None);
        assert!((cam.fov_y - 60f32.to_radians()).abs() < 1e-6);
        assert!(b.contains(cam.eye) && cam.target.z < cam.eye.z);
        assert!(!scene.has_alpha_mask() && !scene.has_blend() && !scene.has_spot_lights());
        assert!(scene.materials.iter().any(|m| m.base_color_texture.is_some()));
    }

    #[test]
    fn default_scene_is_deterministic() {
        let opts = DefaultSceneOptions {
            grid_objects: 17,
            density: GridDensity::Low,
            transparent_objects: 5,
            ..Default::default()
        };
        assert_eq!(default_scene(&opts).unwrap(), default_scene(&opts).unwrap());
    }

    #[test]
    fn grid_objects_counts_per_density() {
        let base = default_scene(&DefaultSceneOptions::default()).unwrap();
        for (density, per_object) in [(GridDensity::Low, 484), (GridDensity::Medium, 1764), (GridDensity::High, 3600)] {
            assert_eq!(density.triangles_per_object(), per_object);
            for n in [1u32, 7, 100, 280] {
                let opts = DefaultSceneOptions { grid_objects: n, density, ..Default::default() };
                let scene = default_scene(&opts).unwrap();
                let grid: Vec<&Instance> = scene.instances.iter().filter(|i| i.material == M_GRID).collect();
                assert_eq!(grid.len(), n as usize);
                // All grid objects share one mesh, so the renderer can instance them.
                let mesh = grid[0].mesh;
                assert!(grid.iter().all(|i| i.mesh == mesh));
                assert_eq!(scene.meshes[mesh].triangle_count(), per_object);
                assert_eq!(scene.triangle_count(), base.triangle_count() + u64::from(n) * per_object);
                if n == 280 {
                    scene.validate().unwrap();
                }
            }
        }
    }

    #[test]
    fn grid_objects_stay_apart_and_inside() {
        for n in [1u32, 2, 10, 11, 29, 100, 279, 280] {
            let p = grid_positions(n);
            assert_eq!(p.len(), n as usize);
            for (i, a) in p.iter().enumerate() {
                // Inside the column rows (plinths reach x = +-5.55) and on the floor.
                assert!(a.x.abs() + GRID_RADIUS < COLUMN_X - 0.45, "{a}");
                assert!(a.z - GRID_RADIUS > -HALF_LENGTH && a.z + GRID_RADIUS < HALF_LENGTH, "{a}");
                assert_eq!(a.y, GRID_RADIUS);
                for b in &p[i + 1..] {
                    assert!(a.distance(*b) > 2.0 * GRID_RADIUS + 0.1, "n {n}: {a} and {b} overlap");
                }
            }
        }
    }

    #[test]
    fn too_many_grid_objects_rejected() {
        let opts = DefaultSceneOptions { grid_objects: 281, density: GridDensity::Low, ..Default::default() };
        let err = default_scene(&opts).unwrap_err();
        assert!(matches!(err, SceneError::TooManyGridObjects { requested: 281, max: 280 }));
        assert!(err.to_string().contains("281") && err.to_string().contains("280"));
    }

    /// The grid instances of `scene` that use an alpha-blended material, and all of them.
    fn blended_grid_instances(scene: &Scene) -> (Vec<&Instance>, usize) {
        let grid: Vec<&Instance> =
            scene.instances.iter().filter(|i| scene.meshes[i.mesh].name == "grid object").collect();
        let n = grid.len();
        (grid.into_iter().filter(|i| scene.materials[i.material].alpha_mode == AlphaMode::Blend).collect(), n)
    }

    #[test]
    fn emissive_banners_glow_in_their_colour_and_change_nothing_else() {
        let plain = default_scene(&DefaultSceneOptions::default()).unwrap();
        assert!(!plain.materials.iter().any(Material::is_emissive), "the courtyard emits nothing by default");
        let lit = default_scene(&DefaultSceneOptions { emissive_banners: true, ..Default::default() }).unwrap();
        lit.validate().unwrap();
        let glowing: Vec<&str> = lit.materials.iter().filter(|m| m.is_emissive()).map(|m| m.name.as_str()).collect();
        assert_eq!(glowing, ["red fabric", "blue fabric", "green fabric"]);
        for m in lit.materials.iter().filter(|m| m.is_emissive()) {
            assert_eq!(m.emissive, [m.base_color[0], m.base_color[1], m.base_color[2]], "{}", m.name);
        }
        // The banners are drawn: some instance uses each glowing material.
        for i in [M_FABRIC_RED, M_FABRIC_BLUE, M_FABRIC_GREEN] {
            assert!(lit.instances.iter().any(|inst| inst.material == i), "material {i} unused");
        }
        // Same geometry and bounds, the other materials alike.
        assert_eq!(
            (lit.meshes.len(), lit.instances.len(), lit.bounds),
            (plain.meshes.len(), plain.instances.len(), plain.bounds)
        );
        let strip =
            |s: &Scene| s.materials.iter().map(|m| Material { emissive: [0.0; 3], ..m.clone() }).collect::<Vec<_>>();
        assert_eq!(strip(&lit), strip(&plain));
    }

    #[test]
    fn transparent_objects_are_glass_grid_objects() {
        let base =
            default_scene(&DefaultSceneOptions { grid_objects: 100, density: GridDensity::Low, ..Default::default() })
                .unwrap();
        for (n, k) in [(0u32, 0u32), (1, 0), (1, 1), (7, 3), (10, 10), (100, 1), (100, 10), (280, 99), (280, 280)] {
            let opts = DefaultSceneOptions {
                grid_objects: n,
                density: GridDensity::Low,
                transparent_objects: k,
                ..Default::default()
            };
            let scene = default_scene(&opts).unwrap();
            scene.validate().unwrap();
            let (glass, grid) = blended_grid_instances(&scene);
            assert_eq!((glass.len(), grid), (k as usize, n as usize), "{opts:?}");
            // Nothing but the glass grid objects is blended; the opaque ones keep their material.
            let blended = scene.instances.iter().filter(|i| scene.materials[i.material].alpha_mode == AlphaMode::Blend);
            assert_eq!(blended.count(), k as usize);
            assert_eq!(scene.instances.iter().filter(|i| i.material == M_GRID).count(), (n - k) as usize);
            assert_eq!(scene.has_blend(), k > 0, "{opts:?}");
            assert!(!scene.has_alpha_mask());
            // The glass material exists only when used.
            assert_eq!(scene.materials.len(), if k > 0 { M_GLASS + 1 } else { M_GLASS }, "{opts:?}");
            if n == 100 && k == 10 {
                // The all-opaque scene but for the glass material and the instances using it.
                let mut opaque = scene.clone();
                opaque.materials.pop();
                opaque.instances.iter_mut().filter(|i| i.material == M_GLASS).for_each(|i| i.material = M_GRID);
                assert_eq!(opaque, base);
            }
        }
    }

    #[test]
    fn glass_material_is_blended_light_and_double_sided() {
        let scene =
            default_scene(&DefaultSceneOptions { grid_objects: 4, transparent_objects: 2, ..Default::default() })
                .unwrap();
        let m = &scene.materials[M_GLASS];
        assert_eq!(m.alpha_mode, AlphaMode::Blend);
        assert!(m.double_sided);
        assert!((0.3..=0.4).contains(&m.base_color[3]), "alpha {}", m.base_color[3]);
        assert!(m.roughness <= 0.1 && m.metallic == 0.0);
        // A light tint: every channel bright.
        let rgb = &m.base_color[..3];
        assert!(rgb.iter().all(|c| (0.8..=1.0).contains(c)), "{rgb:?}");
        assert!(m.base_color_texture.is_none());
    }

    #[test]
    fn transparent_objects_spread_over_the_grid() {
        for (n, k) in [(100u32, 10u32), (280, 28), (30, 3), (9, 2)] {
            let opts = DefaultSceneOptions { grid_objects: n, transparent_objects: k, ..Default::default() };
            let idx: Vec<u32> = transparent_indices(n, k).collect();
            assert!(idx.windows(2).all(|w| w[0] < w[1]) && idx.iter().all(|&i| i < n), "{idx:?}");
            // Every run of n/k consecutive grid objects holds one, so they span the grid's
            // rows from end to end.
            let run = n / k;
            assert!(idx[0] < run && idx[k as usize - 1] >= n - run, "{idx:?}");
            assert!(idx.windows(2).all(|w| w[1] - w[0] <= run + 1), "{idx:?}");
            let scene = default_scene(&opts).unwrap();
            let zs: Vec<f32> = blended_grid_instances(&scene).0.iter().map(|i| i.transform.w_axis.z).collect();
            let all = grid_positions(n);
            let (lo, hi) = all.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p.z), hi.max(p.z)));
            let (glo, ghi) = zs.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &z| (lo.min(z), hi.max(z)));
            // k evenly spread objects span about 1 - 1/k of the grid's length.
            let span = 1.0 - 1.5 / k as f32;
            assert!(ghi - glo >= span * (hi - lo), "{opts:?}: glass z {glo}..{ghi} of {lo}..{hi}");
        }
    }

    #[test]
    fn more_transparent_than_grid_objects_rejected() {
        for (n, k) in [(0u32, 1u32), (5, 6), (280, 281)] {
            let opts = DefaultSceneOptions { grid_objects: n, transparent_objects: k, ..Default::default() };
            let err = default_scene(&opts).unwrap_err();
            assert!(
                matches!(err, SceneError::TooManyTransparentObjects { requested, grid_objects } if requested == k && grid_objects == n)
            );
            let msg = err.to_string();
            for word in ["transparent_objects", "grid_objects", &k.to_string(), &n.to_string()] {
                assert!(msg.contains(word), "{msg:?} does not mention {word:?}");
            }
        }
        // Too many grid objects is reported first.
        let opts = DefaultSceneOptions { grid_objects: 281, transparent_objects: 300, ..Default::default() };
        assert!(matches!(default_scene(&opts), Err(SceneError::TooManyGridObjects { .. })));
    }
}
