//! No wrong image without a warning: what a run's frames lost to a full light grid (the
//! opaque geometry's, the alpha-blended geometry's own and the virtual point lights'), as the one `warning:` line a
//! command prints on stderr ([`warn`]), the fields of bench's `--json` and the lab's CSV
//! columns, the marks of tables and charts, and `--strict`, which makes any warning an
//! error with a non-zero exit once the output files are written ([`strict`]). The scene's
//! load warnings (a missing texture...) travel next to them as a field of their own
//! ([`load_warnings_cell`]).
//!
//! A light grid drops (list, light) pairs only when its index buffer is full and cannot
//! grow: a fixed budget (the hidden `--grid-budget` flag) or the device's largest storage
//! binding (`max_storage_buffer_binding_size`). Such a frame is wrong where lights were
//! dropped, and its time is that of less work than the whole frame. The workgroup list
//! (`--capacity`) drops nothing: longer lists are culled a second time into the grid.
//! The VPLs' grid has a fixed budget of `VPL_GRID_PER_TILE` indices a tile (fewer with a
//! lower `--vpl-cap`) and never grows: its drops are named apart, with what lowers them.
//! The CSVs' `dropped_*` cells sum the grids; bench's JSON has each grid's own fields.
//!
//! May depend on [`crate::output`], tiledlight-gpu (the grid's header, the renderer) and
//! tiledlight-setup.

use anyhow::{bail, Context, Result};
use serde::Serialize;
use tiledlight_cull::vpl::VPL_GRID_PER_TILE;
use tiledlight_frame::FrameRenderer;
use tiledlight_gpu::light_grid::GridStatus;
use tiledlight_setup::{group_digits, Prepared};

/// The lab CSVs' column of the scene's load warnings, next to the `dropped_*` columns.
pub const LOAD_WARNINGS_COLUMN: &str = "load_warnings";

/// The lab CSVs' column of VPLs the cap refused in a point's last frame (empty without
/// VPLs).
pub const VPLS_REFUSED_COLUMN: &str = "vpls_refused";

/// The [`VPLS_REFUSED_COLUMN`] cell of a frame's VPL count (made, refused).
pub fn vpls_refused_cell(count: Option<(u32, u32)>) -> String {
    count.map(|(_, refused)| refused.to_string()).unwrap_or_default()
}

/// The [`LOAD_WARNINGS_COLUMN`] cell: the scene's load warnings (`Prepared::scene_warnings`,
/// each printed as a `warning:` line when the scene loaded) joined by " | "; empty for none.
pub fn load_warnings_cell(warnings: &[String]) -> String {
    warnings.join(" | ")
}

/// What one light grid lost over the frames whose header was read back.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct GridDrops {
    /// Headers read back.
    pub frames_read: usize,
    /// Of them, the frames that dropped lights.
    pub frames: usize,
    /// (list, light) pairs dropped, summed over those frames.
    pub pairs: u64,
    /// Lists that lost lights, summed over those frames.
    pub lists: u64,
    /// Of the dropping frames, the largest need: (pairs found, indices the grid held).
    #[serde(skip)]
    pub worst: Option<(u32, u32)>,
}

impl GridDrops {
    /// The drops of these headers (None without any: no grid, or none read back).
    pub fn of(statuses: &[GridStatus]) -> Option<Self> {
        if statuses.is_empty() {
            return None;
        }
        let mut d = GridDrops { frames_read: statuses.len(), ..Default::default() };
        for s in statuses.iter().filter(|s| !s.complete()) {
            let h = &s.header;
            d.frames += 1;
            d.pairs += u64::from(h.dropped_pairs);
            d.lists += u64::from(h.dropped_lists);
            if d.worst.is_none_or(|(need, _)| h.pairs > need) {
                d.worst = Some((h.pairs, h.capacity));
            }
        }
        Some(d)
    }
}

/// What the frames lost, per grid (None: the method has no such grid, the scene no
/// blended geometry, or the settings no VPLs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dropped {
    /// The opaque geometry's light grid.
    pub opaque: Option<GridDrops>,
    /// The alpha-blended geometry's own light grid.
    pub blended: Option<GridDrops>,
    /// The virtual point lights' own light grid (`--vpl`, tiled methods).
    pub vpl: Option<GridDrops>,
}

