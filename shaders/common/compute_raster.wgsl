// The visibility buffer's compute rasteriser (issue 29): one triangle's coverage, depth and
// packed (depth, ID) texels, by the rules of its CPU twin tiledlight_cull::raster (same
// operations in the same order; tests/tests/compute_raster.rs compares them):
// homogeneous clipping against the near plane z <= w, the far plane z >= 0 and a guard
// band |x|, |y| <= 64 w; window coordinates snapped to 1/256 px (round half to even, as
// Rust's round_ties_even); exact i64 edge functions with the top-left rule at pixel
// centres; depth z/w interpolated affinely in f32; texels (depth bits << 32) | ID, resolved
// by the includer's atomicMax. Needs wgpu's SHADER_INT64 (and the includer
// SHADER_INT64_ATOMIC_MIN_MAX). The includer defines
// `fn raster_emit(x: u32, y: u32, texel: u64)`.

const RASTER_SUBPIXEL: f32 = 256.0;
const RASTER_ONE: i64 = 256li;
const RASTER_GUARD: f32 = 64.0;

// Vertex v's side of clip plane k (>= 0 inside): near, far, then the guard band.
fn raster_plane(v: vec4<f32>, k: u32) -> f32 {
    switch k {
        case 0u: { return v.w - v.z; }
        case 1u: { return v.z; }
        case 2u: { return RASTER_GUARD * v.w - v.x; }
        case 3u: { return RASTER_GUARD * v.w + v.x; }
        case 4u: { return RASTER_GUARD * v.w - v.y; }
        default: { return RASTER_GUARD * v.w + v.y; }
    }
}

// A convex polygon: a triangle clipped by six planes has at most nine vertices.
struct RasterPoly {
    v: array<vec4<f32>, 9>,
    n: u32,
}

// Whether every vertex lies inside all six clip planes (then clipping keeps the triangle as
// it is).
fn raster_inside(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>) -> bool {
    for (var k = 0u; k < 6u; k++) {
        if raster_plane(c0, k) < 0.0 || raster_plane(c1, k) < 0.0 || raster_plane(c2, k) < 0.0 {
            return false;
        }
    }
    return true;
}

fn raster_clip(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>) -> RasterPoly {
    var p: RasterPoly;
    p.v[0] = c0;
    p.v[1] = c1;
    p.v[2] = c2;
    p.n = 3u;
    if raster_inside(c0, c1, c2) {
        return p;
    }
    for (var k = 0u; k < 6u; k++) {
        if p.n == 0u {
            break;
        }
        var out: RasterPoly;
        out.n = 0u;
        for (var i = 0u; i < p.n; i++) {
            let a = p.v[i];
            let b = p.v[(i + 1u) % p.n];
            let da = raster_plane(a, k);
            let db = raster_plane(b, k);
            if da >= 0.0 {
                out.v[out.n] = a;
                out.n += 1u;
            }
            if (da >= 0.0) != (db >= 0.0) {
                let t = da / (da - db);
                out.v[out.n] = a + (b - a) * t;
                out.n += 1u;
            }
        }
        p = out;
    }
    return p;
}

// A window-space vertex: x and y in 1/256 px, depth.
struct RasterVertex {
    x: i64,
    y: i64,
    depth: f32,
}

fn raster_snap(v: vec4<f32>, size: vec2<u32>) -> RasterVertex {
    let nx = v.x / v.w;
    let ny = v.y / v.w;
    let wx = (nx + 1.0) * 0.5 * f32(size.x);
    let wy = (1.0 - ny) * 0.5 * f32(size.y);
    return RasterVertex(i64(round(wx * RASTER_SUBPIXEL)), i64(round(wy * RASTER_SUBPIXEL)), v.z / v.w);
}

