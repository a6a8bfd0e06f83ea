//! The table of pass settings ([`Knobs`], [`KNOBS`]): every setting that a pass reads
//! declared once, as one row of the [`knobs!`](crate::knobs!) invocation below: its field
//! and type, default, command-line name and help, the methods it applies to, its check and
//! the viewer's control. Everything else is derived from the rows, never spelled again:
//!
//! 1. the struct [`Knobs`] (one field a row) that the frame settings carry and
//!    [`crate::features::Features::knobs`] hands to every pass;
//! 2. the command-line flags (the app builds them from [`KNOBS`]: `--NAME VALUE`, or for a
//!    switch `--NAME` when it is off by default and `--no-NAME` when on);
//! 3. the lab's axes and the viewer's script keys (`NAME=VALUE`, [`Knob::set`]);
//! 4. the range checks ([`Knobs::check`], errors naming the flag);
//! 5. what a change rebuilds (each row rebuilds the renderer; [`Knobs::changed`] lists the
//!    rows that differ);
//! 6. the reports' and the JSON's keys ([`Knob::field`], values by [`Knob::get`]);
//! 7. the viewer's controls ([`Knob::control`]), shown for the methods a row applies to.
//!
//! So a switch that reaches one pass is one row here, its read in the pass
//! (`features.knobs.NAME`) and its WGSL: three files.
//!
//! Why a `macro_rules!` table and not a derive or an inventory: the rows are data of one
//! crate, a declarative macro needs no proc-macro crate or linker section, and the
//! generated code stays readable by `cargo expand`. Settings that are not a pass's (the
//! scene, the lights, the screen) live in `tiledlight-setup`'s `Settings`.
//!
//! Depends on [`crate::method`] (the method and raster types) and tiledlight-cull (the draw
//! order).

use std::fmt;

use crate::method::{LargeRaster, MethodTraits, Raster};
use tiledlight_cull::draw_order::DrawOrderMode;
use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat, TILE_SIZES};

/// How blended geometry is composited.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BlendMode {
    /// Instances sorted back to front each frame and drawn "over" (TiledLighting11's way).
    #[default]
    Sorted,
    /// Weighted blended order-independent transparency (McGuire and Bavoil 2013): no sort,
    /// an approximation of "over" whose error the lab measures against the sorted result.
    WeightedOit,
}

impl BlendMode {
    /// Both modes.
    pub const ALL: [BlendMode; 2] = [Self::Sorted, Self::WeightedOit];

    /// The flag value.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sorted => "sorted",
            Self::WeightedOit => "wboit",
        }
    }
    /// The mode of flag value `name` (`sorted`, `wboit`).
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "sorted" => Ok(Self::Sorted),
            "wboit" => Ok(Self::WeightedOit),
            _ => Err(format!("blend mode {name:?}: use sorted or wboit")),
        }
    }
}

/// What kind of value a row holds: how a command line, a chart's axis and the JSON write it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// On or off: a flag on the command line, `on`/`off` on an axis, a JSON boolean.
    Switch,
    /// A whole number.
    Count,
    /// A real number.
    Number,
    /// One of these names.
    Choice(&'static [&'static str]),
    /// One of these whole numbers (written as numbers: on a chart's axis and in JSON).
    Values(&'static [&'static str]),
    /// Free text (a file or a scene's name): a string in JSON, never a numeric axis.
    Text,
}

/// A value a row can hold: parsed from and written as the command line's text.
pub trait KnobValue: Clone + PartialEq + fmt::Debug + 'static {
    /// How it is written.
    const KIND: Kind;
    /// The value of `text` (an error says what was expected).
    fn parse(text: &str) -> Result<Self, String>;
    /// The text that parses back to this value.
    fn text(&self) -> String;
    /// One line on what the choice named `name` does (a command line's help lists it
    /// beside the name); None: the name says it.
    fn value_help(_name: &str) -> Option<&'static str> {
        None
    }
}

impl KnobValue for bool {
    const KIND: Kind = Kind::Switch;
    fn parse(text: &str) -> Result<Self, String> {
        match text.to_ascii_lowercase().as_str() {
            "on" | "true" | "yes" | "1" => Ok(true),
            "off" | "false" | "no" | "0" => Ok(false),
            _ => Err("expected on or off".into()),
        }
    }
    fn text(&self) -> String {
        if *self { "on" } else { "off" }.into()
    }
}

impl KnobValue for u32 {
    const KIND: Kind = Kind::Count;
    fn parse(text: &str) -> Result<Self, String> {
        text.trim().parse().map_err(|_| "expected a whole number".into())
    }
    fn text(&self) -> String {
        self.to_string()
    }
}

impl KnobValue for u64 {
    const KIND: Kind = Kind::Count;
    fn parse(text: &str) -> Result<Self, String> {
        text.trim().parse().map_err(|_| "expected a whole number".into())
    }
    fn text(&self) -> String {
        self.to_string()
    }
}

