//! The lab as a library, on the GPU (lavapipe in CI): the frame loop measures every pass
//! of a small Forward+ frame, `render_frame` reads back images of the frame's size, and the
//! lab's axes build a point's settings from a base (`Flags` on the library settings' own
//! terms: a program without the app's flags).

use anyhow::Result;
use tiledlight_lab::axes::{self, Flags};
use tiledlight_lab::bench;
use tiledlight_setup::{Prepared, Settings};

/// A 64x36 frame of the courtyard with a light count and a tile size of its own.
#[derive(Clone, Debug, Default)]
struct Tiny {
    lights: Option<u64>,
    tile_size: Option<u32>,
}

impl Flags for Tiny {
    fn set_axis(&mut self, name: &str, value: &str) -> Result<()> {
        match name {
            "lights" => self.lights = Some(value.parse()?),
            "tile-size" => self.tile_size = Some(value.parse()?),
            _ => anyhow::bail!("not an axis of this test: {name}"),
        }
        Ok(())
    }

    fn plain(&self) -> Settings {
        let d = Settings::default();
        Settings {
            width: 64,
            height: 36,
            lights: self.lights.or(Some(16)),
            tile_size: self.tile_size.unwrap_or(16),
            ..d
        }
    }
}

#[test]
fn the_frame_loop_measures_a_point_of_a_sweep() {
    tiledlight_gpu::skip_display_gpu_probe();
    let axes = vec![axes::parse_axis::<Tiny>("lights=8").unwrap(), axes::parse_axis::<Tiny>("tile-size=32").unwrap()];
    let point = &axes::points(&axes).unwrap()[0];
    let settings = axes::args_at(&Tiny::default(), &axes, point).unwrap().settings().unwrap();
    assert_eq!((settings.lights, settings.tile_size, settings.width), (Some(8), 32, 64));
    let prep = Prepared::new(&settings).expect("a GPU adapter (lavapipe in CI)");
    let mut renderer = prep.renderer(false).unwrap();
    let m = bench::measure(&prep, &mut renderer, 0, 3).unwrap();
    assert_eq!(m.cpu_ms.len(), 3);
    if m.timestamps {
        let passes: Vec<String> = m.passes().into_iter().map(|p| p.pass).collect();
        assert!(passes.iter().any(|p| p == "forward.shade"), "{passes:?}");
        assert!(bench::table(&m).contains("total GPU"));
    }
    assert!(!m.dropped().any(), "8 lights fill no grid");
    let f = bench::render_frame(&prep.ctx, &mut renderer, &prep.scene_gpu, &prep.camera).unwrap();
    assert_eq!((f.hdr.len(), f.ldr.len()), (64 * 36, 64 * 36 * 4));
    assert!(f.hdr.iter().any(|p| p[0] > 0.0), "the courtyard is lit");
}
