//! A mesh split into clusters (meshlets) of at most a fixed number of triangles, each with
//! its bounds: what the compute rasteriser (issue 29) culls per cluster on the GPU.
//! The triangles are ordered along a Morton (Z-order) curve of their centroids in the
//! mesh's bounds and cut into consecutive runs, so a cluster is a contiguous range of that
//! order (the mesh's index buffer is left as it is) and spatially compact (not the minimal-bounds optimum a
//! meshoptimizer-style builder finds: the order is one sort, deterministic, and good enough
//! for frustum and bounds culling; measured in the tests on a grid mesh). Depends on the
//! scene model and glam.

use glam::Vec3;

use crate::model::{Aabb, Mesh, Scene};

/// The compute rasteriser's cluster size: at most this many triangles a cluster.
pub const CLUSTER_TRIANGLES: u32 = 128;

/// One cluster: a range of the reordered triangles and their bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// First slot of [`Clustered::order`] it holds.
    pub first_triangle: u32,
    /// Triangles, 1 to the cluster size.
    pub triangles: u32,
    /// Object-space bounds of its triangles.
    pub bounds: Aabb,
}

/// A mesh's triangles in clusters: the mesh's index buffer stays as it is (each triangle
/// keeps its vertex order, so its winding); the clusters name its triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct Clustered {
    /// The mesh's triangles in cluster order: per slot, the triangle's index in the mesh.
    pub order: Vec<u32>,
    /// The clusters, in order, covering every triangle once.
    pub clusters: Vec<Cluster>,
}

/// Spreads the low 21 bits of `v` three apart (the Morton interleave).
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x1f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x1f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// The 63-bit Morton code of `p` within `b` (21 bits an axis).
fn morton(p: Vec3, b: &Aabb) -> u64 {
    let extent = (b.max - b.min).max(Vec3::splat(f32::MIN_POSITIVE));
    let q = ((p - b.min) / extent).clamp(Vec3::ZERO, Vec3::ONE) * ((1u32 << 21) - 1) as f32;
    spread(q.x as u64) | (spread(q.y as u64) << 1) | (spread(q.z as u64) << 2)
}

/// Every mesh of `scene` in clusters of [`CLUSTER_TRIANGLES`] ([`cluster_mesh`]), in mesh
/// order: what the compute raster culls. The GPU scene keeps each mesh's own index order
/// (the hardware raster's vertex reuse depends on it, and blending within a mesh follows
/// it); a cluster names its triangles through [`Clustered::order`].
pub fn cluster_scene(scene: &Scene) -> Vec<Clustered> {
    scene.meshes.iter().map(|m| cluster_mesh(m, CLUSTER_TRIANGLES)).collect()
}

/// Splits `mesh` into clusters of at most `max_triangles` (at least 1) triangles.
pub fn cluster_mesh(mesh: &Mesh, max_triangles: u32) -> Clustered {
    let max = max_triangles.max(1) as usize;
    let bounds = mesh.bounds();
    let pos = |i: u32| Vec3::from(mesh.positions[i as usize]);
    let tris: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let mut order: Vec<(u64, usize)> =
        tris.iter().enumerate().map(|(k, t)| (morton((pos(t[0]) + pos(t[1]) + pos(t[2])) / 3.0, &bounds), k)).collect();
    // Stable by triangle index within one code: deterministic.
    order.sort_unstable();
    runs(mesh, &tris, order.into_iter().map(|(_, k)| k), max)
}