fn raster_area(a: RasterVertex, b: RasterVertex, c: RasterVertex) -> i64 {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Edge a -> b of a positive-area triangle (window y down) is a top or a left edge.
fn raster_top_left(a: RasterVertex, b: RasterVertex) -> bool {
    let dx = b.x - a.x;
    let dy = b.y - a.y;
    return (dy == 0li && dx > 0li) || dy < 0li;
}

fn raster_edge(a: RasterVertex, b: RasterVertex, px: i64, py: i64) -> i64 {
    return (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
}

// floor(m / RASTER_ONE) for any sign.
fn raster_floor_div(m: i64) -> i64 {
    let q = m / RASTER_ONE;
    return select(q, q - 1li, m < 0li && q * RASTER_ONE != m);
}

// A triangle ready to fill: its vertices ordered to a positive area, which of its edges
// own the pixels on them (top-left), 1 / area, and the pixels its bounds cover on screen.
struct RasterFill {
    v0: RasterVertex,
    v1: RasterVertex,
    v2: RasterVertex,
    own: vec3<bool>,
    inv: f32,
    lo: vec2<i64>,
    hi: vec2<i64>,
    // False for a zero area (nothing drawn).
    drawn: bool,
}

fn raster_prepare(a: RasterVertex, b: RasterVertex, c: RasterVertex, size: vec2<u32>) -> RasterFill {
    var f: RasterFill;
    let ab = raster_area(a, b, c);
    f.drawn = ab != 0li;
    f.v0 = a;
    f.v1 = b;
    f.v2 = c;
    var area = ab;
    if ab < 0li {
        f.v1 = c;
        f.v2 = b;
        area = -ab;
    }
    let half = RASTER_ONE / 2li;
    f.lo = max(
        vec2<i64>(
            raster_floor_div(min(min(f.v0.x, f.v1.x), f.v2.x) - half),
            raster_floor_div(min(min(f.v0.y, f.v1.y), f.v2.y) - half)
        ),
        vec2<i64>(0li)
    );
    f.hi = min(
        vec2<i64>(
            raster_floor_div(max(max(f.v0.x, f.v1.x), f.v2.x) - half),
            raster_floor_div(max(max(f.v0.y, f.v1.y), f.v2.y) - half)
        ),
        vec2<i64>(size) - vec2<i64>(1li)
    );
    f.own = vec3<bool>(raster_top_left(f.v1, f.v2), raster_top_left(f.v2, f.v0), raster_top_left(f.v0, f.v1));
    f.inv = 1.0 / f32(select(area, 1li, area == 0li));
    return f;
}

// Pixel (px, py), covered (`inside`, by the top-left rule) or not, with its edge values
// `e` as f32: its texel emitted when covered.
fn raster_cover_at(f: RasterFill, inside: bool, e: vec3<f32>, px: i64, py: i64, id: u32) {
    if inside {
        let depth = (e.x * f.inv) * f.v0.depth + (e.y * f.inv) * f.v1.depth + (e.z * f.inv) * f.v2.depth;
        let texel = (u64(bitcast<u32>(max(depth, 0.0))) << 32u) | u64(id);
        raster_emit(u32(px), u32(py), texel);
    }
}

// Pixel (px, py) with edge values e (raster_edge of the three edges at its centre).
fn raster_cover(f: RasterFill, e: vec3<i64>, px: i64, py: i64, id: u32) {
    let inside = all((e > vec3<i64>(0li)) | ((e == vec3<i64>(0li)) & f.own));
    raster_cover_at(f, inside, vec3<f32>(f32(e.x), f32(e.y), f32(e.z)), px, py, id);
}

// raster_cover with the edge values in i32 (raster_fill's small triangles): the same
// integers, so the same coverage and the same f32 conversions.
fn raster_cover32(f: RasterFill, e: vec3<i32>, px: i64, py: i64, id: u32) {
    let inside = all((e > vec3<i32>(0)) | ((e == vec3<i32>(0)) & f.own));
    raster_cover_at(f, inside, vec3<f32>(e), px, py, id);
}

// Sub-pixel spread of a triangle's vertices below which its edge values fit an i32 at
// every pixel centre of its bounds: |e| <= 2 S (S + 256) < 2^31 for S < 32,000; 64 px.
const RASTER_I32_SPAN: i64 = 16384li;

// The edge values at the centre of pixel (px, py).
fn raster_edges(f: RasterFill, px: i64, py: i64) -> vec3<i64> {
    let cx = px * RASTER_ONE + RASTER_ONE / 2li;
    let cy = py * RASTER_ONE + RASTER_ONE / 2li;
    return vec3<i64>(raster_edge(f.v1, f.v2, cx, cy), raster_edge(f.v2, f.v0, cx, cy), raster_edge(f.v0, f.v1, cx, cy));
}

// Fills a snapped triangle, one thread.
fn raster_fill(a: RasterVertex, b: RasterVertex, c: RasterVertex, size: vec2<u32>, id: u32) {
    let f = raster_prepare(a, b, c, size);
    if !f.drawn {
        return;
    }
    // The edge functions are linear in the sample point: stepped by exact integer
    // additions from the first pixel's values, equal to evaluating raster_edges at every
    // pixel; in i32 (native on GPUs, where i64 is emulated) when the values fit.
    var row = raster_edges(f, f.lo.x, f.lo.y);
    let sx = vec3<i64>(f.v1.y - f.v2.y, f.v2.y - f.v0.y, f.v0.y - f.v1.y) * RASTER_ONE;
    let sy = vec3<i64>(f.v2.x - f.v1.x, f.v0.x - f.v2.x, f.v1.x - f.v0.x) * RASTER_ONE;
    let vlo = min(min(vec2<i64>(f.v0.x, f.v0.y), vec2<i64>(f.v1.x, f.v1.y)), vec2<i64>(f.v2.x, f.v2.y));
    let vhi = max(max(vec2<i64>(f.v0.x, f.v0.y), vec2<i64>(f.v1.x, f.v1.y)), vec2<i64>(f.v2.x, f.v2.y));
    if all(vhi - vlo < vec2<i64>(RASTER_I32_SPAN)) {
        var row32 = vec3<i32>(row);
        let sx32 = vec3<i32>(sx);
        let sy32 = vec3<i32>(sy);
        for (var py = f.lo.y; py <= f.hi.y; py++) {
            var e = row32;
            for (var px = f.lo.x; px <= f.hi.x; px++) {
                raster_cover32(f, e, px, py, id);
                e += sx32;
            }
            row32 += sy32;
        }
        return;
    }
    for (var py = f.lo.y; py <= f.hi.y; py++) {
        var e = row;
        for (var px = f.lo.x; px <= f.hi.x; px++) {
            raster_cover(f, e, px, py, id);
            e += sx;
        }
        row += sy;
    }
}

// Side of the screen tiles a large triangle is split into (tiledlight_cull::raster::LARGE_TILE).
const RASTER_TILE: i64 = 16li;

// Whether no edge of f rules out screen tile `tile` (tiledlight_cull::raster::large_tiles):
// an edge function is linear, so its largest value over the tile's pixel centres (clipped
// to f's bounds, which must not be empty) is at one of their four corners.
fn raster_tile_open(f: RasterFill, tile: vec2<i64>) -> bool {
    let lo = max(tile * RASTER_TILE, f.lo);
    let hi = min(tile * RASTER_TILE + vec2<i64>(RASTER_TILE - 1li), f.hi);
    let a = raster_edges(f, lo.x, lo.y);
    let b = raster_edges(f, hi.x, lo.y);
    let c = raster_edges(f, lo.x, hi.y);
    let d = raster_edges(f, hi.x, hi.y);
    return all(max(max(a, b), max(c, d)) >= vec3<i64>(0li));
}

// Fills the pixels of screen tile `tile` that f covers, one thread: raster_fill's
// coverage and depths within the tile.
fn raster_fill_tile(f: RasterFill, tile: vec2<i64>, id: u32) {
    let lo = max(tile * RASTER_TILE, f.lo);
    let hi = min(tile * RASTER_TILE + vec2<i64>(RASTER_TILE - 1li), f.hi);
    for (var py = lo.y; py <= hi.y; py++) {
        for (var px = lo.x; px <= hi.x; px++) {
            raster_cover(f, raster_edges(f, px, py), px, py, id);
        }
    }
}

// No NaN or infinity in v.
fn raster_finite(v: vec4<f32>) -> bool {
    return all(v == v) && all(abs(v) <= vec4<f32>(3.4028235e38));
}

// A triangle inside every clip plane, snapped: what most triangles are, without the
// clipped polygon's nine-vertex arrays (the same result as raster_setup's general path).
struct RasterTri {
    a: RasterVertex,
    b: RasterVertex,
    c: RasterVertex,
    // False when nothing is drawn (zero area, or a back face culled).
    drawn: bool,
}

// raster_setup for a triangle with raster_inside(c0, c1, c2) and finite vertices.
fn raster_setup_inside(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, size: vec2<u32>, cull_back: bool) -> RasterTri {
    let a = raster_snap(c0, size);
    let b = raster_snap(c1, size);
    let c = raster_snap(c2, size);
    let area = raster_area(a, b, c);
    return RasterTri(a, b, c, area != 0li && !(cull_back && area > 0li));
}

// The pixels a snapped triangle's bounds span: (columns, rows).
fn raster_span_tri(t: RasterTri) -> vec2<i64> {
    let lo = min(min(vec2<i64>(t.a.x, t.a.y), vec2<i64>(t.b.x, t.b.y)), vec2<i64>(t.c.x, t.c.y));
    let hi = max(max(vec2<i64>(t.a.x, t.a.y), vec2<i64>(t.b.x, t.b.y)), vec2<i64>(t.c.x, t.c.y));
    return (hi - lo) / vec2<i64>(RASTER_ONE) + vec2<i64>(1li);
}

// A triangle set up for filling: its clipped polygon in window coordinates (a fan from
// vertex 0), empty (n = 0) when nothing of it is drawn.
struct RasterSetup {
    s: array<RasterVertex, 9>,
    n: u32,
}

// Clips, snaps and culls triangle (c0, c1, c2) (clip space) on a `size` target; with
// `cull_back` drops it when it faces away (clockwise in NDC).
fn raster_setup(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, size: vec2<u32>, cull_back: bool) -> RasterSetup {
    var out: RasterSetup;
    out.n = 0u;
    if !(raster_finite(c0) && raster_finite(c1) && raster_finite(c2)) || size.x == 0u || size.y == 0u {
        return out;
    }
    let p = raster_clip(c0, c1, c2);
    if p.n < 3u {
        return out;
    }
    for (var i = 0u; i < p.n; i++) {
        out.s[i] = raster_snap(p.v[i], size);
    }
    var total = 0li;
    for (var i = 1u; i + 1u < p.n; i++) {
        total += raster_area(out.s[0], out.s[i], out.s[i + 1u]);
    }
    // Window y points down: counter-clockwise in NDC is a negative area here.
    if total == 0li || (cull_back && total > 0li) {
        return out;
    }
    out.n = p.n;
    return out;
}

// The pixels a set-up triangle's bounds span: (columns, rows).
fn raster_span(t: RasterSetup) -> vec2<i64> {
    var lo = vec2<i64>(t.s[0].x, t.s[0].y);
    var hi = lo;
    for (var i = 1u; i < t.n; i++) {
        lo = min(lo, vec2<i64>(t.s[i].x, t.s[i].y));
        hi = max(hi, vec2<i64>(t.s[i].x, t.s[i].y));
    }
    return (hi - lo) / vec2<i64>(RASTER_ONE) + vec2<i64>(1li);
}

// Fills a set-up triangle with `id`.
fn raster_fill_setup(t: RasterSetup, size: vec2<u32>, id: u32) {
    for (var i = 1u; i + 1u < t.n; i++) {
        raster_fill(t.s[0], t.s[i], t.s[i + 1u], size, id);
    }
}

// Rasterises triangle (c0, c1, c2) (clip space) with `id` on a `size` target; with
// `cull_back` drops it when it faces away (clockwise in NDC).
fn raster_triangle(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, size: vec2<u32>, cull_back: bool, id: u32) {
    if raster_finite(c0) && raster_finite(c1) && raster_finite(c2) && raster_inside(c0, c1, c2) {
        let t = raster_setup_inside(c0, c1, c2, size, cull_back);
        if t.drawn && size.x > 0u && size.y > 0u {
            raster_fill(t.a, t.b, t.c, size, id);
        }
        return;
    }
    raster_fill_setup(raster_setup(c0, c1, c2, size, cull_back), size, id);
}
