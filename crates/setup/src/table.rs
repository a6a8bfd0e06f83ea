//! The table of run settings ([`SETTINGS`]): every setting of [`Settings`] that is one
//! value (the scene, the lights, the screen and method, the culling, the shadow casters, the
//! input checks) declared once, as one row of the `settings!` invocation below: its field
//! and type, command-line name, help and heading, the viewer's label, the methods it
//! applies to, its range check and what a change rebuilds. The pass settings are the same
//! kind of table one layer down (`tiledlight_gpu::knobs`, the rows a pass reads); this one
//! holds what is not a pass's. Everything else is derived from the rows:
//!
//! 1. the command-line flags (`SettingArgs`, feature `clap`: `--NAME VALUE`, a switch
//!    `--NAME`, under the row's heading; `-h` lists the rows marked `short`);
//! 2. the lab's axes and the viewer's script keys ([`Settings::set_row`]: `NAME=VALUE`;
//!    the lab's axis list and which axes are numeric come from [`Setting::kind`]);
//! 3. the range checks ([`check_rows`], called first by [`Settings::validate`]; the checks
//!    that relate two settings stay there);
//! 4. what a change rebuilds ([`Setting::rebuild`], read by `rebuild_plan`);
//! 5. the reports' names and values ([`Setting::name`], [`Setting::get`]).
//!
//! Settings that are several values at once or derived from several flags (the light
//! placement and its preset, the exposure, the cluster options, VPLs, the camera bookmark,
//! the demo) are the app's flags and the settings' own fields.
//!
//! Why a `macro_rules!` table over the existing fields (not a derive or an inventory): the
//! same reasons as the pass settings' (no proc-macro crate, no linker section, readable by
//! `cargo expand`), and `Settings` keeps its plain typed fields for every reader.
//!
//! Pure data: depends on [`crate::settings`], tiledlight-gpu's table types (`knobs`) and
//! tiledlight-frame's [`Method`]; [`crate::validate`] and [`crate::rebuild`] read it.

use std::fmt;

use tiledlight_cull::lists::MAX_CAPACITY;
use tiledlight_cull::tiles::MAX_SCREEN_SIDE;
use tiledlight_frame::Method;
use tiledlight_gpu::features::MethodTraits;
use tiledlight_gpu::knob_choice;
use tiledlight_gpu::knobs::{Kind, KnobValue};
use tiledlight_scene::{GridDensity, MAX_GRID_OBJECTS, MAX_LIGHTS};

use crate::settings::{CasterChoice, SceneSource, Settings};

/// The light grid's layout: screen tiles, two lists a tile, 2.5D depth masks or clusters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GridLayout {
    /// One list per screen tile (TiledLighting11).
    #[default]
    Tiled,
    /// Two lists per tile, split at the middle of its depth range (TiledLighting11's half-z).
    HalfZ,
    /// One list per tile, lights tested against 32 depth bins of the tile that hold a
    /// surface (Harada 2012).
    DepthMask,
    /// 3D clusters: tiles x exponential depth slices (Olsson 2012), assigned light-centrically.
    Clustered,
}

impl GridLayout {
    /// Every layout.
    pub const ALL: [GridLayout; 4] = [Self::Tiled, Self::HalfZ, Self::DepthMask, Self::Clustered];

    /// The flag value.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Tiled => "tiled",
            Self::HalfZ => "half-z",
            Self::DepthMask => "2.5d",
            Self::Clustered => "clustered",
        }
    }

    /// How the viewer's panel says it.
    pub const fn label(self) -> &'static str {
        match self {
            Self::Tiled => "tiles",
            Self::HalfZ => "half-z (two lists per tile)",
            Self::DepthMask => "2.5D (32 depth bins per tile)",
            Self::Clustered => "clusters (exponential depth slices)",
        }
    }

    /// The layout `s` names.
    pub fn of(s: &Settings) -> Self {
        match (s.clusters.is_some(), s.depth_mask, s.half_z) {
            (true, ..) => Self::Clustered,
            (_, true, _) => Self::DepthMask,
            (_, _, true) => Self::HalfZ,
            _ => Self::Tiled,
        }
    }

    /// Sets `s` to this layout (clusters keep their options, or get the defaults).
    pub fn apply(self, s: &mut Settings) {
        s.half_z = self == Self::HalfZ;
        s.depth_mask = self == Self::DepthMask;
        s.clusters = (self == Self::Clustered).then(|| s.clusters.unwrap_or_default());
    }
}