/// The triangles `tris` of `mesh` in `order`, cut into runs of `max`.
fn runs(mesh: &Mesh, tris: &[[u32; 3]], order: impl Iterator<Item = usize>, max: usize) -> Clustered {
    let pos = |i: u32| Vec3::from(mesh.positions[i as usize]);
    let order: Vec<usize> = order.collect();
    let mut clusters = Vec::with_capacity(order.len().div_ceil(max));
    let triangle_order = order.iter().map(|&k| k as u32).collect();
    for (c, run) in order.chunks(max).enumerate() {
        let mut b = Aabb::empty();
        for &k in run {
            for &i in &tris[k] {
                b.min = b.min.min(pos(i));
                b.max = b.max.max(pos(i));
            }
        }
        clusters.push(Cluster { first_triangle: (c * max) as u32, triangles: run.len() as u32, bounds: b });
    }
    Clustered { order: triangle_order, clusters }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n x n grid of quads in the XZ plane (2 n^2 triangles), its rows in order.
    fn grid(n: u32) -> Mesh {
        let mut m = Mesh { name: "grid".into(), ..Default::default() };
        for z in 0..=n {
            for x in 0..=n {
                m.positions.push([x as f32, 0.0, z as f32]);
                m.normals.push([0.0, 1.0, 0.0]);
                m.uvs.push([0.0, 0.0]);
            }
        }
        let v = |x: u32, z: u32| z * (n + 1) + x;
        for z in 0..n {
            for x in 0..n {
                m.indices.extend_from_slice(&[
                    v(x, z),
                    v(x, z + 1),
                    v(x + 1, z),
                    v(x + 1, z),
                    v(x, z + 1),
                    v(x + 1, z + 1),
                ]);
            }
        }
        m
    }

    /// Every triangle lands in exactly one cluster; clusters hold at
    /// most the maximum and are as few as it allows; bounds hold their triangles.
    #[test]
    fn clusters_partition_the_triangles() {
        let m = grid(37);
        let c = cluster_mesh(&m, CLUSTER_TRIANGLES);
        let n = m.indices.len() / 3;
        assert_eq!(c.clusters.len(), n.div_ceil(CLUSTER_TRIANGLES as usize));
        let mut seen = vec![false; n];
        for &t in &c.order {
            assert!(!std::mem::replace(&mut seen[t as usize], true), "triangle {t} twice");
        }
        assert!(seen.iter().all(|&s| s), "every triangle once");
        let mut next = 0;
        for cl in &c.clusters {
            assert_eq!(cl.first_triangle, next);
            assert!((1..=CLUSTER_TRIANGLES).contains(&cl.triangles));
            next += cl.triangles;
            for t in cl.first_triangle..cl.first_triangle + cl.triangles {
                for k in 0..3 {
                    let i = m.indices[(c.order[t as usize] * 3 + k) as usize];
                    let p = Vec3::from(m.positions[i as usize]);
                    assert!(p.cmpge(cl.bounds.min).all() && p.cmple(cl.bounds.max).all());
                }
            }
        }
        assert_eq!(next as usize, n);
    }

    /// Spatially compact: on a 64 x 64 grid (8,192 triangles, 64 clusters of 128, each
    /// could be an 8 x 8 patch) a cluster's longer side is on average at most 16 (Morton
    /// order of a regular grid cuts square patches: measured 8); runs of the mesh's own
    /// row-by-row order are one-row strips 64 long and fail. Degenerate and empty meshes
    /// work.
    #[test]
    fn clusters_are_compact() {
        let m = grid(64);
        let side = |b: Aabb| (b.max.x - b.min.x).max(b.max.z - b.min.z);
        let c = cluster_mesh(&m, CLUSTER_TRIANGLES);
        let mean = c.clusters.iter().map(|cl| side(cl.bounds)).sum::<f32>() / c.clusters.len() as f32;
        eprintln!("mean longer side of a cluster: {mean}");
        assert!(mean <= 16.0, "{mean}");
        // The check's teeth: runs of 128 in the mesh's own order (one-row strips) fail it.
        let strips: Vec<f32> = m
            .indices
            .chunks(3 * CLUSTER_TRIANGLES as usize)
            .map(|run| {
                let mut b = Aabb::empty();
                for &i in run {
                    let p = Vec3::from(m.positions[i as usize]);
                    (b.min, b.max) = (b.min.min(p), b.max.max(p));
                }
                side(b)
            })
            .collect();
        let strip_mean = strips.iter().sum::<f32>() / strips.len() as f32;
        assert!(strip_mean > 16.0, "row strips: {strip_mean}");
        // A degenerate and an empty mesh: one cluster, none.
        let mut flat = grid(1);
        flat.positions.iter_mut().for_each(|p| *p = [0.0; 3]);
        assert_eq!(cluster_mesh(&flat, 128).clusters.len(), 1);
        let empty = Mesh { name: "empty".into(), ..Default::default() };
        assert!(cluster_mesh(&empty, 128).clusters.is_empty());
    }
}