impl KnobValue for f32 {
    const KIND: Kind = Kind::Number;
    fn parse(text: &str) -> Result<Self, String> {
        text.trim().parse().map_err(|_| "expected a number".into())
    }
    fn text(&self) -> String {
        self.to_string()
    }
}

/// A value that may be left to a default chosen later (a scene's own light count, a list
/// capacity fitted to the GPU): `auto` is None.
impl<T: KnobValue> KnobValue for Option<T> {
    const KIND: Kind = T::KIND;
    fn parse(text: &str) -> Result<Self, String> {
        if text.trim().eq_ignore_ascii_case(AUTO) {
            Ok(None)
        } else {
            T::parse(text).map(Some)
        }
    }
    fn text(&self) -> String {
        self.as_ref().map_or_else(|| AUTO.to_string(), T::text)
    }
}

/// The text of a value left to its default ([`Option`]'s None).
pub const AUTO: &str = "auto";

/// A choice of named values as a [`KnobValue`]: `knob_choice!(Type, ALL, name_fn)` (or
/// with a last argument `Values` when the names are whole numbers); `KIND` lists the names,
/// parsing accepts any case. Exported so that the crates above implement it for their own
/// choices (the run settings' table in tiledlight-setup).
#[macro_export]
macro_rules! knob_choice {
    ($ty:ty, $all:expr, $name:expr) => {
        $crate::knob_choice!($ty, $all, $name, Choice);
    };
    ($ty:ty, $all:expr, $name:expr, $kind:ident) => {
        $crate::knob_choice!($ty, $all, $name, $kind, |_: &str| None);
    };
    ($ty:ty, $all:expr, $name:expr, $kind:ident, $help:expr) => {
        impl $crate::knobs::KnobValue for $ty {
            const KIND: $crate::knobs::Kind = $crate::knobs::Kind::$kind(&{
                let all = $all;
                let mut names = [""; $all.len()];
                let mut i = 0;
                while i < names.len() {
                    names[i] = $name(all[i]);
                    i += 1;
                }
                names
            });
            fn parse(text: &str) -> Result<Self, String> {
                let ($crate::knobs::Kind::Choice(names) | $crate::knobs::Kind::Values(names)) =
                    <Self as $crate::knobs::KnobValue>::KIND
                else {
                    unreachable!()
                };
                names
                    .iter()
                    .position(|n| n.eq_ignore_ascii_case(text.trim()))
                    .map(|i| $all[i])
                    .ok_or_else(|| format!("expected one of {}", names.join(", ")))
            }
            fn text(&self) -> String {
                $name(*self).to_string()
            }
            fn value_help(name: &str) -> Option<&'static str> {
                let help: fn(&str) -> Option<&'static str> = $help;
                help(name)
            }
        }
    };
}

crate::knob_choice!(DrawOrderMode, [DrawOrderMode::FrontToBack, DrawOrderMode::Submission], DrawOrderMode::label);
crate::knob_choice!(ShadowFormat, ShadowFormat::ALL, ShadowFormat::name);
crate::knob_choice!(BlendMode, BlendMode::ALL, BlendMode::name);

crate::knob_choice!(ShadowFilter, ShadowFilter::ALL, ShadowFilter::name, Values);
crate::knob_choice!(Raster, Raster::ALL, Raster::name);
crate::knob_choice!(LargeRaster, LargeRaster::ALL, LargeRaster::name);
crate::knob_choice!(
    tiledlight_scene::GridDensity,
    [tiledlight_scene::GridDensity::Low, tiledlight_scene::GridDensity::Medium, tiledlight_scene::GridDensity::High],
    tiledlight_scene::GridDensity::name
);

/// When a row is read at all, beyond its methods: a change of a row the frame does not
/// read rebuilds nothing (model only what the scene requires).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Needs {
    /// Whenever its method runs.
    Always,
    /// Only while some light casts a shadow (the shadow atlas exists).
    Shadows,
    /// Only while the scene may have alpha-blended geometry.
    Blended,
}

/// The viewer's control for a row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Control {
    /// A checkbox (switches).
    Checkbox,
    /// A slider over this range (numbers).
    Slider(f64, f64),
    /// A drop-down of the names (choices).
    Choice,
}