impl Dropped {
    /// The drops of the opaque and the blended grid's headers.
    pub fn of(opaque: &[GridStatus], blended: &[GridStatus]) -> Self {
        Self { opaque: GridDrops::of(opaque), blended: GridDrops::of(blended), vpl: None }
    }

    /// The same, with the drops of the VPL grid's headers.
    pub fn with_vpl(self, vpl: &[GridStatus]) -> Self {
        Self { vpl: GridDrops::of(vpl), ..self }
    }

    /// The last frame of `renderer` (its headers read back, stalling): what its image lost.
    pub fn last_frame(prep: &Prepared, renderer: &FrameRenderer) -> Result<Self> {
        let (device, queue) = (&prep.ctx.device, &prep.ctx.queue);
        let opaque = match renderer.outputs().light_grid {
            Some(g) => vec![g.status(device, queue).context("reading the light grid's header back")?],
            None => Vec::new(),
        };
        let blended = match renderer.outputs().blended.and_then(|b| b.culling.as_ref()) {
            Some(c) => vec![c.grid.status(device, queue).context("reading the blended light grid's header back")?],
            None => Vec::new(),
        };
        let vpl = match renderer.outputs().vpl_light_grid {
            Some(g) => vec![g.status(device, queue).context("reading the VPL light grid's header back")?],
            None => Vec::new(),
        };
        Ok(Self::of(&opaque, &blended).with_vpl(&vpl))
    }

    fn grids(&self) -> impl Iterator<Item = &GridDrops> {
        self.opaque.iter().chain(self.blended.iter()).chain(self.vpl.iter())
    }

    /// True when some frame dropped lights.
    pub fn any(&self) -> bool {
        self.frames() > 0
    }

    /// Frames read back that dropped lights (of any grid: the largest count, as all are
    /// read back from the same frames, though not always all).
    pub fn frames(&self) -> usize {
        self.grids().map(|g| g.frames).max().unwrap_or(0)
    }

    /// Frames whose header was read back (None for a method without a light grid).
    pub fn frames_read(&self) -> Option<usize> {
        self.grids().map(|g| g.frames_read).max()
    }

    /// Pairs dropped, every grid, summed over the frames.
    pub fn pairs(&self) -> u64 {
        self.grids().map(|g| g.pairs).sum()
    }

    /// Lists that lost lights, every grid, summed over the frames.
    pub fn lists(&self) -> u64 {
        self.grids().map(|g| g.lists).sum()
    }

    /// The CSV cells `dropped_frames`, `dropped_lights`, `dropped_lists`, every grid's
    /// together (empty for a method without a light grid).
    pub fn csv(&self) -> [String; 3] {
        match self.frames_read() {
            None => [String::new(), String::new(), String::new()],
            Some(_) => [self.frames().to_string(), self.pairs().to_string(), self.lists().to_string()],
        }
    }

    /// A short mark for a table or log line: "DROPPED lights in 3 of 5 frames" (None when
    /// nothing was dropped).
    pub fn mark(&self) -> Option<String> {
        self.any().then(|| {
            format!("DROPPED lights in {} of {} frames read back", self.frames(), self.frames_read().unwrap_or(0))
        })
    }

