//! A light tree over every light (issue 48, item 1; after Conty Estevez and Kulla 2018,
//! without their orientation cones): the stochastic method draws its far candidates by
//! descending it, so that a light is drawn in proportion to how much it can give the
//! point, not uniformly (one in a million: the few far lights that matter are almost never
//! found). The CPU twin of `shaders/common/light_tree.wgsl` (`tests/tests/stochastic_twin.rs`
//! compares the two).
//!
//! 1. **Build** ([`LightTree::build`], once per light set): a binary tree whose leaves are
//!    the lights, split at the median of the longest axis of their positions' bounds;
//!    each node keeps the bounds and its lights' summed power (the luminance of colour
//!    times intensity). A node's two children are adjacent (`link`, `link + 1`); a leaf's
//!    `link` is the light with [`LEAF`] set. 2n - 1 nodes of 32 bytes for n lights.
//! 2. **Importance** ([`importance`]) of a node at point `p`: its power over the squared
//!    distance from `p` to its bounds' centre, clamped below by the squared half
//!    diagonal (near or inside a box any of its lights may be close: the clamp keeps the
//!    importance finite and the choice between two boxes fair).
//! 3. **Descent** ([`LightTree::sample`]): from the root, a child with probability in
//!    proportion to its importance (half each when both are 0), one random number a level
//!    ([`level_rand`]); the light's probability is the product of the choices.
//! 4. Every light keeps a probability above 0 wherever its power is (no light is pruned),
//!    so a sampler that weighs candidates by `1 / q` stays unbiased however loose the
//!    bounds are: lights that moved since the build only cost variance.
//!
//! Depends on this crate's light and stochastic modules, glam and bytemuck.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::light::Light;
use crate::stochastic::{luminance, pcg_hash};

/// The bit of a leaf's `link` (light indices are below 2^20).
pub const LEAF: u32 = 1 << 31;

/// The deepest descent the GPU takes: a median split of 2^20 lights is 21 levels deep.
pub const MAX_DEPTH: u32 = 48;

/// One node (`LightNode` in `shaders/common/light_tree.wgsl`): bounds, power, link.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Node {
    /// The smallest corner of its lights' positions.
    pub min: [f32; 3],
    /// Its lights' summed power (luminance of colour times intensity).
    pub power: f32,
    /// The largest corner.
    pub max: [f32; 3],
    /// The first of its two adjacent children, or a leaf's light with [`LEAF`].
    pub link: u32,
}

/// The tree: node 0 is the root (no node for no lights).
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    /// Every node, children after their parent.
    pub nodes: Vec<Node>,
}

/// A light's power: what the tree draws it in proportion to (at equal distance).
pub fn power(l: &Light) -> f32 {
    luminance(l.color) * l.intensity
}

/// Step 2: the importance of `node` at point `p`.
pub fn importance(node: &Node, p: Vec3) -> f32 {
    let (lo, hi) = (Vec3::from(node.min), Vec3::from(node.max));
    let d2 = (0.5 * (lo + hi) - p).length_squared();
    let h2 = 0.25 * (hi - lo).length_squared();
    node.power / d2.max(h2).max(1e-12)
}

/// Step 3's number for `level` of draw `draw` of `pixel` in `frame`: 24 bits of a hash
/// chain, as the GPU's `tree_rand`.
pub fn level_rand(pixel: u32, frame: u32, draw: u32, level: u32) -> f32 {
    let h = pcg_hash(pcg_hash(pixel ^ pcg_hash(frame ^ pcg_hash(draw))) ^ pcg_hash(level.wrapping_add(0x68bc_21eb)));
    (h >> 8) as f32 / 16_777_216.0
}

/// The probability of the first child of two with importances `a` and `b`.
pub fn first_share(a: f32, b: f32) -> f32 {
    if a + b > 0.0 {
        a / (a + b)
    } else {
        0.5
    }
}