/// One row of the table: what every layer needs to know of one setting.
#[derive(Clone, Copy)]
pub struct Knob {
    /// The command-line name, the lab's axis, the viewer's script key: `early-outs`.
    pub name: &'static str,
    /// The field of [`Knobs`] and the key in JSON reports: `early_outs`.
    pub field: &'static str,
    /// The flag that turns a switch on by default off: `no-early-outs`.
    pub off_flag: &'static str,
    /// The help, one doc line an entry (the command line's and the viewer's).
    pub help_lines: &'static [&'static str],
    /// The short label of the viewer's control.
    pub label: &'static str,
    /// The placeholder of the value on the command line (`2..5`, `PX`).
    pub value_name: &'static str,
    /// How the value is written.
    pub kind: Kind,
    /// The viewer's control.
    pub control: Control,
    /// Whether a method with these traits reads it (others ignore it): by trait, so a new
    /// method gets the rows its passes read without a change here.
    pub applies: fn(MethodTraits) -> bool,
    /// What else the frame must have for it to be read.
    pub needs: Needs,
    /// The value of the default [`Knobs`], as text.
    pub default: fn() -> String,
    /// The value in `knobs`, as text.
    pub get: fn(&Knobs) -> String,
    /// Sets the value from text (an error names the row and the text).
    pub set: fn(&mut Knobs, &str) -> Result<(), String>,
    /// Checks the value's range (an error names the flag, the value and the limit).
    pub check: fn(&Knobs) -> Result<(), String>,
}

impl fmt::Debug for Knob {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Knob").field("name", &self.name).field("kind", &self.kind).finish_non_exhaustive()
    }
}

impl Knob {
    /// The help as one paragraph.
    pub fn help(&self) -> String {
        self.help_lines.iter().map(|l| l.trim()).collect::<Vec<_>>().join(" ")
    }

    /// The command-line flag without dashes: the name, or for a switch that is on by
    /// default its `no-` form.
    pub fn flag(&self) -> &'static str {
        if self.kind == Kind::Switch && (self.default)() == "on" {
            self.off_flag
        } else {
            self.name
        }
    }

    /// True when the value differs between `a` and `b`.
    pub fn differs(&self, a: &Knobs, b: &Knobs) -> bool {
        (self.get)(a) != (self.get)(b)
    }
}

