//! A light tree over every light (issue 48, item 1; after Conty Estevez and Kulla 2018,
//! without their orientation cones): the stochastic method draws its far candidates by
//! descending it, so that a light is drawn in proportion to how much it can give the
//! point, not uniformly (one in a million: the few far lights that matter are almost never
//! found). The CPU twin of `shaders/common/light_tree.wgsl` (`tests/tests/stochastic_twin.rs`
//! compares the two).
//!
//! 1. **Build** ([`LightTree::build`], once per light set): a binary tree whose leaves are
//!    the lights, split at the median of the longest axis of their positions' bounds;
//!    each node keeps the bounds, its lights' summed power (the luminance of colour times
//!    intensity) and their smallest radius. A node's two children are adjacent (`link`,
//!    `link + 1`); a leaf's `link` is the light with [`LEAF`] set. 2n - 1 nodes of 48 bytes
//!    for n lights. [`LightTree::refit`] recomputes bounds, power and radii for moved
//!    lights, keeping the shape (O(n)).
//! 2. **Importance** ([`importance`]) of a node at point `p`: its power over the squared
//!    distance from `p` to its bounds' centre, clamped below by the squared half
//!    diagonal (near or inside a box any of its lights may be close: the clamp keeps the
//!    importance finite and the choice between two boxes fair). A leaf whose light's
//!    radius reaches `p` has none: the stochastic method draws those lights from the
//!    pixel's list, and the tree serves the others (the far candidates), so a draw that
//!    ended on a near light would be wasted ([`child_importance`]); nor has a node whose
//!    whole box lies within its smallest radius of `p` (every light of it reaches `p`: a
//!    cluster of lights around the point, which would otherwise take most draws).
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

/// One node (`LightNode` in `shaders/common/light_tree.wgsl`): bounds, power, link and
/// its lights' smallest radius.
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
    /// Its lights' smallest radius.
    pub reach: f32,
    /// Padding to 16-byte alignment.
    pub _pad: [f32; 3],
}

/// A light as the tree sees it: position, power, radius.
pub type TreeLight = (Vec3, f32, f32);

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