/// How lights get into the grid's lists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Assign {
    /// Tile-centric: a workgroup per tile tests the lights (TiledLighting11; cost ~ lights
    /// x tiles, two-level by default).
    #[default]
    Gather,
    /// Light-centric: each light scatters itself into the tiles it covers (cost ~ lights +
    /// pairs). Same lists.
    Scatter,
}

impl Assign {
    /// Both.
    pub const ALL: [Assign; 2] = [Self::Gather, Self::Scatter];

    /// The flag value.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Gather => "gather",
            Self::Scatter => "scatter",
        }
    }
}

/// A check that `v` is one of `values` (an error lists them).
fn one_of(v: u32, values: &[u32]) -> Result<(), String> {
    if values.contains(&v) {
        return Ok(());
    }
    let (last, rest) = values.split_last().expect("a choice of at least one value");
    let rest: Vec<String> = rest.iter().map(u32::to_string).collect();
    Err(format!("must be {} or {last}", rest.join(", ")))
}

knob_choice!(GridLayout, GridLayout::ALL, GridLayout::name);
knob_choice!(Assign, Assign::ALL, Assign::name);
knob_choice!(CasterChoice, [CasterChoice::Brightness, CasterChoice::Contribution], CasterChoice::name);

/// `--scene`: a built-in scene's name or a glTF file ([`SceneSource::parse`]).
impl KnobValue for SceneSource {
    const KIND: Kind = Kind::Text;
    fn parse(text: &str) -> Result<Self, String> {
        Ok(SceneSource::parse(text.trim()))
    }
    fn text(&self) -> String {
        self.to_string()
    }
}

/// Where a row is listed in `--help`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Heading {
    /// The scene and its objects.
    Scene,
    /// The random lights.
    Lights,
    /// The renderer and the image.
    MethodAndImage,
    /// The light grid and its tests.
    Culling,
    /// The shadow casters.
    Shadows,
    /// Alpha-blended geometry.
    Blended,
    /// How a glTF file is read.
    InputChecks,
}

impl Heading {
    /// The heading's title.
    pub const fn title(self) -> &'static str {
        match self {
            Self::Scene => "Scene",
            Self::Lights => "Lights",
            Self::MethodAndImage => "Method and image",
            Self::Culling => "Culling",
            Self::Shadows => "Shadows",
            Self::Blended => "Blended geometry",
            Self::InputChecks => "Input checks",
        }
    }
}

/// What a change of a row rebuilds (`rebuild_plan` reads it; its module's table says the
/// same in prose).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rebuilds {
    /// The scene is built again, with its lights and camera (and so the renderer).
    Scene,
    /// The scene when it is a glTF file (its load reads the row), else nothing.
    SceneOfFile,
    /// The scene when it is a glTF file (its own lights' radii follow the row), else the
    /// light data.
    SceneOfFileElseLightData,
    /// New light buffers (and so the renderer) when the random light counts or the
    /// shadow casters change.
    LightBuffers,
    /// The light data is rewritten in place.
    LightData,
    /// The light data, while some light casts a shadow (the casters are chosen again).
    Casters,
    /// The camera (aspect ratio) and the renderer.
    Screen,
    /// The renderer.
    Renderer,
}