/// Declares the table: the struct [`Knobs`] and its rows [`KNOBS`], one entry a setting.
///
/// ```text
/// /// Help (the doc lines are the help).
/// field: Type = default; "name", "label", "VALUE", control, applies(|m| ...), check(|v| ...)
///     [, needs(Shadows)];
/// ```
#[macro_export]
macro_rules! knobs {
    (@needs) => { Needs::Always };
    (@needs $needs:ident) => { Needs::$needs };
    ($(
        $(#[doc = $doc:literal])*
        $field:ident : $ty:ty = $default:expr ;
        $name:literal, $label:literal, $value_name:literal, $control:expr,
        applies($applies:expr), check($check:expr) $(, needs($needs:ident))? ;
    )*) => {
        /// Every pass setting's value (the rows of [`KNOBS`]); `Default` is every row's default.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Knobs {
            $( $(#[doc = $doc])* pub $field: $ty, )*
        }

        impl Default for Knobs {
            fn default() -> Self {
                Self { $( $field: $default, )* }
            }
        }

        /// The rows, in the order help and reports list them.
        pub const KNOBS: &[Knob] = &[$(
            Knob {
                name: $name,
                field: stringify!($field),
                off_flag: concat!("no-", $name),
                help_lines: &[$($doc),*],
                label: $label,
                value_name: $value_name,
                kind: <$ty as KnobValue>::KIND,
                control: $control,
                applies: $applies,
                needs: $crate::knobs!(@needs $($needs)?),
                default: || KnobValue::text(&Knobs::default().$field),
                get: |k| KnobValue::text(&k.$field),
                set: |k, text| {
                    k.$field = <$ty as KnobValue>::parse(text).map_err(|e| format!("{} '{text}': {e}", $name))?;
                    Ok(())
                },
                check: |k| {
                    let check: fn($ty) -> Result<(), String> = $check;
                    check(k.$field).map_err(|e| format!("--{} {}: {e}", $name, KnobValue::text(&k.$field)))
                },
            },
        )*];
    };
}

fn any_method(_: MethodTraits) -> bool {
    true
}

fn no_check<T>(_: T) -> Result<(), String> {
    Ok(())
}

/// The methods that draw shadow maps (the traced references cast rays instead).
fn shadow_mapped(m: MethodTraits) -> bool {
    !m.traced
}

knobs! {
    /// The shading's early-outs: a light beyond its radius or behind the surface returns at
    /// once. Off is an ablation: every light a list holds is shaded in full and the result
    /// discarded (the image is the same), to measure what the early-outs save.
    early_outs: bool = true;
    "early-outs", "shading early-outs", "on|off", Control::Checkbox, applies(any_method), check(no_check);

    /// Tiled Deferred's G-buffer render targets, 2 to 5: the extra ones are written white
    /// and read back (the sample's bandwidth stress knob; the image does not change).
    gbuffer_rts: u32 = 2;
    "gbuffer-rts", "G-buffer RTs", "2..5", Control::Slider(2.0, 5.0),
    applies(|m| m.gbuffer),
    check(|v| if (2..=5).contains(&v) { Ok(()) } else { Err("must be between 2 and 5".into()) });

    /// The order the depth pre-pass and the G-buffer draw the scene in: front-to-back
    /// (nearest first, sorted again when the eye moves) or submission (the instance
    /// buffer's, to measure what sorting saves). Images differ only where two surfaces tie
    /// in depth.
    draw_order: DrawOrderMode = DrawOrderMode::FrontToBack;
    "draw-order", "draw order", "ORDER", Control::Choice, applies(any_method), check(no_check);

    /// The visibility buffer's raster: auto (compute on a discrete GPU with 64-bit atomics
    /// at one sample a pixel, else hardware), hardware or compute.
    raster: Raster = Raster::Auto;
    "raster", "raster", "RASTER", Control::Choice, applies(|m| m.visibility_buffer), check(no_check);

    /// The compute raster hands a triangle whose bounds span more pixels than this (either
    /// way) to the large-triangle path.
    raster_large_px: u32 = 32;
    "raster-large-px", "large triangle (px)", "PX", Control::Slider(1.0, 256.0),
    applies(|m| m.visibility_buffer),
    check(|v| if v >= 1 { Ok(()) } else { Err("a triangle spans at least one pixel".into()) });

    /// Who draws the compute raster's large triangles: compute (split into 16 px screen
    /// tiles, a workgroup a tile) or hardware (one indirect draw).
    raster_large: LargeRaster = LargeRaster::Compute;
    "raster-large", "large triangles by", "BY", Control::Choice, applies(|m| m.visibility_buffer),
    check(no_check);

    /// The visibility buffer with MSAA: two triangle IDs in a pixel make it an edge (shaded
    /// per sample) only where their surfaces differ by the edge test (another material,
    /// off the plane or turned beyond --edge-distance and --edge-normal-deg); off, any two
    /// IDs do (a floor of two triangles then has an edge along its diagonal).
    surface_edges: bool = true;
    "surface-edges", "edges by surface, not ID", "on|off", Control::Checkbox,
    applies(|m| m.visibility_buffer), check(no_check);

    /// The visibility buffer's shading stages its workgroup's light list (its first 256
    /// lights: indices and shading records) in workgroup memory once, and every pixel reads
    /// them from there (on an H100: shading 15-25% faster); off, every pixel reads the
    /// records from the light buffer. Used with tile lists only (one list a workgroup);
    /// half-z and clusters read as off. The image is the same.
    stage_lights: bool = true;
    "stage-lights", "stage lists in workgroup memory", "on|off", Control::Checkbox,
    applies(|m| m.visibility_buffer && m.tiled), check(no_check);

    /// The MSAA edge test (Tiled Deferred, visibility buffer): a sample farther than this
    /// fraction of the view distance from sample 0's tangent plane makes the pixel an edge.
    edge_distance: f32 = 0.002;
    "edge-distance", "edge: off-plane distance", "F", Control::Slider(0.0, 0.05),
    applies(|m| m.gbuffer || m.visibility_buffer),
    check(|v| if v.is_finite() && v >= 0.0 { Ok(()) } else { Err("must be a number >= 0".into()) });

    /// The MSAA edge test (Tiled Deferred, visibility buffer): a sample normal turned more
    /// than this many degrees from sample 0's makes the pixel an edge.
    edge_normal_deg: f32 = 10.0;
    "edge-normal-deg", "edge: normal angle (deg)", "DEG", Control::Slider(0.0, 90.0),
    applies(|m| m.gbuffer || m.visibility_buffer),
    check(|v| if (0.0..=180.0).contains(&v) { Ok(()) } else { Err("must be between 0 and 180 degrees".into()) });

    /// Texels per side of each shadow face's atlas tile, 128 to 1024 (used only when some
    /// light casts a shadow).
    shadow_size: u32 = 256;
    "shadow-size", "shadow tile (texels)", "TEXELS", Control::Slider(128.0, 1024.0), applies(shadow_mapped),
    check(|v| {
        if TILE_SIZES.contains(&v) {
            Ok(())
        } else {
            Err(format!("must be between {} and {} texels", TILE_SIZES.start(), TILE_SIZES.end()))
        }
    }), needs(Shadows);

    /// Shadow filter: taps per side of the percentage-closer filter, 1, 3 or 5.
    shadow_filter: ShadowFilter = ShadowFilter::Pcf5;
    "shadow-filter", "shadow PCF taps", "1|3|5", Control::Choice, applies(shadow_mapped), check(no_check),
    needs(Shadows);

    /// Depth format of the shadow atlas: d16 (TiledLighting11's) or d32.
    shadow_format: ShadowFormat = ShadowFormat::Depth16;
    "shadow-format", "shadow depth format", "FORMAT", Control::Choice, applies(shadow_mapped), check(no_check),
    needs(Shadows);

    /// The stochastic method's near candidates a pixel each frame: lights drawn from the
    /// pixel's list in the light grid, for the lights whose radius reaches it, one from each
    /// of as many runs of the list (stratified: none twice; as many as the list is long or
    /// more take every light in it once, its unshadowed light exact). One of all the
    /// candidates is kept in proportion to its unshadowed contribution and shadowed by a
    /// ray: more cost more shading (no more rays) and leave less noise. H100, 1080p, 8
    /// frames of a still camera (docs/ACCURACY.md, "The near field in full"): on the
    /// Figure 9 scene at 4,096 lights 4 give FLIP 0.103 at 3.6 ms, 16 0.097 at 3.8 ms,
    /// every list light (4096) 0.095 at 5.3 ms with PSNR 11 -> 34 dB (no fireflies next to
    /// lights that almost touch a surface); at threshold 0.0015 (longer lists) 4 give 0.176
    /// and 16 0.128.
    candidates: u32 = 4;
    "candidates", "near candidates a pixel", "M", Control::Slider(1.0, 256.0), applies(|m| m.stochastic),
    check(|v| if (1..=4096).contains(&v) { Ok(()) } else { Err("must be between 1 and 4096".into()) });

    /// The stochastic method's far candidates a pixel each frame: lights drawn from every
    /// light, for those whose radius does not reach the pixel (what the cutoff drops). 0
    /// leaves them out: faster, and biased by exactly the cutoff's share.
    far_candidates: u32 = 16;
    "far-candidates", "far candidates a pixel", "M", Control::Slider(0.0, 64.0), applies(|m| m.stochastic),
    check(|v| if v <= 4096 { Ok(()) } else { Err("must be at most 4096".into()) });

    /// The stochastic method's shadow rays a pixel each frame: as many lights kept of the
    /// same candidates (each its own reservoir, their numbers shifted apart so they spread
    /// over the candidates rather than repeat the heaviest), each shadowed by its own ray,
    /// the pixel's light their mean. The noise left when the near lights are shaded in full
    /// is the shadows' (which of the lights a pixel sees): K rays divide its variance by
    /// up to K for K times the rays and no more shading of candidates. 1 to 8.
    rays: u32 = 1;
    "rays", "shadow rays a pixel", "K", Control::Slider(1.0, 8.0), applies(|m| m.stochastic),
    check(|v| {
        use tiledlight_cull::stochastic::MAX_RAYS;
        if (1..=MAX_RAYS).contains(&v) { Ok(()) } else { Err(format!("must be between 1 and {MAX_RAYS}")) }
    });

    /// The stochastic method's far candidates drawn from a light tree over every light (in
    /// proportion to each light's power over its distance, the lights whose radius reaches
    /// the pixel left to its list; `tiledlight_cull::light_tree`): where thousands of lights
    /// lie beyond the radii (the million preset, low thresholds) uniform draws rarely find
    /// the few that matter. Off: uniform over every light, cheaper (no descent; on
    /// lavapipe's courtyard with 256 lights the tree took FLIP after 8 frames 0.196 ->
    /// 0.186 for 1.7x the CPU time, docs/ACCURACY.md); its GPU cost is not measured yet,
    /// so it is off by default: measure it on your scene (`--axis light-tree=off,on`).
    light_tree: bool = false;
    "light-tree", "far candidates from a light tree", "on|off", Control::Checkbox, applies(|m| m.stochastic),
    check(no_check);

    /// The stochastic method's spatial reuse: neighbours whose reservoirs each pixel
    /// merges with its own (drawn from the 31x31-pixel box around it, those whose surface
    /// turns less than 25 degrees and whose distance differs by less than 10%), each
    /// neighbour's light weighed by its contribution here and by its share of the light
    /// among the merged pixels (the balance heuristic: unbiased): a frame's pixel chooses
    /// among (1 + N) times the candidates for N more contribution evaluations and no more
    /// rays (ReSTIR DI's spatial reuse). 0 turns it off (no second run of the pass, no record
    /// buffer); at most 16.
    reuse: u32 = 0;
    "reuse", "spatial reuse neighbours", "N", Control::Slider(0.0, 16.0), applies(|m| m.stochastic),
    check(|v| {
        use tiledlight_cull::reuse::MAX_NEIGHBOURS;
        if v <= MAX_NEIGHBOURS { Ok(()) } else { Err(format!("must be at most {MAX_NEIGHBOURS} neighbours")) }
    });

    /// The stochastic method's temporal reuse: each pixel merges this frame's reservoir with
    /// the one its surface had last frame (found by reprojecting the pixel into the previous
    /// view; none where the surface was hidden, off the screen or after the scene changed),
    /// the history counting at most N times a frame's candidates (ReSTIR DI's temporal
    /// reuse, 20 in the paper; the balance heuristic keeps it unbiased). A light chosen well
    /// once keeps being offered while the camera moves (or with `--accumulate 0`), where
    /// the frames' mean starts again each frame; once a still view accumulates, its frames
    /// stay independent and the mean takes over. On lavapipe's courtyard, the camera
    /// orbiting 1 degree a frame, after 8 frames: FLIP 0.205 -> 0.196 denoised (PSNR 20.6
    /// -> 21.9 dB), the light lost 2.0% -> 0.8% (`accuracy --camera-orbit 1`,
    /// docs/ACCURACY.md); a still view's error is unchanged. 0 turns it off (no history
    /// buffer, 64 bytes a pixel less); at most 64.
    temporal: u32 = 20;
    "temporal", "temporal reuse cap", "N", Control::Slider(0.0, 64.0), applies(|m| m.stochastic),
    check(|v| {
        use tiledlight_cull::temporal::MAX_CAP;
        if v <= MAX_CAP { Ok(()) } else { Err(format!("must be at most {MAX_CAP} (times a frame's candidates)")) }
    });

    /// The stochastic method's history: a pixel's image is the mean of up to this many
    /// frames since the view or the lights last changed (a moving average beyond); 0 shows
    /// each frame's own estimate (the raw estimator's noise, as the lab measures it).
    accumulate: u32 = 64;
    "accumulate", "frames accumulated", "FRAMES", Control::Slider(0.0, 256.0), applies(|m| m.stochastic),
    check(|v| if v <= 65_536 { Ok(()) } else { Err("must be at most 65536 frames".into()) });

    /// The stochastic method's denoiser: iterations of an edge-avoiding à-trous filter
    /// (taps 1, 2, 4, ... pixels apart) guided by each pixel's normal and view distance and
    /// by the variance of its accumulated estimate, on the light over the albedo (textures
    /// stay sharp). As a still view's frames add up the variance falls and the filter lets
    /// the mean through, so it converges to the same truth. 0 shows the accumulated estimate
    /// unfiltered (the raw estimator's error, as the lab measures it).
    denoise: u32 = 4;
    "denoise", "denoiser iterations", "N", Control::Slider(0.0, 8.0), applies(|m| m.stochastic),
    check(|v| {
        use tiledlight_cull::denoise::MAX_ITERATIONS;
        if v <= MAX_ITERATIONS { Ok(()) } else { Err(format!("must be at most {MAX_ITERATIONS} iterations")) }
    });

    /// How alpha-blended geometry (transparent objects, glTF BLEND materials) is composited
    /// over the opaque image: sorted (back to front each frame, drawn "over": exact for
    /// instances that do not interpenetrate, TiledLighting11's way) or wboit (weighted
    /// blended order-independent transparency, McGuire and Bavoil 2013: no sort, an
    /// approximation of "over").
    blend_mode: BlendMode = BlendMode::Sorted;
    "blend-mode", "blended geometry", "MODE", Control::Choice, applies(any_method), check(no_check),
    needs(Blended);
}

impl Knobs {
    /// Checks every row's range; the first error names its flag.
    pub fn check(&self) -> Result<(), String> {
        KNOBS.iter().try_for_each(|k| (k.check)(self))
    }

    /// The rows whose values differ between `self` and `other`.
    pub fn changed(&self, other: &Knobs) -> Vec<&'static Knob> {
        KNOBS.iter().filter(|k| k.differs(self, other)).collect()
    }

    /// The row named `name` ([`Knob::name`]).
    pub fn row(name: &str) -> Option<&'static Knob> {
        KNOBS.iter().find(|k| k.name == name)
    }

    /// Sets row `name` from `text`: None when no row has that name.
    pub fn set(&mut self, name: &str, text: &str) -> Option<Result<(), String>> {
        Self::row(name).map(|k| (k.set)(self, text))
    }
}