/// Step 2 for a child: 0 for a leaf whose light `reaches(light, p)` (the near source's)
/// and for a node whose box lies within its smallest radius of `p` (the farthest corner
/// closer than it: every light of it reaches `p`), else [`importance`].
pub fn child_importance(node: &Node, p: Vec3, reaches: &impl Fn(u32, Vec3) -> bool) -> f32 {
    if node.link & LEAF != 0 {
        return if reaches(node.link & !LEAF, p) { 0.0 } else { importance(node, p) };
    }
    let far = (p - Vec3::from(node.min)).abs().max((Vec3::from(node.max) - p).abs());
    if far.length_squared() < node.reach * node.reach {
        0.0
    } else {
        importance(node, p)
    }
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
        Self::from_points(&lights.iter().map(|l| (l.position, power(l), l.radius)).collect::<Vec<_>>())
    }

    /// Step 1 for lights given as `(position, power, radius)` (the GPU's shading records:
    /// the luminance of `color * intensity`).
    pub fn from_points(lights: &[TreeLight]) -> Self {
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
            let mut reach = f32::INFINITY;
            for &i in slice.iter() {
                let (position, power, radius) = lights[i as usize];
                lo = lo.min(position);
                hi = hi.max(position);
                sum += power;
                reach = reach.min(radius);
            }
            nodes[at] = Node { min: lo.into(), power: sum, max: hi.into(), reach, ..Node::default() };
            if slice.len() == 1 {
                nodes[at].link = slice[0] | LEAF;
                continue;
            }
            let axis = (hi - lo).max_position();
            let mid = slice.len() / 2;
            slice.select_nth_unstable_by(mid, |&a, &b| {
                let (pa, pb) = (lights[a as usize].0[axis], lights[b as usize].0[axis]);
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

    /// Recomputes every node's bounds, power and radius for `lights` (the same count, moved
    /// or changed), keeping the tree's shape: children come after their parents, so one
    /// pass from the last node up suffices.
    pub fn refit(&mut self, lights: &[TreeLight]) {
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            self.nodes[i] = if n.link & LEAF != 0 {
                let (position, power, reach) = lights[(n.link & !LEAF) as usize];
                Node { min: position.into(), power, max: position.into(), reach, ..n }
            } else {
                let (a, b) = (self.nodes[n.link as usize], self.nodes[n.link as usize + 1]);
                let min = Vec3::from(a.min).min(b.min.into()).into();
                let max = Vec3::from(a.max).max(b.max.into()).into();
                Node { min, max, power: a.power + b.power, reach: a.reach.min(b.reach), ..n }
            };
        }
    }

    /// Step 3 at point `p`: a light and its probability, descending with the numbers of
    /// draw `draw` of `pixel` in `frame`, the lights that `reaches(light, p)` left out where
    /// their sibling is not; None for an empty tree.
    pub fn sample(
        &self,
        p: Vec3,
        (pixel, frame, draw): (u32, u32, u32),
        reaches: impl Fn(u32, Vec3) -> bool,
    ) -> Option<(u32, f32)> {
        let mut node = *self.nodes.first()?;
        let mut pdf = 1.0f32;
        for level in 0..MAX_DEPTH {
            if node.link & LEAF != 0 {
                return Some((node.link & !LEAF, pdf));
            }
            let (a, b) = (self.nodes[node.link as usize], self.nodes[node.link as usize + 1]);
            let share = first_share(child_importance(&a, p, &reaches), child_importance(&b, p, &reaches));
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
    pub fn pdf(&self, p: Vec3, light: u32, reaches: impl Fn(u32, Vec3) -> bool) -> f32 {
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
            let (a, b) = (&self.nodes[first], &self.nodes[first + 1]);
            let share = first_share(child_importance(a, p, &reaches), child_importance(b, p, &reaches));
            pdf *= if at == first { share } else { 1.0 - share };
            at = parent[at];
        }
        pdf
    }
}

impl crate::stochastic::FarSource for LightTree {
    fn draw(&self, p: Vec3, draws: (u32, u32, u32), reaches: &dyn Fn(u32, Vec3) -> bool) -> Option<(u32, f32)> {
        self.sample(p, draws, reaches)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No light reaches any point.
    fn none(_: u32, _: Vec3) -> bool {
        false
    }

    /// A point light of radius 1 mm (no box lies within it of a point: the tests that
    /// leave lights to the list give radii of their own).
    fn light(p: Vec3, intensity: f32) -> Light {
        Light { radius: 1e-3, ..Light::point(p, Vec3::ONE, intensity, 0.1).expect("light") }
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
        assert!(LightTree::build(&[]).sample(Vec3::ZERO, (0, 0, 0), none).is_none());
    }

    /// The lights' probabilities at a point add up to 1, each above 0; the sampler's
    /// returned probability is the light's; a near bright light is drawn far more often
    /// than its share of the count, and the draws' frequencies follow the probabilities.
    #[test]
    fn the_probabilities_add_up_and_the_draws_follow_them() {
        let ls = lights(200);
        let t = LightTree::build(&ls);
        let p = Vec3::new(1.2, 1.5, 3.1);
        let pdfs: Vec<f32> = (0..ls.len() as u32).map(|l| t.pdf(p, l, none)).collect();
        let total: f32 = pdfs.iter().sum();
        assert!((total - 1.0).abs() < 1e-4, "{total}");
        assert!(pdfs.iter().all(|&q| q > 0.0));
        let mut counts = vec![0u32; ls.len()];
        let draws = 20_000;
        for d in 0..draws {
            let (l, q) = t.sample(p, (d, 7, 3), none).expect("a light");
            assert!((q - pdfs[l as usize]).abs() <= 1e-5 * q.max(1e-30) + 1e-9, "{l}: {q} vs {}", pdfs[l as usize]);
            counts[l as usize] += 1;
        }
        // The cluster at (1, 2, 3) holds every seventh light: most draws land there.
        let near: u32 = (0..ls.len()).filter(|i| i % 7 == 0).map(|i| counts[i]).sum();
        assert!(near as f32 > 0.5 * draws as f32, "{near} of {draws} draws near the point");
        for (l, &q) in pdfs.iter().enumerate() {
            let expected = q * draws as f32;
            let sd = (expected * (1.0 - q)).sqrt();
            assert!(
                (counts[l] as f32 - expected).abs() < 5.0 * sd + 3.0,
                "light {l}: {} draws, {expected} expected",
                counts[l]
            );
        }
    }

    /// At the extremes: lights all at one point (the split goes by index), a light of no
    /// power (never drawn where others have some, its probability 0 is its contribution's),
    /// a point inside a box and far outside every box: the probabilities still add up.
    #[test]
    fn degenerate_sets_still_sample_properly() {
        let same: Vec<Light> = (0..33).map(|_| light(Vec3::ONE, 2.0)).collect();
        let t = LightTree::build(&same);
        let total: f32 = (0..33).map(|l| t.pdf(Vec3::ONE, l, none)).sum();
        assert!((total - 1.0).abs() < 1e-4);
        let mut dark = lights(40);
        dark[5].color = Vec3::ZERO;
        let t = LightTree::build(&dark);
        for p in [Vec3::ZERO, Vec3::splat(1e6), dark[5].position] {
            let total: f32 = (0..40).map(|l| t.pdf(p, l, none)).sum();
            assert!((total - 1.0).abs() < 1e-4, "at {p}: {total}");
            assert_eq!(t.pdf(p, 5, none), 0.0);
        }
        assert_eq!(t.pdf(Vec3::ZERO, 99, none), 0.0, "a light not in the tree");
    }

    /// The lights that reach the point are left out where their sibling is not: the others'
    /// probabilities still add up to 1 when no two near lights are siblings, the near ones
    /// are drawn only when both children of a node reach, and the sampler agrees.
    #[test]
    fn lights_that_reach_the_point_are_left_to_the_list() {
        let ls: Vec<Light> = lights(300).into_iter().map(|l| Light { radius: 2.0, ..l }).collect();
        let t = LightTree::build(&ls);
        let p = Vec3::new(1.2, 1.5, 3.1);
        let reaches = |l: u32, q: Vec3| (ls[l as usize].position - q).length() < ls[l as usize].radius;
        let near = (0..300u32).filter(|&l| reaches(l, p)).count();
        assert!(near > 20 && near < 100, "{near} lights reach the point");
        let far_mass: f32 = (0..300u32).filter(|&l| !reaches(l, p)).map(|l| t.pdf(p, l, reaches)).sum();
        let near_mass: f32 = (0..300u32).filter(|&l| reaches(l, p)).map(|l| t.pdf(p, l, reaches)).sum();
        assert!((far_mass + near_mass - 1.0).abs() < 1e-4);
        // Without the rule the cluster at the point takes most draws (the test above).
        assert!(near_mass < 0.2, "the near lights still take {near_mass} of the draws");
        for d in 0..2000 {
            let (l, q) = t.sample(p, (d, 1, 0), reaches).expect("a light");
            assert!((q - t.pdf(p, l, reaches)).abs() <= 1e-5 * q);
        }
        assert!((0..300u32)
            .filter(|&l| !reaches(l, p))
            .all(|l| t.pdf(p, l, reaches) > 0.0 || ls[l as usize].intensity == 0.0));
    }

    /// A refit of moved lights keeps the shape and brings every node up to date: each leaf
    /// holds its light's position, power and radius, each inner node its children's union,
    /// sum and smallest radius; the probabilities still add up.
    #[test]
    fn a_refit_follows_the_lights() {
        let mut ls = lights(100);
        let mut t = LightTree::build(&ls);
        let links: Vec<u32> = t.nodes.iter().map(|n| n.link).collect();
        for (i, l) in ls.iter_mut().enumerate() {
            l.position += Vec3::new(0.5, -0.25, i as f32 * 0.01);
            l.radius = 0.5 + (i % 5) as f32;
            l.intensity *= 2.0;
        }
        let moved: Vec<TreeLight> = ls.iter().map(|l| (l.position, power(l), l.radius)).collect();
        t.refit(&moved);
        assert_eq!(t.nodes.iter().map(|n| n.link).collect::<Vec<_>>(), links, "the shape changed");
        for n in &t.nodes {
            if n.link & LEAF != 0 {
                let (p, w, r) = moved[(n.link & !LEAF) as usize];
                assert_eq!((Vec3::from(n.min), Vec3::from(n.max), n.power, n.reach), (p, p, w, r));
                continue;
            }
            let (a, b) = (t.nodes[n.link as usize], t.nodes[n.link as usize + 1]);
            assert_eq!(Vec3::from(n.min), Vec3::from(a.min).min(b.min.into()));
            assert_eq!(Vec3::from(n.max), Vec3::from(a.max).max(b.max.into()));
            assert_eq!((n.power, n.reach), (a.power + b.power, a.reach.min(b.reach)));
        }
        let total: f32 = (0..100).map(|l| t.pdf(Vec3::ZERO, l, none)).sum();
        assert!((total - 1.0).abs() < 1e-4);
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
