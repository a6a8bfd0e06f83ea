//! Mesh building blocks for the procedural scenes: a builder that appends vertices and
//! triangles, and the shapes the courtyard is made of (subdivided boxes and planes, UV
//! spheres, surfaces of revolution, arch walls, hanging banners). Every shape winds its
//! front faces counter-clockwise seen from outside and writes unit normals.
//! Depends on glam and this crate's model only.

use std::f32::consts::{PI, TAU};

use glam::{Mat3, Mat4, Vec2, Vec3};

use crate::model::Mesh;

/// Accumulates one mesh.
#[derive(Clone, Debug, Default)]
pub(crate) struct MeshBuilder {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    indices: Vec<u32>,
}

impl MeshBuilder {
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Adds a vertex (the normal is normalised) and returns its index.
    pub(crate) fn vertex(&mut self, p: Vec3, n: Vec3, uv: Vec2) -> u32 {
        let index = self.positions.len() as u32;
        self.positions.push(p.to_array());
        self.normals.push(n.normalize_or(Vec3::Y).to_array());
        self.uvs.push(uv.to_array());
        index
    }

    pub(crate) fn triangle(&mut self, a: u32, b: u32, c: u32) {
        self.indices.extend_from_slice(&[a, b, c]);
    }

    fn position(&self, i: u32) -> Vec3 {
        Vec3::from_array(self.positions[i as usize])
    }

    fn normal(&self, i: u32) -> Vec3 {
        Vec3::from_array(self.normals[i as usize])
    }

    /// Adds the quad `a b c d` (a ring of vertices) as two triangles, wound so they face
    /// the side the vertex normals point to. Choosing the winding from the normals keeps
    /// every hand-built shape consistent without reasoning about each one's orientation.
    pub(crate) fn quad_facing_normals(&mut self, a: u32, b: u32, c: u32, d: u32) {
        let n = self.normal(a) + self.normal(b) + self.normal(c) + self.normal(d);
        let (pa, pb, pc, pd) = (self.position(a), self.position(b), self.position(c), self.position(d));
        let geometric = (pb - pa).cross(pc - pa) + (pc - pa).cross(pd - pa);
        if geometric.dot(n) >= 0.0 {
            self.triangle(a, b, c);
            self.triangle(a, c, d);
        } else {
            self.triangle(a, c, b);
            self.triangle(a, d, c);
        }
    }

    /// A flat quad with one normal for all four corners.
    pub(crate) fn flat_quad(&mut self, corners: [Vec3; 4], normal: Vec3, uvs: [Vec2; 4]) {
        let v: Vec<u32> = corners.iter().zip(uvs).map(|(&p, uv)| self.vertex(p, normal, uv)).collect();
        self.quad_facing_normals(v[0], v[1], v[2], v[3]);
    }

    /// Appends `other` transformed by `m` (normals by its inverse transpose; mirrored
    /// transforms get their winding flipped so front faces stay counter-clockwise).
    pub(crate) fn append(&mut self, other: &MeshBuilder, m: Mat4) {
        let base = self.positions.len() as u32;
        let normal_matrix = Mat3::from_mat4(m).inverse().transpose();
        for ((p, n), uv) in other.positions.iter().zip(&other.normals).zip(&other.uvs) {
            let p = m.transform_point3(Vec3::from_array(*p));
            let n = normal_matrix * Vec3::from_array(*n);
            self.vertex(p, n, Vec2::from_array(*uv));
        }
        let flip = m.determinant() < 0.0;
        for t in other.indices.chunks_exact(3) {
            if flip {
                self.triangle(base + t[0], base + t[2], base + t[1]);
            } else {
                self.triangle(base + t[0], base + t[1], base + t[2]);
            }
        }
    }

    #[cfg(test)]
    pub(crate) fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub(crate) fn build(self, name: &str) -> Mesh {
        Mesh {
            name: name.to_owned(),
            positions: self.positions,
            normals: self.normals,
            uvs: self.uvs,
            indices: self.indices,
            ..Mesh::default()
        }
    }
}

