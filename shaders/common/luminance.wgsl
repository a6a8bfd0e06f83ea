// Rec. 709 relative luminance of linear RGB (the automatic exposure's and the stochastic
// method's target; CPU: tiledlight_cull::exposure::luminance). Include-only.
fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}