/// The table's flags on a command line (feature `clap`): `#[command(flatten)] knobs:
/// KnobArgs` adds one flag a row, named, helped and checked by the row. A value the row
/// cannot parse is clap's usage error naming the flag; a range error is left to
/// [`Knobs::check`], with the other settings' checks.
#[cfg(feature = "clap")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KnobArgs(pub Knobs);

#[cfg(feature = "clap")]
impl clap::FromArgMatches for KnobArgs {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut args = Self::default();
        args.update_from_arg_matches(matches)?;
        Ok(args)
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        for row in KNOBS {
            let flag = Flag { id: row.field, long: row.flag(), kind: row.kind, value_name: row.value_name };
            if let Some(text) = flag.given(matches, &(row.default)()) {
                (row.set)(&mut self.0, &text).map_err(|e| {
                    clap::Error::raw(clap::error::ErrorKind::ValueValidation, format!("--{}: {e}\n", row.flag()))
                })?;
            }
        }
        Ok(())
    }
}

#[cfg(feature = "clap")]
impl clap::Args for KnobArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        KNOBS.iter().fold(cmd, |cmd, row| {
            // Under their own heading, listed by --help only (-h names the group).
            let flag = Flag { id: row.field, long: row.flag(), kind: row.kind, value_name: row.value_name };
            cmd.arg(
                flag.arg(row.help(), &(row.default)(), |_| None).help_heading("Pass settings").hide_short_help(true),
            )
        })
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// One table row as a command-line flag (feature `clap`): the pass settings' table here
/// and the run settings' table of tiledlight-setup build their flags with it.
#[cfg(feature = "clap")]
#[derive(Clone, Copy, Debug)]
pub struct Flag {
    /// clap's id (a row's field: unique in a command).
    pub id: &'static str,
    /// The flag without dashes.
    pub long: &'static str,
    /// How the value is written.
    pub kind: Kind,
    /// The value's placeholder.
    pub value_name: &'static str,
}

