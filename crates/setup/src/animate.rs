//! Light animation, as in TiledLighting11: every light circles the scene's vertical axis at
//! its own speed and direction ([`LightAnimator`]). Positions (and spot directions) are
//! computed on the CPU from the lights as generated and written over the existing buffers
//! each frame: no buffer is created, and the scratch arrays are reused. The viewer moves
//! its lights with it, and `bench --move-lights` to measure the shadow pass with moving
//! lights; after each [`LightAnimator::advance`] they give the renderer the moved lights
//! (`Renderer::lights_moved` with [`LightAnimator::current`]) so that the shadows follow.
//! Depends on glam, wgpu and tiledlight-cull / tiledlight-gpu.

use glam::{Quat, Vec3};
use tiledlight_cull::light::PackedLights;
use tiledlight_gpu::light_buffers::LightBuffers;

/// Angular speed range of the lights, radians per second.
const SPEED: (f32, f32) = (0.15, 0.6);

/// Moves a set of lights around a vertical axis.
pub struct LightAnimator {
    base: PackedLights,
    moved: PackedLights,
    center: Vec3,
    time: f32,
}

/// A light's angular speed: a fixed hash of its index, half of them turning clockwise.
fn angular_speed(i: usize) -> f32 {
    let h = (i as u32).wrapping_mul(0x9E37_79B9).rotate_left(13).wrapping_mul(0x85EB_CA6B);
    let t = (h >> 8) as f32 / (1u32 << 24) as f32;
    let w = SPEED.0 + (SPEED.1 - SPEED.0) * t;
    if h & 1 == 0 {
        w
    } else {
        -w
    }
}

impl LightAnimator {
    /// Animates `lights` (as uploaded) around the vertical axis through `center`.
    pub fn new(lights: &PackedLights, center: Vec3) -> Self {
        Self { base: lights.clone(), moved: lights.clone(), center, time: 0.0 }
    }

    /// Advances by `dt` seconds and writes the moved lights over `buffers`, which must be
    /// the buffers of the lights this animator was made for.
    pub fn advance(&mut self, queue: &wgpu::Queue, buffers: &LightBuffers, dt: f32) {
        if self.base.is_empty() || buffers.len() as usize != self.base.len() {
            return;
        }
        self.time += dt.clamp(0.0, 0.25);
        let num_point = self.base.num_point as usize;
        for i in 0..self.base.len() {
            let rot = Quat::from_rotation_y(angular_speed(i) * self.time);
            let turn = |p: [f32; 3]| (self.center + rot * (Vec3::from(p) - self.center)).to_array();
            self.moved.cull[i].center = turn(self.base.cull[i].center);
            self.moved.shading[i].position = turn(self.base.shading[i].position);
            if i >= num_point {
                let s = i - num_point;
                self.moved.spots[s].direction = (rot * Vec3::from(self.base.spots[s].direction)).to_array();
            }
        }
        queue.write_buffer(&buffers.cull, 0, bytemuck::cast_slice(&self.moved.cull));
        queue.write_buffer(&buffers.shading, 0, bytemuck::cast_slice(&self.moved.shading));
        if let Some(spots) = &buffers.spots {
            queue.write_buffer(spots, 0, bytemuck::cast_slice(&self.moved.spots));
        }
    }

    /// The lights as last written.
    pub fn current(&self) -> &PackedLights {
        &self.moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speeds_vary_and_stay_in_range() {
        let w: Vec<f32> = (0..1000).map(angular_speed).collect();
        assert!(w.iter().all(|w| (SPEED.0..=SPEED.1).contains(&w.abs())));
        let cw = w.iter().filter(|w| **w < 0.0).count();
        assert!((300..700).contains(&cw), "{cw} of 1000 turn clockwise");
    }
}