impl LightTree {
    /// Step 1: the tree of `lights` (their indices are the leaves' lights).
    pub fn build(lights: &[Light]) -> Self {
        let mut nodes = Vec::with_capacity((2 * lights.len()).saturating_sub(1));
        if lights.is_empty() {
            return Self { nodes };
        }
        let mut order: Vec<u32> = (0..lights.len() as u32).collect();
        nodes.push(Node::default());
        // (node, range of `order`): nodes are filled top-down, children pushed in pairs.
        let mut stack = vec![(0usize, 0usize, lights.len())];
        while let Some((at, start, end)) = stack.pop() {
            let slice = &mut order[start..end];
            let (mut lo, mut hi, mut sum) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), 0.0f32);
            for &i in slice.iter() {
                let l = &lights[i as usize];
                lo = lo.min(l.position);
                hi = hi.max(l.position);
                sum += power(l);
            }
            nodes[at] = Node { min: lo.into(), power: sum, max: hi.into(), link: 0 };
            if slice.len() == 1 {
                nodes[at].link = slice[0] | LEAF;
                continue;
            }
            let axis = (hi - lo).max_position();
            let mid = slice.len() / 2;
            slice.select_nth_unstable_by(mid, |&a, &b| {
                let (pa, pb) = (lights[a as usize].position[axis], lights[b as usize].position[axis]);
                pa.total_cmp(&pb).then(a.cmp(&b))
            });
            let first = nodes.len();
            nodes.push(Node::default());
            nodes.push(Node::default());
            nodes[at].link = first as u32;
            stack.push((first, start, start + mid));
            stack.push((first + 1, start + mid, end));
        }
        Self { nodes }
    }

    /// Step 3 at point `p`: a light and its probability, descending with the numbers of
    /// draw `draw` of `pixel` in `frame`; None for an empty tree.
    pub fn sample(&self, p: Vec3, (pixel, frame, draw): (u32, u32, u32)) -> Option<(u32, f32)> {
        let mut node = *self.nodes.first()?;
        let mut pdf = 1.0f32;
        for level in 0..MAX_DEPTH {
            if node.link & LEAF != 0 {
                return Some((node.link & !LEAF, pdf));
            }
            let (a, b) = (self.nodes[node.link as usize], self.nodes[node.link as usize + 1]);
            let share = first_share(importance(&a, p), importance(&b, p));
            if level_rand(pixel, frame, draw, level) < share {
                pdf *= share;
                node = a;
            } else {
                pdf *= 1.0 - share;
                node = b;
            }
        }
        None
    }

    /// The probability that [`Self::sample`] at `p` draws `light` (0 for a light not in
    /// the tree): the product of the choices along its path.
    pub fn pdf(&self, p: Vec3, light: u32) -> f32 {
        // Each node's parent, then the path from the light's leaf up.
        let mut parent = vec![usize::MAX; self.nodes.len()];
        let mut leaf = None;
        for (i, n) in self.nodes.iter().enumerate() {
            if n.link & LEAF != 0 {
                if n.link & !LEAF == light {
                    leaf = Some(i);
                }
            } else {
                parent[n.link as usize] = i;
                parent[n.link as usize + 1] = i;
            }
        }
        let Some(mut at) = leaf else { return 0.0 };
        let mut pdf = 1.0f32;
        while parent[at] != usize::MAX {
            let first = self.nodes[parent[at]].link as usize;
            let share = first_share(importance(&self.nodes[first], p), importance(&self.nodes[first + 1], p));
            pdf *= if at == first { share } else { 1.0 - share };
            at = parent[at];
        }
        pdf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(p: Vec3, intensity: f32) -> Light {
        Light::point(p, Vec3::ONE, intensity, 0.1).expect("light")
    }

    /// A scatter of lights of varied power, some at one point.
    fn lights(n: usize) -> Vec<Light> {
        (0..n)
            .map(|i| {
                let f = i as f32;
                let p = if i % 7 == 0 {
                    Vec3::new(1.0, 2.0, 3.0)
                } else {
                    Vec3::new((f * 0.37).sin() * 20.0, (f * 0.11).cos() * 3.0, (f * 0.73).sin() * 20.0)
                };
                light(p, 1.0 + (i % 13) as f32)
            })
            .collect()
    }

    /// Every light is a leaf once; every internal node's bounds hold its children's and
    /// its power is theirs summed; 2n - 1 nodes; the depth stays logarithmic.
    #[test]
    fn the_tree_holds_every_light_once_in_nested_bounds() {
        for n in [1, 2, 3, 10, 1000] {
            let ls = lights(n);
            let t = LightTree::build(&ls);
            assert_eq!(t.nodes.len(), 2 * n - 1);
            let mut seen = vec![0; n];
            for node in &t.nodes {
                if node.link & LEAF != 0 {
                    seen[(node.link & !LEAF) as usize] += 1;
                    continue;
                }
                for c in [t.nodes[node.link as usize], t.nodes[node.link as usize + 1]] {
                    assert!((0..3).all(|k| c.min[k] >= node.min[k] && c.max[k] <= node.max[k]));
                }
                let sum = t.nodes[node.link as usize].power + t.nodes[node.link as usize + 1].power;
                assert!((sum - node.power).abs() <= 1e-4 * node.power);
            }
            assert!(seen.iter().all(|&s| s == 1), "{n} lights: {seen:?}");
        }
        assert!(LightTree::build(&[]).nodes.is_empty());
        assert!(LightTree::build(&[]).sample(Vec3::ZERO, (0, 0, 0)).is_none());
    }

    /// The lights' probabilities at a point add up to 1, each above 0; the sampler's
    /// returned probability is the light's; a near bright light is drawn far more often
    /// than its share of the count, and the draws' frequencies follow the probabilities.
    #[test]
    fn the_probabilities_add_up_and_the_draws_follow_them() {
        let ls = lights(200);
        let t = LightTree::build(&ls);
        let p = Vec3::new(1.2, 1.5, 3.1);
        let pdfs: Vec<f32> = (0..ls.len() as u32).map(|l| t.pdf(p, l)).collect();
        let total: f32 = pdfs.iter().sum();
        assert!((total - 1.0).abs() < 1e-4, "{total}");
        assert!(pdfs.iter().all(|&q| q > 0.0));
        let mut counts = vec![0u32; ls.len()];
        let draws = 20_000;
        for d in 0..draws {
            let (l, q) = t.sample(p, (d, 7, 3)).expect("a light");
            assert!((q - pdfs[l as usize]).abs() <= 1e-5 * q.max(1e-30) + 1e-9, "{l}: {q} vs {}", pdfs[l as usize]);
            counts[l as usize] += 1;
        }
        // The cluster at (1, 2, 3) holds every seventh light: most draws land there.
        let near: u32 = (0..ls.len()).filter(|i| i % 7 == 0).map(|i| counts[i]).sum();
        assert!(near as f32 > 0.5 * draws as f32, "{near} of {draws} draws near the point");
        for (l, &q) in pdfs.iter().enumerate() {
            let expected = q * draws as f32;
            let sd = (expected * (1.0 - q)).sqrt();
            assert!((counts[l] as f32 - expected).abs() < 5.0 * sd + 3.0, "light {l}: {} draws, {expected} expected", counts[l]);
        }
    }

    /// At the extremes: lights all at one point (the split goes by index), a light of no
    /// power (never drawn where others have some, its probability 0 is its contribution's),
    /// a point inside a box and far outside every box: the probabilities still add up.
    #[test]
    fn degenerate_sets_still_sample_properly() {
        let same: Vec<Light> = (0..33).map(|_| light(Vec3::ONE, 2.0)).collect();
        let t = LightTree::build(&same);
        let total: f32 = (0..33).map(|l| t.pdf(Vec3::ONE, l)).sum();
        assert!((total - 1.0).abs() < 1e-4);
        let mut dark = lights(40);
        dark[5].color = Vec3::ZERO;
        let t = LightTree::build(&dark);
        for p in [Vec3::ZERO, Vec3::splat(1e6), dark[5].position] {
            let total: f32 = (0..40).map(|l| t.pdf(p, l)).sum();
            assert!((total - 1.0).abs() < 1e-4, "at {p}: {total}");
            assert_eq!(t.pdf(p, 5), 0.0);
        }
        assert_eq!(t.pdf(Vec3::ZERO, 99), 0.0, "a light not in the tree");
    }

    /// The level numbers are uniform, differ by level, draw and pixel.
    #[test]
    fn level_numbers_are_uniform_and_independent() {
        let n = 10_000u32;
        let mean: f32 = (0..n).map(|i| level_rand(i, 3, 1, 0)).sum::<f32>() / n as f32;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert_ne!(level_rand(1, 2, 3, 4), level_rand(1, 2, 3, 5));
        assert_ne!(level_rand(1, 2, 3, 4), level_rand(1, 2, 4, 4));
        assert_ne!(level_rand(1, 2, 3, 4), level_rand(2, 2, 3, 4));
    }
}