#[cfg(feature = "clap")]
impl Flag {
    /// The argument: a switch flips its default; a choice lists its names (with
    /// `value_help`'s line beside each); a count, number or text takes a value, with the
    /// default as clap's (a subcommand may give its own with `mut_arg`) unless it is
    /// [`AUTO`] (the help then says what auto is).
    pub fn arg(&self, help: String, default: &str, value_help: fn(&str) -> Option<&'static str>) -> clap::Arg {
        let arg = clap::Arg::new(self.id).long(self.long).help(help);
        let arg = match self.kind {
            Kind::Switch => return arg.action(clap::ArgAction::SetTrue),
            Kind::Choice(names) | Kind::Values(names) => {
                let values = names.iter().map(|&n| {
                    let v = clap::builder::PossibleValue::new(n);
                    match value_help(n) {
                        Some(h) => v.help(h),
                        None => v,
                    }
                });
                arg.value_parser(clap::builder::PossibleValuesParser::new(values)).value_name(self.value_name)
            }
            Kind::Count | Kind::Number | Kind::Text => arg.value_name(self.value_name),
        };
        // A choice named auto is a value like any other; elsewhere auto is "left to later".
        if default == AUTO && !matches!(self.kind, Kind::Choice(_) | Kind::Values(_)) {
            arg
        } else {
            arg.default_value(default.to_string())
        }
    }

