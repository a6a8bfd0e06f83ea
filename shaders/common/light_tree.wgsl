// The light tree the stochastic method draws its far candidates from (issue 48, item 1):
// tiledlight_cull::light_tree's steps 2-3 (its module doc numbers them), its CPU twin.
// The includer binds the nodes and says which lights the pixel's list serves:
//
//   @group(..) @binding(..) var<storage, read> light_tree: array<LightNode>;
//   fn tree_reaches(light: u32, p: vec3<f32>) -> bool  // the light's radius reaches p
//
// Include-only.

#include "common/stochastic.wgsl"

// One node: its lights' bounds, summed power and smallest radius; `link` the first of its
// two adjacent children, or a leaf's light with LIGHT_TREE_LEAF
// (tiledlight_cull::light_tree::Node).
struct LightNode {
    min: vec3<f32>,
    power: f32,
    max: vec3<f32>,
    link: u32,
    reach: f32,
}

const LIGHT_TREE_LEAF: u32 = 0x80000000u;
// tiledlight_cull::light_tree::MAX_DEPTH.
const LIGHT_TREE_MAX_DEPTH: u32 = 48u;

// Step 2: the node's power over the squared distance to its bounds' centre, clamped below
// by the squared half diagonal.
fn tree_importance(node: LightNode, p: vec3<f32>) -> f32 {
    let d = 0.5 * (node.min + node.max) - p;
    let e = node.max - node.min;
    return node.power / max(max(dot(d, d), 0.25 * dot(e, e)), 1e-12);
}

// Step 2 for a child: 0 for a leaf whose light reaches p (the list's) and for a node whose
// box lies within its smallest radius of p, else its importance.
fn tree_child_importance(node: LightNode, p: vec3<f32>) -> f32 {
    if (node.link & LIGHT_TREE_LEAF) != 0u {
        return select(tree_importance(node, p), 0.0, tree_reaches(node.link & ~LIGHT_TREE_LEAF, p));
    }
    let far = max(abs(p - node.min), abs(node.max - p));
    return select(tree_importance(node, p), 0.0, dot(far, far) < node.reach * node.reach);
}

// Step 3's number for `level` of draw `draw` (tiledlight_cull::light_tree::level_rand).
fn tree_rand(pixel: u32, frame: u32, draw: u32, level: u32) -> f32 {
    let h = pcg_hash(pcg_hash(pixel ^ pcg_hash(frame ^ pcg_hash(draw))) ^ pcg_hash(level + 0x68bc21ebu));
    return f32(h >> 8u) / 16777216.0;
}

// A light drawn at point p and its probability (x: the light, y: the probability's bits);
// the probability 0 when the tree is empty or deeper than the limit.
fn tree_sample(p: vec3<f32>, pixel: u32, frame: u32, draw: u32) -> vec2<u32> {
    if arrayLength(&light_tree) == 0u {
        return vec2<u32>(0u, 0u);
    }
    var node = light_tree[0];
    var pdf = 1.0;
    for (var level = 0u; level < LIGHT_TREE_MAX_DEPTH; level++) {
        if (node.link & LIGHT_TREE_LEAF) != 0u {
            return vec2<u32>(node.link & ~LIGHT_TREE_LEAF, bitcast<u32>(pdf));
        }
        let a = light_tree[node.link];
        let b = light_tree[node.link + 1u];
        let ia = tree_child_importance(a, p);
        let ib = tree_child_importance(b, p);
        var share = 0.5;
        if ia + ib > 0.0 {
            share = ia / (ia + ib);
        }
        if tree_rand(pixel, frame, draw, level) < share {
            pdf *= share;
            node = a;
        } else {
            pdf *= 1.0 - share;
            node = b;
        }
    }
    return vec2<u32>(0u, 0u);
}
