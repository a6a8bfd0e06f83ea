//! A sweep of your own through the lab's API: light count x tile size, Forward+ on the
//! default courtyard at a small size, every pass's median GPU time written to a CSV.
//!
//! Run it (any GPU; on lavapipe, Mesa's CPU Vulkan, it takes about a minute):
//!
//! ```text
//! WGPU_ADAPTER_NAME=llvmpipe WGPU_BACKEND=vulkan \
//!     cargo run -p tiledlight-lab --example lights_by_tile -- out/lights_by_tile.csv
//! ```
//!
//! The CSV (default `out/lights_by_tile.csv`) has one row per point and pass:
//! `lights,tile-size,pass,median_ms,min_ms,max_ms,frames`. Run it again and the points
//! already in the file are skipped ([`ResumableCsv`]); delete the file to measure again.
//!
//! What the lab gives here: the axes (`NAME=VALUES`, ranges), their product, the
//! resumable CSV and the frame loop with its per-pass timings. What the program brings:
//! its own settings type ([`Small`]), on which the two axes act through [`Flags`].

use std::path::PathBuf;

use anyhow::{bail, ensure, Context, Result};
use tiledlight_lab::axes::{self, Flags, ResumableCsv};
use tiledlight_lab::bench;
use tiledlight_setup::{Prepared, Settings};

/// The settings this program varies: the light count and the tile size, at 320x180.
#[derive(Clone, Debug, Default)]
struct Small {
    lights: Option<u64>,
    tile_size: Option<u32>,
}

impl Flags for Small {
    fn set_axis(&mut self, name: &str, value: &str) -> Result<()> {
        let n = || value.parse::<u64>().with_context(|| format!("{name} '{value}': expected an integer"));
        match name {
            "lights" => self.lights = Some(n()?),
            "tile-size" => self.tile_size = Some(u32::try_from(n()?).context("tile-size: too large")?),
            _ => bail!("this example sweeps lights and tile-size only, not '{name}'"),
        }
        Ok(())
    }

    fn plain(&self) -> Settings {
        let d = Settings::default();
        Settings {
            width: 320,
            height: 180,
            lights: self.lights.or(d.lights),
            tile_size: self.tile_size.unwrap_or(d.tile_size),
            ..d
        }
    }
}

fn main() -> Result<()> {
    // Headless: no window-system probe by Mesa's device-select layer (as the app does).
    tiledlight_gpu::skip_display_gpu_probe();
    let out = std::env::args().nth(1).map_or_else(|| PathBuf::from("out/lights_by_tile.csv"), PathBuf::from);
    // Two axes: a doubling range and a list. Their values are checked here, by the
    // library settings' own ranges (tile-size=12 would fail now, not mid-run).
    let axes = vec![axes::parse_axis::<Small>("lights=64..256")?, axes::parse_axis::<Small>("tile-size=8,16,32")?];
    let points = axes::points(&axes)?;
    let header: Vec<String> =
        ["lights", "tile-size", "pass", "median_ms", "min_ms", "max_ms", "frames"].map(String::from).to_vec();
    // A point is done once its last row (the "total" pass) is in the file.
    let mut csv = ResumableCsv::open(&out, &header, &[0, 1], Some((2, "total")))?;
    let mut prep: Option<Prepared> = None;
    let pending: Vec<&axes::Point> = points.iter().filter(|p| !csv.is_done(p)).collect();
    for point in pending {
        let settings = axes::args_at(&Small::default(), &axes, point)?.settings()?;
        // One GPU context and scene for the run; a new point rebuilds only what changed.
        let p = match prep.as_mut() {
            Some(p) => {
                p.reconfigure(&settings)?;
                p
            }
            None => prep.insert(Prepared::new(&settings)?),
        };
        let mut renderer = p.renderer(false)?;
        let m = bench::measure(p, &mut renderer, 3, 10)?;
        ensure!(m.timestamps, "the adapter has no timestamp queries: no pass times to write");
        let passes = m.passes();
        let mut rows: Vec<Vec<String>> = passes
            .iter()
            .map(|ps| {
                let s = ps.summary;
                let times = [s.median_ms, s.min_ms, s.max_ms].map(|t| format!("{t:.4}"));
                [point.clone(), vec![ps.pass.clone()], times.to_vec(), vec![s.frames.to_string()]].concat()
            })
            .collect();
        let total: f64 = passes.iter().map(|ps| ps.summary.median_ms).sum();
        let frames = passes.iter().map(|ps| ps.summary.frames).min().unwrap_or(0);
        let mut last = point.clone();
        last.extend(["total".into(), format!("{total:.4}"), String::new(), String::new(), frames.to_string()]);
        rows.push(last);
        csv.append(&rows)?;
        println!("{}: {total:.3} ms over {} passes", axes::describe(&axes, point), passes.len());
    }
    println!("wrote {}", out.display());
    Ok(())
}