/// One row of the table: what every layer needs to know of one run setting.
#[derive(Clone, Copy)]
pub struct Setting {
    /// The command-line name, the lab's axis, the viewer's script key: `tile-size`.
    pub name: &'static str,
    /// The field of [`Settings`] (or, for a row over several fields, its name).
    pub field: &'static str,
    /// The help, one doc line an entry.
    pub help_lines: &'static [&'static str],
    /// A short label (the viewer's panel, the lab's axis list).
    pub label: &'static str,
    /// The placeholder of the value on the command line.
    pub value_name: &'static str,
    /// Where `--help` lists it.
    pub heading: Heading,
    /// Listed by `-h` too (else `--help` only).
    pub short: bool,
    /// How the value is written.
    pub kind: Kind,
    /// What a change rebuilds.
    pub rebuild: Rebuilds,
    /// Whether a method with these traits reads it.
    pub applies: fn(MethodTraits) -> bool,
    /// The value of `Settings::default()`, as text.
    pub default: fn() -> String,
    /// The value in `s`, as text.
    pub get: fn(&Settings) -> String,
    /// Sets the value from text (an error names the row and the text).
    pub set: fn(&mut Settings, &str) -> Result<(), String>,
    /// Checks the value's range (an error names the flag, the value and the limit).
    pub check: fn(&Settings) -> Result<(), String>,
    /// A line on each choice (the methods' summaries), for the command line's help.
    pub value_help: fn(&str) -> Option<&'static str>,
}

impl fmt::Debug for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Setting").field("name", &self.name).field("kind", &self.kind).finish_non_exhaustive()
    }
}

impl Setting {
    /// The help as one paragraph.
    pub fn help(&self) -> String {
        self.help_lines.iter().map(|l| l.trim()).collect::<Vec<_>>().join(" ")
    }

    /// True when the value differs between `a` and `b`.
    pub fn differs(&self, a: &Settings, b: &Settings) -> bool {
        (self.get)(a) != (self.get)(b)
    }

    /// The methods that read this row, when not every method does (`--help` names them).
    pub fn only_for(&self) -> Option<Vec<Method>> {
        let read: Vec<Method> = Method::ALL.into_iter().filter(|m| (self.applies)(m.traits())).collect();
        (read.len() < Method::ALL.len()).then_some(read)
    }

    /// The help, with the methods that read the row when not every method does.
    pub fn full_help(&self) -> String {
        match self.only_for() {
            Some(methods) => {
                let names: Vec<&str> = methods.iter().map(|m| m.name()).collect();
                format!("{} [methods: {}]", self.help(), names.join(", "))
            }
            None => self.help(),
        }
    }
}