/// A planar grid from `origin` spanning edges `eu` and `ev`, split into `nu` x `nv`
/// cells, facing `eu x ev`. UVs are in metres along the edges divided by `uv_scale`
/// (so textures tile at a fixed world size).
pub(crate) fn add_grid(b: &mut MeshBuilder, origin: Vec3, eu: Vec3, ev: Vec3, nu: u32, nv: u32, uv_scale: f32) {
    let normal = eu.cross(ev).normalize();
    let (lu, lv) = (eu.length(), ev.length());
    let base = b.positions.len() as u32;
    for j in 0..=nv {
        for i in 0..=nu {
            let (fu, fv) = (i as f32 / nu as f32, j as f32 / nv as f32);
            b.vertex(origin + eu * fu + ev * fv, normal, Vec2::new(fu * lu, fv * lv) / uv_scale);
        }
    }
    let row = nu + 1;
    for j in 0..nv {
        for i in 0..nu {
            let a = base + j * row + i;
            b.quad_facing_normals(a, a + 1, a + 1 + row, a + row);
        }
    }
}

/// The six faces of the box `min..max`, each split into cells of at most `cell` metres.
pub(crate) fn add_box(b: &mut MeshBuilder, min: Vec3, max: Vec3, cell: f32) {
    let d = max - min;
    let cells = |len: f32| ((len / cell).ceil() as u32).max(1);
    let faces = [
        (Vec3::new(max.x, min.y, max.z), Vec3::new(0.0, 0.0, -d.z), Vec3::new(0.0, d.y, 0.0)),
        (Vec3::new(min.x, min.y, min.z), Vec3::new(0.0, 0.0, d.z), Vec3::new(0.0, d.y, 0.0)),
        (Vec3::new(min.x, max.y, max.z), Vec3::new(d.x, 0.0, 0.0), Vec3::new(0.0, 0.0, -d.z)),
        (Vec3::new(min.x, min.y, min.z), Vec3::new(d.x, 0.0, 0.0), Vec3::new(0.0, 0.0, d.z)),
        (Vec3::new(min.x, min.y, max.z), Vec3::new(d.x, 0.0, 0.0), Vec3::new(0.0, d.y, 0.0)),
        (Vec3::new(max.x, min.y, min.z), Vec3::new(-d.x, 0.0, 0.0), Vec3::new(0.0, d.y, 0.0)),
    ];
    for (origin, eu, ev) in faces {
        add_grid(b, origin, eu, ev, cells(eu.length()), cells(ev.length()), 1.0);
    }
}

/// A UV sphere with `stacks` stacks and `slices` slices and exactly
/// `2 * stacks * slices` triangles: the quads touching the poles keep both triangles
/// (one of them degenerate), which is how TiledLighting11 counts its grid objects
/// (484 / 1764 / 3600 triangles for 11 / 21 / 30 stacks).
pub(crate) fn add_uv_sphere(b: &mut MeshBuilder, center: Vec3, radius: f32, stacks: u32, slices: u32) {
    let base = b.positions.len() as u32;
    for i in 0..=stacks {
        let phi = PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let theta = TAU * j as f32 / slices as f32;
            let n = Vec3::new(phi.sin() * theta.sin(), phi.cos(), phi.sin() * theta.cos());
            b.vertex(center + n * radius, n, Vec2::new(j as f32 / slices as f32, i as f32 / stacks as f32));
        }
    }
    let row = slices + 1;
    for i in 0..stacks {
        for j in 0..slices {
            let top = base + i * row + j;
            let bottom = top + row;
            // Viewed from outside, `bottom, bottom+1, top+1, top` runs counter-clockwise.
            b.triangle(bottom, bottom + 1, top + 1);
            b.triangle(bottom, top + 1, top);
        }
    }
}

