//! `tiledlight-cull` on its own, as an engine that brings its own depth buffer would use
//! it: the CPU reference culler for a GPU light-culling kernel of your own.
//!
//! 1. A reversed-Z camera (`Camera::perspective`, infinite far plane) looking at a floor.
//! 2. The depth buffer your renderer would produce, here computed by intersecting each
//!    pixel's ray with the floor (sky stays 0, reversed-Z's clear value).
//! 3. Lights with radii from an intensity threshold, validated and packed as the GPU
//!    buffers hold them (`try_pack_lights`: points first, 16-byte cull spheres).
//! 4. `cull_tiles`: per 16x16 tile, the lights whose sphere reaches the tile's view volume
//!    (planes, depth range and the tighter AABB test), and the statistics a tuning pass
//!    wants: lights per tile and the false-positive rate.
//! 5. The guarantee a GPU kernel must keep too: every light that reaches a pixel is in its
//!    tile's list (`lights_reaching` is the ground truth, per pixel).
//!
//! Compare your kernel's lists with `TileLists::lists` tile for tile. Run with
//! `cargo run -p tiledlight-cull --example cull_a_floor`.

use glam::{Vec3, Vec4};
use tiledlight_cull::light::try_pack_lights;
use tiledlight_cull::reference::{false_positive_rate, lights_reaching, pixel_view_position, stats};
use tiledlight_cull::tiles::{pixel_to_ndc_x, pixel_to_ndc_y};
use tiledlight_cull::{cull_tiles, Camera, CullConfig, CullError, Light};

fn main() -> Result<(), CullError> {
    let (w, h) = (320u32, 180u32);
    // 1. The camera: 2 m above a floor, looking 10 m ahead.
    let camera = Camera::perspective(
        Vec3::new(0.0, 2.0, 6.0),
        Vec3::new(0.0, 0.0, -4.0),
        Vec3::Y,
        60f32.to_radians(),
        w as f32 / h as f32,
        0.1,
        None,
    )?;
    // 2. Its depth buffer: the floor y = 0 where a pixel's ray meets it, sky elsewhere.
    let inv_view = camera.view().inverse();
    let params = camera.depth_params();
    let mut depth = vec![0.0f32; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let ndc = (pixel_to_ndc_x(x as f32 + 0.5, w), pixel_to_ndc_y(y as f32 + 0.5, h));
            // View-space point at view distance 1 on the pixel's ray, in world space.
            let at_one = (inv_view * Vec4::from((camera.view_point_at(ndc.0, ndc.1, 1.0), 1.0))).truncate();
            let (eye, step) = (camera.eye(), at_one - camera.eye());
            if step.y < 0.0 {
                // The ray reaches y = 0 at view distance -eye.y / step.y.
                depth[(y * w + x) as usize] = params.depth(-eye.y / step.y);
            }
        }
    }
    // 3. An 8 x 8 grid of coloured lights 0.3 m above the floor; radius from threshold 0.05.
    let mut lights = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            let position = Vec3::new(-7.0 + 2.0 * i as f32, 0.3, -12.0 + 2.0 * j as f32);
            let color = Vec3::new(i as f32 / 7.0, 0.5, j as f32 / 7.0);
            lights.push(Light::point(position, color, 0.4, 0.05)?);
        }
    }
    let packed = try_pack_lights(&lights)?;

    // 4. Cull, with the AABB test on top of the planes.
    let config = CullConfig { tile_size: 16, aabb: true, ..CullConfig::default() };
    let lists = cull_tiles(&depth, w, h, &camera, &packed, &config)?;
    let s = stats(&lists);
    println!(
        "{} lights, {}x{} tiles: mean {:.1}, max {} lights per tile over {} tiles with geometry; \
         false-positive rate {:.1}%",
        packed.len(),
        lists.grid.tiles_x,
        lists.grid.tiles_y,
        s.mean_per_list,
        s.max_per_list,
        s.tiles_with_geometry,
        100.0 * false_positive_rate(&depth, &camera, &packed, &lists)
    );
    // Lights per tile, one character a tile (. none, 1-9, + ten or more).
    for ty in 0..lists.grid.tiles_y {
        let row: String = (0..lists.grid.tiles_x)
            .map(|tx| match lists.lists[(ty * lists.grid.tiles_x + tx) as usize].len() {
                0 => '.',
                n @ 1..=9 => char::from_digit(n as u32, 10).unwrap_or('?'),
                _ => '+',
            })
            .collect();
        println!("  {row}");
    }

    // 5. No false negatives: every light reaching a pixel is in that pixel's tile list.
    let view = camera.view();
    let mut pairs = 0usize;
    for y in 0..h {
        for x in 0..w {
            let Some(p) = pixel_view_position(&camera, w, h, x, y, depth[(y * w + x) as usize]) else { continue };
            let tile = ((y / 16) * lists.grid.tiles_x + x / 16) as usize;
            for l in lights_reaching(&view, &packed, p, 0.0) {
                assert!(
                    lists.lists[tile].binary_search(&l).is_ok(),
                    "light {l} reaches pixel ({x}, {y}) but not its list"
                );
                pairs += 1;
            }
        }
    }
    println!("checked {pairs} (pixel, light) pairs: every reaching light is in its tile's list");
    assert!(pairs > 0, "no light reaches the floor: the example shows nothing");
    Ok(())
}