/// Declares [`SETTINGS`], one entry a run setting.
///
/// ```text
/// /// Help (the doc lines are the help).
/// field: Type [=> (get, put)]; "name", Heading, "VALUE", "label",
///     applies(|m| ...), check(|v: &Type| ...), rebuild(Rebuilds::...) [, short];
/// ```
/// A row over a field reads and writes it; `=> (get, put)` makes a row over several
/// fields (`get(&Settings) -> Type`, `put(&mut Settings, Type)`).
macro_rules! settings {
    (@short) => { false };
    (@short $short:ident) => { true };
    (@read $s:expr, $field:ident) => { $s.$field.clone() };
    (@read $s:expr, $field:ident, $get:expr) => { ($get)(&$s) };
    (@write $s:expr, $field:ident, $v:expr) => { $s.$field = $v };
    (@write $s:expr, $field:ident, $v:expr, $put:expr) => { ($put)($s, $v) };
    ($(
        $(#[doc = $doc:literal])*
        $field:ident : $ty:ty $(=> ($get:expr, $put:expr))? ;
        $name:literal, $heading:ident, $value_name:literal, $label:literal,
        applies($applies:expr), check($check:expr), rebuild($rebuild:expr) $(, $short:ident)? ;
    )*) => {
        /// The rows, in the order help and reports list them.
        pub const SETTINGS: &[Setting] = &[$(
            Setting {
                name: $name,
                field: stringify!($field),
                help_lines: &[$($doc),*],
                label: $label,
                value_name: $value_name,
                heading: Heading::$heading,
                short: settings!(@short $($short)?),
                kind: <$ty as KnobValue>::KIND,
                rebuild: $rebuild,
                applies: $applies,
                default: || {
                    let s = Settings::default();
                    let v: $ty = settings!(@read s, $field $(, $get)?);
                    KnobValue::text(&v)
                },
                get: |s| {
                    let v: $ty = settings!(@read s, $field $(, $get)?);
                    KnobValue::text(&v)
                },
                set: |s, text| {
                    let v = <$ty as KnobValue>::parse(text).map_err(|e| format!("{} '{text}': {e}", $name))?;
                    settings!(@write s, $field, v $(, $put)?);
                    Ok(())
                },
                check: |s| {
                    let check: fn(&$ty) -> Result<(), String> = $check;
                    let v: $ty = settings!(@read s, $field $(, $get)?);
                    check(&v).map_err(|e| format!("--{} {}: {e}", $name, KnobValue::text(&v)))
                },
                value_help: <$ty as KnobValue>::value_help,
            },
        )*];
    };
}

fn any_method(_: MethodTraits) -> bool {
    true
}

fn tiled(m: MethodTraits) -> bool {
    m.tiled
}

fn no_check<T>(_: &T) -> Result<(), String> {
    Ok(())
}

fn side(v: &u32) -> Result<(), String> {
    if (1..=MAX_SCREEN_SIDE).contains(v) {
        Ok(())
    } else {
        Err(format!("must be between 1 and {MAX_SCREEN_SIDE} pixels"))
    }
}

fn light_count(v: &Option<u64>) -> Result<(), String> {
    match v {
        Some(n) if *n > MAX_LIGHTS => Err(format!("at most {MAX_LIGHTS} lights are supported")),
        _ => Ok(()),
    }
}

settings! {
    /// `default` (the procedural courtyard), `materials` (576 boxes with --materials
    /// distinct textured materials), `bevy-many-lights` (Bevy's many_lights stress test
    /// rebuilt: 100,000 lights of 0.3 m on a sphere) or a glTF file (.gltf or .glb).
    scene: SceneSource;
    "scene", Scene, "default|materials|bevy-many-lights|FILE", "scene",
    applies(any_method), check(no_check), rebuild(Rebuilds::Scene), short;

    /// Random point lights [default: 1024 for the default scene; for a glTF file, random
    /// lights are added to its own lights only when this or --spot-lights is given].
    lights: Option<u64>;
    "lights", Lights, "N", "point lights",
    applies(any_method), check(light_count), rebuild(Rebuilds::LightBuffers), short;

    /// Random spot lights [default: 0]. A glTF scene's go near its surfaces, aimed at them
    /// (never past the first geometry above), their radius following its area and the
    /// count; the default scene's (and with --lights-in-bounds) go in the bounds.
    spot_lights: Option<u64>;
    "spot-lights", Lights, "N", "spot lights",
    applies(any_method), check(light_count), rebuild(Rebuilds::LightBuffers), short;

    /// Seed of the random lights (the same seed gives the same lights).
    seed: u64;
    "seed", Lights, "S", "seed of the random lights",
    applies(any_method), check(no_check), rebuild(Rebuilds::LightData);

    /// Intensity threshold that sets each light's radius: r = sqrt(intensity / T).
    threshold: f32;
    "threshold", Lights, "T", "light intensity threshold, the radius dial",
    applies(any_method),
    check(|v: &f32| if v.is_finite() && *v > 0.0 { Ok(()) } else { Err("must be a positive number".into()) }),
    rebuild(Rebuilds::SceneOfFileElseLightData);

    /// Grid objects (instanced spheres) added to the default scene, 0 to 280.
    grid_objects: u32;
    "grid-objects", Scene, "N", "grid objects of the default scene",
    applies(any_method),
    check(|v: &u32| if *v <= MAX_GRID_OBJECTS { Ok(()) } else { Err(format!("must be between 0 and {MAX_GRID_OBJECTS}")) }),
    rebuild(Rebuilds::Scene), short;

    /// Distinct textured materials of `--scene materials`, 1 to 4096 (box i takes material
    /// i mod N: the boxes, and so the coverage, stay the same).
    materials: u32;
    "materials", Scene, "N", "textured materials of --scene materials",
    applies(any_method),
    check(|v: &u32| {
        use tiledlight_scene::materials::MAX_MATERIALS;
        if (1..=MAX_MATERIALS).contains(v) { Ok(()) } else { Err(format!("must be between 1 and {MAX_MATERIALS}")) }
    }),
    rebuild(Rebuilds::Scene);

    /// Tessellation of the grid objects.
    density: GridDensity;
    "density", Scene, "DENSITY", "grid object tessellation",
    applies(any_method), check(no_check), rebuild(Rebuilds::Scene);

    /// Grid objects drawn as alpha-blended glass spheres, 0 to the grid count (spread evenly
    /// over the grid; the default scene only: a glTF file's BLEND materials are drawn
    /// blended on their own).
    transparent_objects: u32;
    "transparent-objects", Blended, "N", "grid objects drawn as blended glass",
    applies(any_method), check(no_check), rebuild(Rebuilds::Scene), short;

    /// The default scene's banners glow in their colour (emissive materials: Tiled
    /// Deferred's G-buffer gets its emission target; for measuring its cost).
    emissive: bool;
    "emissive", Scene, "on|off", "glowing banners",
    applies(any_method), check(no_check), rebuild(Rebuilds::Scene);

    /// Image width in pixels.
    width: u32;
    "width", MethodAndImage, "W", "image width",
    applies(any_method), check(side), rebuild(Rebuilds::Screen), short;

    /// Image height in pixels.
    height: u32;
    "height", MethodAndImage, "H", "image height",
    applies(any_method), check(side), rebuild(Rebuilds::Screen), short;

    /// Renderer.
    method: Method;
    "method", MethodAndImage, "METHOD", "method",
    applies(any_method), check(no_check), rebuild(Rebuilds::Renderer), short;

    /// MSAA samples per pixel: 1 (off), 2, 4 or 8 (2 and 8 where the GPU has them). Forward+
    /// and brute force use hardware MSAA; Tiled Deferred shades edge pixels per sample.
    msaa: u32;
    "msaa", MethodAndImage, "1|2|4|8", "MSAA samples per pixel, 1 | 2 | 4 | 8",
    applies(any_method), check(|v: &u32| one_of(*v, &[1, 2, 4, 8])),
    rebuild(Rebuilds::Renderer), short;

    /// Tile side in pixels: 8, 16 or 32.
    tile_size: u32;
    "tile-size", Culling, "8|16|32", "tile side in pixels, 8 | 16 | 32",
    applies(tiled), check(|v: &u32| one_of(*v, &[8, 16, 32])),
    rebuild(Rebuilds::Renderer);

    /// Light indices stored per tile list (more are counted as overflow), 1 to 2048.
    /// Default (auto): the light count, up to what the GPU's workgroup memory holds (2048),
    /// so lists overflow only when a tile really sees more lights than that.
    capacity: Option<u32>;
    "capacity", Culling, "N", "lights a tile list holds",
    applies(tiled),
    check(|v: &Option<u32>| match v {
        Some(c) if !(1..=MAX_CAPACITY).contains(c) => Err(format!("must be between 1 and {MAX_CAPACITY} lights per tile list")),
        _ => Ok(()),
    }),
    rebuild(Rebuilds::Renderer);

    /// The light grid's layout: screen tiles, half-z (two lists a tile), 2.5D depth masks
    /// or clusters (the --cluster-* flags shape them).
    grid: GridLayout => (GridLayout::of, |s: &mut Settings, v: GridLayout| v.apply(s));
    "grid", Culling, "LAYOUT", "light grid layout",
    applies(tiled), check(no_check), rebuild(Rebuilds::Renderer);

    /// How lights are assigned to the grid's lists: gather (a workgroup a tile tests the
    /// lights) or scatter (each light writes itself into the tiles it covers; clusters are
    /// always scattered).
    assign: Assign => (
        |s: &Settings| if s.scatter { Assign::Scatter } else { Assign::Gather },
        |s: &mut Settings, v: Assign| s.scatter = v == Assign::Scatter
    );
    "assign", Culling, "HOW", "light assignment",
    applies(tiled), check(no_check), rebuild(Rebuilds::Renderer);

    /// Also test light spheres against each tile's view-space AABB.
    aabb: bool;
    "aabb", Culling, "on|off", "sphere-vs-AABB test",
    applies(tiled), check(no_check), rebuild(Rebuilds::Renderer);

    /// Also test spot cones against each tile (needs spot lights to matter).
    spot_cone: bool;
    "spot-cone", Culling, "on|off", "spot cone test",
    applies(tiled), check(no_check), rebuild(Rebuilds::Renderer);

    /// One-level culling: every tile tests every light (the default first culls per
    /// 64x64-pixel cell, and tiles test only their cell's lights).
    flat_cull: bool;
    "flat-cull", Culling, "on|off", "one-level culling",
    applies(tiled), check(no_check), rebuild(Rebuilds::Renderer);

    /// Shadow-casting point lights: the N brightest point lights cast shadows (six cube
    /// faces each, in the shadow atlas).
    shadow_point_lights: u32;
    "shadow-point-lights", Shadows, "N", "shadow-casting point lights",
    applies(crate::settings::reads_casters), check(no_check), rebuild(Rebuilds::LightBuffers), short;

    /// Shadow-casting spot lights: the N brightest spot lights cast shadows (one face each).
    shadow_spot_lights: u32;
    "shadow-spot-lights", Shadows, "N", "shadow-casting spot lights",
    applies(crate::settings::reads_casters), check(no_check), rebuild(Rebuilds::LightBuffers);

    /// How the shadow casters of each kind are chosen: the brightest, or the largest
    /// contributions to the frame (estimated on the GPU from one frame's depth and light
    /// grid, for the camera the lights are made with).
    casters_by: CasterChoice;
    "casters-by", Shadows, "HOW", "how the shadow casters are chosen",
    applies(crate::settings::reads_casters), check(no_check), rebuild(Rebuilds::Casters);

    /// Turn every warning (missing textures, unknown extensions, dropped lights...) into an
    /// error with a non-zero exit.
    strict: bool;
    "strict", InputChecks, "on|off", "warnings are errors",
    applies(any_method), check(no_check), rebuild(Rebuilds::SceneOfFile);

    /// Read the buffer and image files a glTF file names wherever they point (absolute
    /// paths, `../`, links leading out); without it only files inside the model's folder
    /// are read, since a downloaded model may name any file on the machine.
    allow_any_path: bool;
    "allow-any-path", InputChecks, "on|off", "read files outside the model's folder",
    applies(any_method), check(no_check), rebuild(Rebuilds::SceneOfFile);
}

/// Checks every row's range; the first error names its flag.
pub fn check_rows(s: &Settings) -> Result<(), String> {
    SETTINGS.iter().try_for_each(|r| (r.check)(s))
}

/// The row named `name` ([`Setting::name`]).
pub fn row(name: &str) -> Option<&'static Setting> {
    SETTINGS.iter().find(|r| r.name == name)
}