/// A surface of revolution around +Y through `center`: `profile` holds (radius, height)
/// points, bottom to top, and is swept through `segments` steps. Neighbouring profile
/// segments meeting at less than `smooth_degrees` share a smoothed normal; sharper
/// corners get a crease. Rings on the axis (radius 0) emit one triangle per step, not a
/// degenerate pair.
pub(crate) fn add_lathe(b: &mut MeshBuilder, center: Vec3, profile: &[Vec2], segments: u32, smooth_degrees: f32) {
    let seg_normal = |k: usize| {
        let d = profile[k + 1] - profile[k];
        Vec2::new(d.y, -d.x).normalize_or(Vec2::X)
    };
    let smooth_cos = smooth_degrees.to_radians().cos();
    let joined = |n0: Vec2, n1: Vec2| {
        if n0.dot(n1) >= smooth_cos {
            (n0 + n1).normalize_or(n1)
        } else {
            n1
        }
    };
    let total: f32 = profile.windows(2).map(|w| (w[1] - w[0]).length()).sum::<f32>().max(1e-6);
    let mut travelled = 0.0;
    for k in 0..profile.len().saturating_sub(1) {
        let (p0, p1) = (profile[k], profile[k + 1]);
        let nk = seg_normal(k);
        let n_start = if k > 0 { joined(seg_normal(k - 1), nk) } else { nk };
        let n_end = if k + 2 < profile.len() { joined(seg_normal(k + 1), nk) } else { nk };
        let v0 = travelled / total;
        travelled += (p1 - p0).length();
        let v1 = travelled / total;
        let base = b.positions.len() as u32;
        for (p, n, v) in [(p0, n_start, v0), (p1, n_end, v1)] {
            for j in 0..=segments {
                let theta = TAU * j as f32 / segments as f32;
                let (s, c) = theta.sin_cos();
                let pos = center + Vec3::new(p.x * s, p.y, p.x * c);
                let nrm = Vec3::new(n.x * s, n.y, n.x * c);
                b.vertex(pos, nrm, Vec2::new(j as f32 / segments as f32, v));
            }
        }
        let row = segments + 1;
        for j in 0..segments {
            let (a0, a1, b0, b1) = (base + j, base + j + 1, base + row + j, base + row + j + 1);
            if p0.x > 0.0 {
                b.triangle(a0, a1, b1);
            }
            if p1.x > 0.0 {
                b.triangle(a0, b1, b0);
            }
        }
    }
}

/// Points on a circular arc in the profile plane, from `a0` to `a1` degrees
/// (0 = +radius direction, 90 = up), `steps` segments, endpoints included.
pub(crate) fn arc(center: Vec2, radius: f32, a0: f32, a1: f32, steps: u32) -> Vec<Vec2> {
    (0..=steps)
        .map(|i| {
            let a = (a0 + (a1 - a0) * i as f32 / steps as f32).to_radians();
            center + Vec2::new(a.cos(), a.sin()) * radius
        })
        .collect()
}

