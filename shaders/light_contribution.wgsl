// Each light's contribution to the frame, for choosing the shadow casters by what they
// light on screen (tiledlight_gpu::contribution::LightContribution; CPU twin
// tiledlight_cull::contribution, whose module doc numbers the steps).
// One workgroup per 16x16 tile of a one-list-per-tile light grid:
// 1. each thread puts its pixel's surface back in the world (sky: none) in workgroup memory;
// 2. each thread takes lights of the tile's list and sums their windowed attenuation (and
//    spot cone with SPOTS) over the tile's surface points, in row-major order like the twin;
// 3. brightness * sum * scale is quantised to u32 units (saturating) and added to the
//    light's 64-bit score (low word, then the carry into the high word): integer sums, so
//    the result does not depend on the order the workgroups add in.
// variants: SPOTS
#include "common/view.wgsl"
#include "common/lights.wgsl"
#include "common/brdf.wgsl"
#include "common/light_grid.wgsl"

const TILE: u32 = 16u;
// The largest f32 below 2^32 (tiledlight_cull::contribution::PAIR_MAX).
const PAIR_MAX: f32 = 4294967040.0;

struct ContributionParams {
    // Units per brightness-weighted attenuation sum (tiledlight_cull::contribution::pair_scale).
    scale: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

@group(1) @binding(0) var depth_texture: texture_2d<f32>;
@group(1) @binding(1) var<storage, read> lights: array<ShadingLight>;
@group(1) @binding(2) var<uniform> lighting: Lighting;
@group(1) @binding(3) var<uniform> params: ContributionParams;
// Per light (packed order): low word, high word.
@group(1) @binding(4) var<storage, read_write> scores: array<atomic<u32>>;
@group(1) @binding(5) var<storage, read> light_grid: LightGrid;
@group(1) @binding(6) var<storage, read> light_indices: array<u32>;
#ifdef SPOTS
@group(1) @binding(7) var<storage, read> spots: array<SpotLight>;
#endif

// The tile's surface points; w = 0 for sky and pixels past the screen's edge.
var<workgroup> points: array<vec4<f32>, 256>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) i: u32) {
    let p = wg.xy * TILE + vec2<u32>(i % TILE, i / TILE);
    var point = vec4<f32>(0.0);
    if all(p < view.screen) {
        let d = textureLoad(depth_texture, p, 0).x;
        if d > 0.0 {
            let v = view_point_at(pixel_to_ndc(vec2<f32>(p) + 0.5), view_distance(d));
            point = vec4<f32>((view.view_to_world * vec4<f32>(v, 1.0)).xyz, 1.0);
        }
    }
    points[i] = point;
    workgroupBarrier();
    let tile = wg.y * light_grid.header.tiles.x + wg.x;
    let list = light_list(light_grid.lists[tile], light_grid.header.capacity);
    for (var k = i; k < list.count; k += TILE * TILE) {
        let li = light_indices[list.first + k];
        let l = lights[li];
        var sum = 0.0;
        for (var j = 0u; j < TILE * TILE; j++) {
            let q = points[j];
            if q.w == 0.0 {
                continue;
            }
            let to_light = l.position - q.xyz;
            let d2 = dot(to_light, to_light);
            var a = windowed_attenuation(d2, l.radius);
#ifdef SPOTS
            if li >= lighting.num_point_lights {
                let s = spots[li - lighting.num_point_lights];
                let dir = to_light / max(sqrt(d2), 1.17549435e-38);
                a *= spot_falloff(dot(-dir, s.direction), s.angle_scale, s.angle_offset);
            }
#endif
            sum += a;
        }
        let v = max(l.radiance.x, max(l.radiance.y, l.radiance.z)) * sum * params.scale;
        var units = 0u;
        if v >= PAIR_MAX {
            units = 0xffffffffu;
        } else if v > 0.0 {
            units = u32(v);
        }
        if units != 0u {
            let old = atomicAdd(&scores[2u * li], units);
            if old > 0xffffffffu - units {
                atomicAdd(&scores[2u * li + 1u], 1u);
            }
        }
    }
}