impl Settings {
    /// Sets the run setting or pass setting named `name` (a row of [`SETTINGS`] or of
    /// `tiledlight_gpu::knobs`) from `text`: None when no row has that name. The lab's
    /// axes and the viewer's script keys are these names.
    pub fn set_row(&mut self, name: &str, text: &str) -> Option<Result<(), String>> {
        match row(name) {
            Some(r) => Some((r.set)(self, text)),
            None => self.knobs.set(name, text),
        }
    }

    /// The rows of [`SETTINGS`] whose values differ between `self` and `other`.
    pub fn changed_rows(&self, other: &Settings) -> Vec<&'static Setting> {
        SETTINGS.iter().filter(|r| r.differs(self, other)).collect()
    }
}

/// The table's flags on a command line (feature `clap`): `#[command(flatten)] settings:
/// SettingArgs` adds one flag a row, under its heading, named, helped and parsed by the
/// row. A value the row cannot parse is clap's usage error naming the flag; a range error
/// is left to [`Settings::validate`].
#[cfg(feature = "clap")]
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SettingArgs(pub Settings);

#[cfg(feature = "clap")]
fn flag(row: &Setting) -> tiledlight_gpu::knobs::Flag {
    tiledlight_gpu::knobs::Flag { id: row.field, long: row.name, kind: row.kind, value_name: row.value_name }
}