    /// The warning (without "warning: ") about `subject` ("the image", "the measured
    /// frames"), None when nothing was dropped. `budget`: the settings' fixed light-grid
    /// budget; `max_binding`: the device's `max_storage_buffer_binding_size`.
    pub fn warning(&self, subject: &str, budget: Option<u32>, max_binding: u64) -> Option<String> {
        if !self.any() {
            return None;
        }
        let mut parts = Vec::new();
        // What would help, from the first grid's cause.
        let mut hint = None;
        let grids = [
            ("", "light", self.opaque),
            ("the blended geometry's lists: ", "light", self.blended),
            ("the VPL lists: ", "VPL", self.vpl),
        ];
        for (name, what, g) in grids {
            let Some(g) = g.filter(|g| g.frames > 0) else { continue };
            let mut p = format!(
                "{name}{} (list, {what}) pairs from {} list{}",
                group_digits(g.pairs),
                group_digits(g.lists),
                if g.lists == 1 { "" } else { "s" }
            );
            if let Some((need, capacity)) = g.worst {
                let (cause, help) = match budget {
                    // The VPLs' grid has its own fixed budget and never grows.
                    _ if what == "VPL" => (
                        format!(
                            "its fixed budget of {} indices (at most {} VPLs a tile; it does not grow)",
                            group_digits(capacity.into()),
                            group_digits(VPL_GRID_PER_TILE.into())
                        ),
                        "fewer VPLs a tile: a larger --vpl-block, a higher --vpl-colour-threshold or \
                         --vpl-brightness-threshold, or a --vpl-cap of at most 1,024",
                    ),
                    Some(b) => (
                        format!("its fixed budget of {} indices (--grid-budget {b})", group_digits(b.into())),
                        "a larger --grid-budget, or none",
                    ),
                    None if u64::from(capacity) >= max_binding / 4 => (
                        format!(
                            "{} indices, the most the device binds (limit max_storage_buffer_binding_size = \
                             {max_binding} bytes, asked for {} bytes)",
                            group_digits(capacity.into()),
                            u64::from(need) * 4
                        ),
                        "fewer lights: --lights, smaller radii: a higher --threshold, or tighter lists: --grid clustered",
                    ),
                    // Grown for the next frame: only frames before the growth lost lights.
                    None => (
                        format!("{} indices, then grew", group_digits(capacity.into())),
                        "--warmup 1 or more lets it grow first",
                    ),
                };
                hint.get_or_insert(help);
                p.push_str(&format!(" (a frame needed {} indices; the grid holds {cause})", group_digits(need.into())));
            }
            parts.push(p);
        }
        let frames = match self.frames_read() {
            Some(1) | None => String::new(),
            Some(n) => format!(" in {} of {n} frames read back", self.frames()),
        };
        let hint = hint.map(|h| format!(" ({h})")).unwrap_or_default();
        Some(format!(
            "{subject}: light lists overflowed{frames}, DROPPED {}: image and times incomplete (docs/RELIABILITY.md, \
             \"Dropped lights\"){hint}",
            parts.join("; ")
        ))
    }
}

/// Prints `line` as one `warning:` line on stderr and counts it.
pub fn warn(count: &mut usize, line: &str) {
    eprintln!("warning: {}", crate::output::one_line(line));
    *count += 1;
}

/// One warning out of a point's dropped-lights warning and its refused-VPLs warning (the
/// lab reports one warning a point).
pub fn join_warnings(a: Option<String>, b: Option<String>) -> Option<String> {
    match (a, b) {
        (Some(a), Some(b)) => Some(format!("{a}; {b}")),
        (a, b) => a.or(b),
    }
}

/// `--strict`: after the output files are written, any warning of the run is an error.
pub fn strict(strict: bool, warnings: usize) -> Result<()> {
    if strict && warnings > 0 {
        let s = if warnings == 1 { "" } else { "s" };
        bail!("--strict: {warnings} warning{s} above (the output files were written)");
    }
    Ok(())
}

/// The `warning:` line for VPLs the cap refused in the last frame of `renderer` (None:
/// none refused, or no VPLs). Reads the count back: call after the frames, not in them.
pub fn refused_warning(
    renderer: &FrameRenderer,
    ctx: &tiledlight_gpu::GpuContext,
    what: &str,
) -> anyhow::Result<Option<String>> {
    Ok(renderer.vpl_count(ctx)?.and_then(|count| refused_line(what, count)))
}