    /// The text a command line gives this flag in `matches`: a switch's flipped default,
    /// else its value; None when the flag is not given.
    pub fn given(&self, matches: &clap::ArgMatches, default: &str) -> Option<String> {
        if self.kind == Kind::Switch {
            let flipped = if default == "on" { "off" } else { "on" };
            matches.get_flag(self.id).then(|| flipped.to_string())
        } else {
            matches.get_one::<String>(self.id).cloned()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every row's default parses back to itself, passes its check, and its text is one of
    /// its choices; names and fields are unique and spelled alike.
    #[test]
    fn every_row_round_trips_and_names_are_unique() {
        let mut names = std::collections::HashSet::new();
        for k in KNOBS {
            assert!(names.insert(k.name), "{} twice", k.name);
            assert_eq!(k.field.replace('_', "-"), k.name, "field and name spelled alike");
            let mut knobs = Knobs::default();
            let default = (k.default)();
            (k.set)(&mut knobs, &default).unwrap();
            assert_eq!(knobs, Knobs::default(), "{}", k.name);
            (k.check)(&knobs).unwrap();
            if let Kind::Choice(names) | Kind::Values(names) = k.kind {
                assert!(names.contains(&default.as_str()), "{}", k.name);
                assert_eq!(k.control, Control::Choice);
            }
            if let Kind::Values(names) = k.kind {
                assert!(names.iter().all(|n| n.parse::<u32>().is_ok()), "{}: values are whole numbers", k.name);
            }
            assert!(!k.help().is_empty() && !k.help().contains("  "), "{}", k.name);
        }
    }

    /// A value is set by name, a bad one named in the error, a range error names the flag.
    #[test]
    fn rows_set_check_and_report_changes() {
        let mut k = Knobs::default();
        k.set("gbuffer-rts", "4").unwrap().unwrap();
        k.set("early-outs", "off").unwrap().unwrap();
        k.set("draw-order", "Submission").unwrap().unwrap();
        k.set("raster", "compute").unwrap().unwrap();
        assert_eq!(
            (k.gbuffer_rts, k.early_outs, k.draw_order, k.raster),
            (4, false, DrawOrderMode::Submission, Raster::Compute)
        );
        let changed: Vec<_> = k.changed(&Knobs::default()).iter().map(|r| r.name).collect();
        assert_eq!(changed, ["early-outs", "gbuffer-rts", "draw-order", "raster"]);
        assert!(k.set("bogus", "1").is_none());
        let e = k.set("raster", "sideways").unwrap().unwrap_err();
        assert!(e.contains("raster 'sideways'") && e.contains("auto, hardware, compute"), "{e}");
        let e = k.set("gbuffer-rts", "x").unwrap().unwrap_err();
        assert!(e.contains("whole number"), "{e}");
        k.gbuffer_rts = 7;
        assert_eq!(k.check().unwrap_err(), "--gbuffer-rts 7: must be between 2 and 5");
        k.gbuffer_rts = 2;
        k.edge_distance = f32::NAN;
        assert!(k.check().unwrap_err().starts_with("--edge-distance NaN"));
        k.edge_distance = 0.0;
        k.edge_normal_deg = 181.0;
        assert!(k.check().unwrap_err().starts_with("--edge-normal-deg 181"));
        k.edge_normal_deg = 180.0;
        k.raster_large_px = 0;
        assert!(k.check().unwrap_err().starts_with("--raster-large-px 0"));
        k.raster_large_px = 1;
        // The shadow rows: a size out of range, a filter and a format by name.
        k.shadow_size = 100;
        assert_eq!(k.check().unwrap_err(), "--shadow-size 100: must be between 128 and 1024 texels");
        k.shadow_size = 1024;
        k.check().unwrap();
        k.set("shadow-filter", "3").unwrap().unwrap();
        k.set("shadow-format", "d32").unwrap().unwrap();
        assert_eq!((k.shadow_filter, k.shadow_format), (ShadowFilter::Pcf3, ShadowFormat::Depth32));
        let e = k.set("shadow-filter", "2").unwrap().unwrap_err();
        assert!(e.contains("shadow-filter '2'") && e.contains("1, 3, 5"), "{e}");
    }

    /// Every row is a flag: parsed into the row's field, a bad value refused by name.
    #[cfg(feature = "clap")]
    #[test]
    fn every_row_is_a_command_line_flag() {
        use clap::{Args, FromArgMatches};
        let cmd = KnobArgs::augment_args(clap::Command::new("t").no_binary_name(true));
        let parse = |args: &[&str]| {
            let m = cmd.clone().try_get_matches_from(args)?;
            KnobArgs::from_arg_matches(&m).map(|a| a.0)
        };
        assert_eq!(parse(&[]).unwrap(), Knobs::default());
        let k =
            parse(&["--no-early-outs", "--gbuffer-rts", "3", "--draw-order", "submission", "--edge-distance", "0.25"])
                .unwrap();
        assert_eq!(
            (k.early_outs, k.gbuffer_rts, k.draw_order, k.edge_distance),
            (false, 3, DrawOrderMode::Submission, 0.25)
        );
        let e = parse(&["--gbuffer-rts", "three"]).unwrap_err().to_string();
        assert!(e.contains("--gbuffer-rts") && e.contains("whole number"), "{e}");
        assert!(parse(&["--raster", "sideways"]).is_err());
        assert!(parse(&["--early-outs"]).is_err(), "a switch on by default has only its --no- flag");
        let help = cmd.clone().render_long_help().to_string();
        for row in KNOBS {
            assert!(help.contains(&format!("--{}", row.flag())), "{}", row.name);
            // Every switch's flag flips exactly its own row (a command line that names a
            // row's flag sets that row: the app's and the lab's tests need not list rows).
            if row.kind == Kind::Switch {
                let flag = format!("--{}", row.flag());
                let k = parse(&[flag.as_str()]).unwrap();
                let changed: Vec<&str> = Knobs::default().changed(&k).iter().map(|r| r.name).collect();
                assert_eq!(changed, [row.name], "{flag}");
            }
        }
    }

    /// A switch on by default is turned off by `--no-NAME`; one off by default by `--NAME`.
    #[test]
    fn switch_flags_follow_the_default() {
        assert_eq!(Knobs::row("early-outs").unwrap().flag(), "no-early-outs");
        assert_eq!(Knobs::row("gbuffer-rts").unwrap().flag(), "gbuffer-rts");
        // Rows apply by trait: a forward method (tiles, no G-buffer, no visibility buffer)
        // has no G-buffer targets; a traced one reads the raster and draws no shadow maps.
        let forward = MethodTraits {
            tiled: true,
            gbuffer: false,
            visibility_buffer: false,
            traced: false,
            stochastic: false,
            cutoff: true,
        };
        let traced = MethodTraits {
            tiled: false,
            gbuffer: false,
            visibility_buffer: true,
            traced: true,
            stochastic: false,
            cutoff: false,
        };
        assert!(!(Knobs::row("gbuffer-rts").unwrap().applies)(forward));
        assert!((Knobs::row("raster").unwrap().applies)(traced));
        assert!(!(Knobs::row("stage-lights").unwrap().applies)(traced), "staging needs tile lists");
        assert!(
            !(Knobs::row("shadow-size").unwrap().applies)(traced)
                && (Knobs::row("shadow-size").unwrap().applies)(forward)
        );
    }
}