#[cfg(feature = "clap")]
impl clap::FromArgMatches for SettingArgs {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut args = Self::default();
        args.update_from_arg_matches(matches)?;
        Ok(args)
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        for row in SETTINGS {
            if let Some(text) = flag(row).given(matches, &(row.default)()) {
                (row.set)(&mut self.0, &text).map_err(|e| {
                    clap::Error::raw(clap::error::ErrorKind::ValueValidation, format!("--{}: {e}\n", row.name))
                })?;
            }
        }
        Ok(())
    }
}

#[cfg(feature = "clap")]
impl clap::Args for SettingArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        SETTINGS.iter().fold(cmd, |cmd, row| {
            let arg =
                flag(row).arg(row.full_help(), &(row.default)(), row.value_help).help_heading(row.heading.title());
            cmd.arg(arg.hide_short_help(!row.short))
        })
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every row's default parses back to itself and passes its check; names are unique,
    /// spelled as their fields, and no name is also a pass setting's.
    #[test]
    fn every_row_round_trips_and_names_are_unique() {
        let mut names = std::collections::HashSet::new();
        for r in SETTINGS {
            assert!(names.insert(r.name), "{} twice", r.name);
            assert_eq!(r.field.replace('_', "-"), r.name, "field and name spelled alike");
            assert!(tiledlight_gpu::knobs::Knobs::row(r.name).is_none(), "{} is also a pass setting", r.name);
            let mut s = Settings::default();
            (r.set)(&mut s, &(r.default)()).unwrap();
            assert_eq!(s, Settings::default(), "{}", r.name);
            (r.check)(&s).unwrap();
            if let Kind::Choice(names) | Kind::Values(names) = r.kind {
                assert!(names.contains(&(r.default)().as_str()), "{}", r.name);
            }
            assert!(!r.help().is_empty() && !r.help().contains("  "), "{}", r.name);
        }
        check_rows(&Settings::default()).unwrap();
    }

    /// A value is set by name into its field (rows over several fields too), a bad one
    /// named in the error, a range error names the flag; pass settings go to their table.
    #[test]
    fn rows_set_check_and_report_changes() {
        let mut s = Settings::default();
        for (k, v) in [
            ("width", "640"),
            ("lights", "77"),
            ("spot-lights", "auto"),
            ("method", "deferred"),
            ("msaa", "4"),
            ("tile-size", "32"),
            ("grid", "clustered"),
            ("assign", "scatter"),
            ("aabb", "on"),
            ("density", "HIGH"),
            ("casters-by", "contribution"),
            ("scene", "materials"),
            ("capacity", "64"),
            ("gbuffer-rts", "3"),
        ] {
            s.set_row(k, v).unwrap().unwrap();
        }
        assert_eq!((s.width, s.lights, s.spot_lights, s.method), (640, Some(77), None, Method::TiledDeferred));
        assert_eq!((s.msaa, s.tile_size, s.capacity, s.knobs.gbuffer_rts), (4, 32, Some(64), 3));
        assert!(s.clusters.is_some() && s.scatter && s.aabb);
        assert_eq!(
            (s.density, s.casters_by, &s.scene),
            (GridDensity::High, CasterChoice::Contribution, &SceneSource::Materials)
        );
        let changed: Vec<&str> = s.changed_rows(&Settings::default()).iter().map(|r| r.name).collect();
        assert_eq!(
            changed,
            [
                "scene",
                "lights",
                "density",
                "width",
                "method",
                "msaa",
                "tile-size",
                "capacity",
                "grid",
                "assign",
                "aabb",
                "casters-by"
            ]
        );
        s.set_row("grid", "2.5d").unwrap().unwrap();
        assert!(s.depth_mask && s.clusters.is_none() && !s.half_z);
        assert!(s.set_row("bogus", "1").is_none());
        let e = s.set_row("grid", "hex").unwrap().unwrap_err();
        assert!(e.contains("grid 'hex'") && e.contains("tiled, half-z, 2.5d, clustered"), "{e}");
        let e = s.set_row("lights", "many").unwrap().unwrap_err();
        assert!(e.contains("lights 'many'") && e.contains("whole number"), "{e}");
        let e = s.set_row("method", "forward").unwrap().unwrap_err();
        assert!(e.contains("forward-plus"), "{e}");
        s.width = 0;
        assert!(check_rows(&s).unwrap_err().starts_with("--width 0: must be between 1"));
        s.width = 1;
        s.lights = Some(MAX_LIGHTS + 1);
        assert!(check_rows(&s).unwrap_err().starts_with(&format!("--lights {}", MAX_LIGHTS + 1)));
        s.lights = None;
        s.threshold = f32::NAN;
        assert!(check_rows(&s).unwrap_err().starts_with("--threshold NaN"));
        s.threshold = 1.0;
        s.capacity = Some(0);
        assert!(check_rows(&s).unwrap_err().starts_with("--capacity 0"));
    }

    /// Every row is a flag under its heading; the method's choices carry their summaries;
    /// a switch is a bare flag; a value it cannot parse is refused by name.
    #[cfg(feature = "clap")]
    #[test]
    fn every_row_is_a_command_line_flag() {
        use clap::{Args, FromArgMatches};
        let cmd = SettingArgs::augment_args(clap::Command::new("t").no_binary_name(true));
        let parse = |args: &[&str]| {
            let m = cmd.clone().try_get_matches_from(args)?;
            SettingArgs::from_arg_matches(&m).map(|a| a.0)
        };
        assert_eq!(parse(&[]).unwrap(), Settings::default());
        let s = parse(&["--aabb", "--width", "320", "--grid", "half-z", "--lights", "5", "--scene", "x.glb"]).unwrap();
        assert_eq!((s.aabb, s.width, s.half_z, s.lights), (true, 320, true, Some(5)));
        assert_eq!(s.scene, SceneSource::File("x.glb".into()));
        let e = parse(&["--width", "wide"]).unwrap_err().to_string();
        assert!(e.contains("--width") && e.contains("whole number"), "{e}");
        assert!(parse(&["--grid", "hex"]).is_err());
        // A whole number out of its range parses; the check names it.
        let s = parse(&["--msaa", "3", "--tile-size", "7"]).unwrap();
        assert_eq!(check_rows(&s).unwrap_err(), "--msaa 3: must be 1, 2, 4 or 8");
        assert_eq!(check_rows(&Settings { msaa: 4, ..s }).unwrap_err(), "--tile-size 7: must be 8, 16 or 32");
        let help = cmd.clone().render_long_help().to_string();
        assert!(help.contains("Culling:") && help.contains("--spot-cone"), "{help}");
        assert!(help.contains(Method::Stochastic.summary()), "the methods' summaries");
        // A row some methods ignore names those that read it.
        assert!(
            help.contains("[methods: forward-plus, deferred, visibility, stochastic]"),
            "the culling rows name the tiled methods: {help}"
        );
        assert_eq!(row("width").unwrap().only_for(), None);
        let short = cmd.clone().render_help().to_string();
        assert!(short.contains("--width") && !short.contains("--flat-cull"), "{short}");
        for row in SETTINGS {
            assert!(help.contains(&format!("--{}", row.name)), "{}", row.name);
        }
    }
}
