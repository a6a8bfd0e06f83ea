// The sRGB transfer function (IEC 61966-2-1) both ways, what Rgba8UnormSrgb formats
// compute; the CPU twin is tiledlight_cull::gbuffer (linear_to_srgb, srgb_to_linear).

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = saturate(c);
    return select(1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055, 12.92 * x, x <= vec3<f32>(0.0031308));
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}