/// An arch wall: the block `z in [-outer, outer]`, `y in [0, outer]`,
/// `x in [-depth/2, depth/2]` with a semicircular opening of radius `inner` centred on
/// the spring line (y = 0). Its intrados is a tessellated half-annulus of `steps`
/// segments (`steps` is rounded up to a multiple of 4 so the wall's corners fall on
/// sample angles); the spandrels fill the square above. `6 * steps + 10` triangles.
pub(crate) fn add_arch_wall(b: &mut MeshBuilder, inner: f32, outer: f32, depth: f32, steps: u32) {
    let steps = steps.div_ceil(4).max(1) * 4;
    let hx = depth * 0.5;
    let dirs: Vec<Vec2> = (0..=steps)
        .map(|k| {
            let phi = PI * k as f32 / steps as f32;
            Vec2::new(phi.cos(), phi.sin())
        })
        .collect();
    // (z, y) of the opening and of the wall outline along the same rays.
    let inner_pts: Vec<Vec2> = dirs.iter().map(|d| *d * inner).collect();
    let outer_pts: Vec<Vec2> = dirs.iter().map(|d| *d * (outer / d.x.abs().max(d.y))).collect();
    let at = |x: f32, zy: Vec2| Vec3::new(x, zy.y, zy.x);
    for (x, n) in [(hx, Vec3::X), (-hx, Vec3::NEG_X)] {
        for k in 0..steps as usize {
            let quad = [inner_pts[k], outer_pts[k], outer_pts[k + 1], inner_pts[k + 1]];
            let uvs = quad.map(|zy| Vec2::new(zy.x, -zy.y));
            b.flat_quad(quad.map(|zy| at(x, zy)), n, uvs);
        }
    }
    for k in 0..steps as usize {
        let (d0, d1) = (dirs[k], dirs[k + 1]);
        let (n0, n1) = (-at(0.0, d0), -at(0.0, d1));
        let s = |k: usize| PI * inner * k as f32 / steps as f32;
        let v = [
            b.vertex(at(hx, inner_pts[k]), n0, Vec2::new(0.0, s(k))),
            b.vertex(at(-hx, inner_pts[k]), n0, Vec2::new(depth, s(k))),
            b.vertex(at(-hx, inner_pts[k + 1]), n1, Vec2::new(depth, s(k + 1))),
            b.vertex(at(hx, inner_pts[k + 1]), n1, Vec2::new(0.0, s(k + 1))),
        ];
        b.quad_facing_normals(v[0], v[1], v[2], v[3]);
    }
    let face = |b: &mut MeshBuilder, corners: [Vec3; 4], n: Vec3| {
        b.flat_quad(corners, n, [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
    };
    let (o, i) = (outer, inner);
    face(
        b,
        [at(hx, Vec2::new(o, 0.0)), at(-hx, Vec2::new(o, 0.0)), at(-hx, Vec2::new(o, o)), at(hx, Vec2::new(o, o))],
        Vec3::Z,
    );
    face(
        b,
        [at(hx, Vec2::new(-o, 0.0)), at(-hx, Vec2::new(-o, 0.0)), at(-hx, Vec2::new(-o, o)), at(hx, Vec2::new(-o, o))],
        Vec3::NEG_Z,
    );
    face(
        b,
        [at(hx, Vec2::new(-o, o)), at(-hx, Vec2::new(-o, o)), at(-hx, Vec2::new(o, o)), at(hx, Vec2::new(o, o))],
        Vec3::Y,
    );
    for (z0, z1) in [(i, o), (-o, -i)] {
        face(
            b,
            [
                at(hx, Vec2::new(z0, 0.0)),
                at(-hx, Vec2::new(z0, 0.0)),
                at(-hx, Vec2::new(z1, 0.0)),
                at(hx, Vec2::new(z1, 0.0)),
            ],
            Vec3::NEG_Y,
        );
    }
}

/// A hanging cloth banner in the plane x = 0, facing +X: `width` along Z (centred),
/// hanging `height` down from y = 0, with a gentle sideways wave so lights graze it.
/// `nu` x `nv` cells.
pub(crate) fn add_banner(b: &mut MeshBuilder, width: f32, height: f32, nu: u32, nv: u32) {
    let amplitude = 0.06;
    let wavelength = width / 1.5;
    let k = TAU / wavelength;
    let base = b.positions.len() as u32;
    for j in 0..=nv {
        for i in 0..=nu {
            let (fu, fv) = (i as f32 / nu as f32, j as f32 / nv as f32);
            let z = (fu - 0.5) * width;
            // The wave grows towards the free bottom edge, as cloth hangs.
            let a = amplitude * (0.3 + 0.7 * fv);
            let x = a * (k * z).sin();
            let dxdz = a * k * (k * z).cos();
            let n = Vec3::new(1.0, 0.0, -dxdz);
            b.vertex(Vec3::new(x, -fv * height, z), n, Vec2::new(fu, fv));
        }
    }
    let row = nu + 1;
    for j in 0..nv {
        for i in 0..nu {
            let a = base + j * row + i;
            b.quad_facing_normals(a, a + 1, a + 1 + row, a + row);
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Checks the invariants every generated mesh must keep: matching attribute
    /// lengths, unit normals, indices in range, and every non-degenerate triangle facing
    /// the way its vertex normals point (counter-clockwise front faces).
    pub(crate) fn check_mesh(mesh: &Mesh) {
        let n = mesh.positions.len();
        assert_eq!(mesh.normals.len(), n, "{}", mesh.name);
        assert_eq!(mesh.uvs.len(), n, "{}", mesh.name);
        assert_eq!(mesh.indices.len() % 3, 0, "{}", mesh.name);
        for (i, nrm) in mesh.normals.iter().enumerate() {
            let len = Vec3::from_array(*nrm).length();
            assert!((len - 1.0).abs() < 1e-4, "{}: normal {i} has length {len}", mesh.name);
        }
        assert!(mesh.indices.iter().all(|&i| (i as usize) < n), "{}: index out of range", mesh.name);
        for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let p = [tri[0], tri[1], tri[2]].map(|i| Vec3::from_array(mesh.positions[i as usize]));
            let geometric = (p[1] - p[0]).cross(p[2] - p[0]);
            if geometric.length() < 1e-7 {
                continue;
            }
            let shading: Vec3 = tri.iter().map(|&i| Vec3::from_array(mesh.normals[i as usize])).sum();
            assert!(
                geometric.normalize().dot(shading.normalize()) > 0.2,
                "{}: triangle {t} faces away from its normals",
                mesh.name
            );
        }
    }

    #[test]
    fn sphere_has_exact_triangle_count() {
        for s in [3u32, 11, 21, 30] {
            let mut b = MeshBuilder::new();
            add_uv_sphere(&mut b, Vec3::ZERO, 1.0, s, 2 * s);
            assert_eq!(b.triangle_count() as u32, 4 * s * s);
            check_mesh(&b.build("sphere"));
        }
    }

    #[test]
    fn shapes_are_consistent() {
        let mut b = MeshBuilder::new();
        add_box(&mut b, Vec3::new(-1.0, 0.0, -2.0), Vec3::new(1.0, 3.0, 2.0), 0.5);
        assert_eq!(b.triangle_count(), 2 * 2 * (4 * 6 + 4 * 8 + 6 * 8));
        check_mesh(&b.build("box"));

        let mut b = MeshBuilder::new();
        add_arch_wall(&mut b, 1.1, 1.5, 0.6, 48);
        assert_eq!(b.triangle_count(), 6 * 48 + 10);
        check_mesh(&b.build("arch"));

        let mut b = MeshBuilder::new();
        let mut profile = vec![Vec2::new(0.0, 0.0), Vec2::new(0.5, 0.0)];
        profile.extend(arc(Vec2::new(0.5, 0.5), 0.5, -90.0, 90.0, 8));
        profile.push(Vec2::new(0.0, 1.0));
        add_lathe(&mut b, Vec3::ZERO, &profile, 16, 40.0);
        // Bands touching the axis have one triangle per step.
        assert_eq!(b.triangle_count(), 16 * (2 * (profile.len() - 3) + 2));
        check_mesh(&b.build("lathe"));

        let mut b = MeshBuilder::new();
        add_banner(&mut b, 1.2, 4.0, 6, 20);
        assert_eq!(b.triangle_count(), 2 * 6 * 20);
        check_mesh(&b.build("banner"));
    }

    #[test]
    fn append_mirrors_keep_winding() {
        let mut src = MeshBuilder::new();
        add_box(&mut src, Vec3::ZERO, Vec3::ONE, 1.0);
        let mut b = MeshBuilder::new();
        b.append(&src, Mat4::from_scale(Vec3::new(-1.0, 2.0, 1.0)));
        check_mesh(&b.build("mirrored"));
    }
}