/// The `warning:` line for a frame (`what`) that made `kept` VPLs and refused `refused`
/// (None when none were refused).
pub fn refused_line(what: &str, (kept, refused): (u32, u32)) -> Option<String> {
    (refused > 0).then(|| {
        format!(
            "{what}: the VPL cap (--vpl-cap {kept}) refused {refused} of {} VPLs; their light is missing \
             (raise --vpl-cap, --vpl-block or a --vpl-*-threshold)",
            kept + refused
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn load_warnings_share_one_cell() {
        assert_eq!(load_warnings_cell(&[]), "");
        assert_eq!(load_warnings_cell(&["a.gltf: x".into(), "a.gltf: y".into()]), "a.gltf: x | a.gltf: y");
    }
    use tiledlight_gpu::light_grid::LightGridHeader;

    fn status(pairs: u32, capacity: u32) -> GridStatus {
        let dropped = pairs.saturating_sub(capacity);
        GridStatus::from_gpu(LightGridHeader {
            allocated: pairs,
            pairs,
            dropped_pairs: dropped,
            dropped_lists: if dropped > 0 { 3 } else { 0 },
            capacity,
            ..Default::default()
        })
    }

    #[test]
    fn complete_frames_say_nothing() {
        let d = Dropped::of(&[status(10, 100), status(20, 100)], &[]);
        assert!(!d.any());
        assert_eq!(d.warning("the image", None, 1 << 27), None);
        assert_eq!(d.mark(), None);
        assert_eq!(d.csv(), ["0", "0", "0"]);
        // No grid at all (brute force): empty cells, not zeros.
        assert_eq!(Dropped::of(&[], &[]).csv(), ["", "", ""]);
    }

    #[test]
    fn dropping_frames_are_counted_and_named() {
        let d = Dropped::of(&[status(150, 100), status(10, 100), status(130, 100)], &[status(7, 5)]);
        assert!(d.any());
        assert_eq!((d.frames(), d.frames_read(), d.pairs(), d.lists()), (2, Some(3), 50 + 30 + 2, 9));
        assert_eq!(d.csv(), ["2", "82", "9"]);
        let w = d.warning("the measured frames", Some(100), 1 << 27).unwrap();
        assert!(w.starts_with("the measured frames: light lists overflowed in 2 of 3 frames read back"), "{w}");
        assert!(w.contains("DROPPED 80 (list, light) pairs from 6 lists"), "{w}");
        assert!(
            w.contains(
                "a frame needed 150 indices; the grid holds its fixed budget of 100 indices (--grid-budget 100)"
            ),
            "{w}"
        );
        assert!(w.contains("the blended geometry's lists: 2 (list, light) pairs from 3 lists"), "{w}");
        let w = Dropped::of(&[status(150, 100)], &[]).warning("the image", None, 400).unwrap();
        assert!(w.contains("limit max_storage_buffer_binding_size = 400 bytes, asked for 600 bytes"), "{w}");
        // A grid below the device's limit was growing: the frames before it lost lights.
        let w = Dropped::of(&[status(150, 100)], &[]).warning("the image", None, 4000).unwrap();
        assert!(w.contains("the grid holds 100 indices, then grew): image and times incomplete"), "{w}");
        assert!(w.ends_with("(--warmup 1 or more lets it grow first)"), "{w}");
        assert!(!w.contains("frames read back"), "one frame: {w}");
        assert_eq!(d.mark().unwrap(), "DROPPED lights in 2 of 3 frames read back");
    }

    #[test]
    fn vpl_drops_are_named_apart_with_their_own_cause() {
        // The VPL grid alone overflowed (a fixed budget of 240 tiles x 1,024).
        let d = Dropped::of(&[status(10, 100)], &[]).with_vpl(&[status(250_000, 245_760)]);
        assert!(d.any());
        assert_eq!((d.frames(), d.pairs(), d.lists()), (1, 4_240, 3));
        assert_eq!(d.csv(), ["1", "4240", "3"]);
        let w = d.warning("the image", None, 1 << 27).unwrap();
        assert!(w.contains("DROPPED the VPL lists: 4,240 (list, VPL) pairs from 3 lists"), "{w}");
        assert!(
            w.contains(
                "the grid holds its fixed budget of 245,760 indices (at most 1,024 VPLs a tile; it does not grow)"
            ),
            "{w}"
        );
        assert!(w.contains("(fewer VPLs a tile: a larger --vpl-block"), "{w}");
        assert!(!w.contains("--grid-budget"), "the lights' budget is not the VPLs': {w}");
        // A complete VPL grid says nothing, and adds a frame read back, not a drop.
        let d = Dropped::of(&[status(10, 100)], &[]).with_vpl(&[status(5, 245_760)]);
        assert!(!d.any() && d.warning("the image", None, 1 << 27).is_none());
        assert_eq!(d.csv(), ["0", "0", "0"]);
    }

    #[test]
    fn strict_fails_only_with_warnings() {
        assert!(strict(true, 0).is_ok() && strict(false, 3).is_ok());
        assert!(strict(true, 2).unwrap_err().to_string().contains("--strict: 2 warnings"));
    }
}
