//! Typed shader variants: one key type per entry shader (or family of entry files sharing
//! one body), whose values are exactly the variants a pass can build. A pass makes its key
//! from the features and options it was given and builds its module from it
//! ([`crate::util::keyed_module`]); the key derives the entry file and the defines, and
//! refuses a value outside its space ([`ShaderKey::is_valid`]). `cargo xtask
//! validate-shaders` validates every value of every key ([`key_spaces`]), not every
//! combination of flags, and prints each entry file's count.
//!
//! Pure data (std only; the scene's conversion, `MaterialKey::of`, lives beside
//! `MaterialFeatures` in [`crate::scene_gpu`], which imports this module): no device
//! needed, so xtask and tests enumerate the spaces without one.

use crate::define::Define;
use std::fmt;

/// A shader variant: an entry file and the defines it is compiled with.
pub trait ShaderKey: fmt::Debug {
    /// The entry file, relative to `shaders/`.
    fn entry(&self) -> &'static str;
    /// The defines of this variant, in a fixed order.
    fn defines(&self) -> Vec<&'static str>;
    /// Whether this value is one of the key's buildable (and so validated) variants.
    fn is_valid(&self) -> bool;
}

/// Every value of each key type, grouped by entry file: what `cargo xtask
/// validate-shaders` validates (entry file, the define lists of its variants). Entry files
/// not listed have no variants (one, without defines).
pub fn key_spaces() -> Vec<(&'static str, Vec<Vec<&'static str>>)> {
    let mut out: Vec<(&'static str, Vec<Vec<&'static str>>)> = Vec::new();
    let mut add = |keys: Vec<Box<dyn ShaderKey>>| {
        for k in keys {
            debug_assert!(k.is_valid(), "{k:?}");
            let entry = k.entry();
            match out.iter_mut().find(|(e, _)| *e == entry) {
                Some((_, v)) => v.push(k.defines()),
                None => out.push((entry, vec![k.defines()])),
            }
        }
    };
    fn boxed<K: ShaderKey + 'static>(v: Vec<K>) -> Vec<Box<dyn ShaderKey>> {
        v.into_iter().map(|k| Box::new(k) as Box<dyn ShaderKey>).collect()
    }
    add(boxed(ForwardKey::all()));
    add(boxed(BlendedKey::all()));
    add(boxed(CompositeKey::all()));
    add(boxed(DepthPrepassKey::all()));
    add(boxed(GBufferKey::all()));
    add(boxed(DeferredKey::all()));
    add(boxed(CullKey::all()));
    add(boxed(CullCoarseKey::all()));
    add(boxed(TileDepthKey::all()));
    add(boxed(AssignKey::all()));
    add(boxed(TonemapKey::all()));
    add(boxed(VisibilityRasterKey::all()));
    add(boxed(AtomicIdsKey::all()));
    add(boxed(vec![ComputeRasterKey::Clusters, ComputeRasterKey::Large]));
    add(boxed(VisibilityKey::all()));
    add(boxed(TracedKey::all()));
    add(boxed(StochasticKey::all()));
    add(boxed(vec![TraceRaysKey { masks: false }, TraceRaysKey { masks: true }]));
    add(boxed(BOOLS.map(|spots| ContributionKey { spots }).to_vec()));
    out
}

/// Both values of a bool, for enumerating.
const BOOLS: [bool; 2] = [false, true];

/// Pushes `define` when `on`.
fn flag(out: &mut Vec<&'static str>, on: bool, define: Define) {
    if on {
        out.push(define.name());
    }
}

/// The vertex attributes a textured scene adds (`shaders/common/scene.wgsl`): each needs
/// `TEXTURES`. Which slots a material has textures in is per-material data, not a variant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TextureMaps {
    /// `NORMAL_MAP`: the tangent attribute.
    pub normal_map: bool,
    /// `UV1`: some texture reads the second coordinate set.
    pub uv1: bool,
}

/// The material paths of a scene pass (`shaders/common/scene.wgsl`): textures (every
/// material's, in the texture arrays) with the attributes they need, or none. Emission and
/// the metallic-roughness and occlusion maps are per-material data.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct MaterialKey {
    /// `TEXTURES` and the attributes, or no textures at all.
    pub textures: Option<TextureMaps>,
}

impl MaterialKey {
    /// Every value (5).
    pub fn all() -> Vec<Self> {
        let mut maps = vec![None];
        for normal_map in BOOLS {
            for uv1 in BOOLS {
                maps.push(Some(TextureMaps { normal_map, uv1 }));
            }
        }
        maps.into_iter().map(|textures| Self { textures }).collect()
    }

    /// The defines, in `scene.wgsl`'s order: `TEXTURES NORMAL_MAP UV1`.
    pub fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        let m = self.textures.unwrap_or_default();
        flag(&mut d, self.textures.is_some(), Define::Textures);
        flag(&mut d, m.normal_map, Define::NormalMap);
        flag(&mut d, m.uv1, Define::Uv1);
        d
    }
}

/// Shadows and the virtual point lights made from them (`SHADOWS`, `VPLS`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Shadowing {
    /// No shadow casters.
    #[default]
    Off,
    /// `SHADOWS`.
    Shadows,
    /// `SHADOWS VPLS`: VPLs come from the casters' reflective shadow maps.
    ShadowsAndVpls,
}

impl Shadowing {
    /// Every value.
    pub const ALL: [Self; 3] = [Self::Off, Self::Shadows, Self::ShadowsAndVpls];

    /// The value for shadows and VPLs (None: VPLs without shadows, which no pass builds).
    pub fn of(shadows: bool, vpls: bool) -> Option<Self> {
        match (shadows, vpls) {
            (false, false) => Some(Self::Off),
            (true, false) => Some(Self::Shadows),
            (true, true) => Some(Self::ShadowsAndVpls),
            (false, true) => None,
        }
    }

    fn defines(self, d: &mut Vec<&'static str>) {
        flag(d, self != Self::Off, Define::Shadows);
        flag(d, self == Self::ShadowsAndVpls, Define::Vpls);
    }
}

/// The light loop of a forward shading pass, which picks its entry file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LightLoopKey {
    /// Its tile's list in the light grid (`forward.wgsl`, `blended.wgsl`); with `half_z`
    /// its half's (Forward+ only).
    TileLists {
        /// `HALF_Z`.
        half_z: bool,
    },
    /// Its cluster's list (`CLUSTERED`: `forward_clustered.wgsl`, `blended.wgsl`).
    Clusters,
    /// Every light (`BRUTE_FORCE`: `brute_force.wgsl`, `blended_brute_force.wgsl`); without
    /// `cutoff` plain inverse-square (`NO_CUTOFF`).
    Every {
        /// The windowed falloff with its radius cutoff.
        cutoff: bool,
    },
}

impl LightLoopKey {
    /// Every value (with half-z ones only when `half_z` may be set).
    fn all(half_z: bool) -> Vec<Self> {
        let mut v = vec![Self::TileLists { half_z: false }];
        if half_z {
            v.push(Self::TileLists { half_z: true });
        }
        v.extend([Self::Clusters, Self::Every { cutoff: true }, Self::Every { cutoff: false }]);
        v
    }

    fn defines(self, d: &mut Vec<&'static str>) {
        match self {
            Self::TileLists { half_z } => flag(d, half_z, Define::HalfZ),
            Self::Clusters => d.push(Define::Clustered.name()),
            Self::Every { cutoff } => {
                d.push(Define::BruteForce.name());
                flag(d, !cutoff, Define::NoCutoff);
            }
        }
    }
}

/// The forward shading pass (`forward.wgsl`, `forward_clustered.wgsl`, `brute_force.wgsl`,
/// one per light loop; body `common/forward_shade.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ForwardKey {
    /// `SPOT_LIGHTS`.
    pub spots: bool,
    /// `SHADOWS`, `VPLS`.
    pub shadowing: Shadowing,
    /// The material paths.
    pub materials: MaterialKey,
    /// The light loop (the entry file).
    pub lights: LightLoopKey,
    /// `ALPHA_MASK`: the masked draw kind's pipeline.
    pub alpha_mask: bool,
}

impl ForwardKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for lights in LightLoopKey::all(true) {
            for spots in BOOLS {
                for shadowing in Shadowing::ALL {
                    for materials in MaterialKey::all() {
                        for alpha_mask in BOOLS {
                            v.push(Self { spots, shadowing, materials, lights, alpha_mask });
                        }
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for ForwardKey {
    fn entry(&self) -> &'static str {
        match self.lights {
            LightLoopKey::TileLists { .. } => "forward.wgsl",
            LightLoopKey::Clusters => "forward_clustered.wgsl",
            LightLoopKey::Every { .. } => "brute_force.wgsl",
        }
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        flag(&mut d, self.spots, Define::SpotLights);
        self.shadowing.defines(&mut d);
        d.extend(self.materials.defines());
        self.lights.defines(&mut d);
        flag(&mut d, self.alpha_mask, Define::AlphaMask);
        d
    }

    fn is_valid(&self) -> bool {
        true
    }
}

/// The blended shading pass (`blended.wgsl` over lists, `blended_brute_force.wgsl` over
/// every light; body `common/blended_shade.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BlendedKey {
    /// `SPOT_LIGHTS`.
    pub spots: bool,
    /// `SHADOWS` (blended geometry does not shade VPLs).
    pub shadows: bool,
    /// The material paths.
    pub materials: MaterialKey,
    /// The light loop: no half-z lists (one list per tile).
    pub lights: LightLoopKey,
    /// `WBOIT`: weighted blended order-independent transparency.
    pub wboit: bool,
}

impl BlendedKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for lights in LightLoopKey::all(false) {
            for spots in BOOLS {
                for shadows in BOOLS {
                    for materials in MaterialKey::all() {
                        for wboit in BOOLS {
                            v.push(Self { spots, shadows, materials, lights, wboit });
                        }
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for BlendedKey {
    fn entry(&self) -> &'static str {
        match self.lights {
            LightLoopKey::Every { .. } => "blended_brute_force.wgsl",
            _ => "blended.wgsl",
        }
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        flag(&mut d, self.spots, Define::SpotLights);
        flag(&mut d, self.shadows, Define::Shadows);
        d.extend(self.materials.defines());
        flag(&mut d, self.wboit, Define::Wboit);
        self.lights.defines(&mut d);
        d
    }

    fn is_valid(&self) -> bool {
        !matches!(self.lights, LightLoopKey::TileLists { half_z: true })
    }
}

/// The blended layer's composite (`blended_composite.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CompositeKey {
    /// `WBOIT`: the layer is accumulation and revealage.
    pub wboit: bool,
}

impl CompositeKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        BOOLS.map(|wboit| Self { wboit }).to_vec()
    }
}

impl ShaderKey for CompositeKey {
    fn entry(&self) -> &'static str {
        "blended_composite.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        if self.wboit {
            vec![Define::Wboit.name()]
        } else {
            Vec::new()
        }
    }
    fn is_valid(&self) -> bool {
        true
    }
}

/// The depth pre-pass (`depth_prepass.wgsl`): only the masked pipeline samples (the base
/// colour's alpha), so only it has textures and their coordinate set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DepthPrepassKey {
    /// Opaque: positions only.
    #[default]
    Opaque,
    /// `ALPHA_MASK` on the materials' factors (no textures in the scene).
    Masked,
    /// `ALPHA_MASK TEXTURES`, with `UV1` when some texture reads the second set.
    MaskedTextured {
        /// `UV1`.
        uv1: bool,
    },
}

impl DepthPrepassKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        vec![Self::Opaque, Self::Masked, Self::MaskedTextured { uv1: false }, Self::MaskedTextured { uv1: true }]
    }
}

impl ShaderKey for DepthPrepassKey {
    fn entry(&self) -> &'static str {
        "depth_prepass.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        match self {
            Self::Opaque => Vec::new(),
            Self::Masked => vec![Define::AlphaMask.name()],
            Self::MaskedTextured { uv1: false } => vec![Define::AlphaMask.name(), Define::Textures.name()],
            Self::MaskedTextured { uv1: true } => {
                vec![Define::AlphaMask.name(), Define::Textures.name(), Define::Uv1.name()]
            }
        }
    }
    fn is_valid(&self) -> bool {
        true
    }
}

/// The G-buffer pass (`gbuffer.wgsl`; also the VPLs' reflective shadow maps).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GBufferKey {
    /// `ALPHA_MASK`.
    pub alpha_mask: bool,
    /// The material paths.
    pub materials: MaterialKey,
    /// `EMISSION`: the emission target is written.
    pub emission: bool,
    /// `EXTRA_TEST_VALUES`: the extra targets get test values (tests only).
    pub extra_test_values: bool,
}

impl GBufferKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for alpha_mask in BOOLS {
            for materials in MaterialKey::all() {
                for emission in BOOLS {
                    for extra_test_values in BOOLS {
                        v.push(Self { alpha_mask, materials, emission, extra_test_values });
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for GBufferKey {
    fn entry(&self) -> &'static str {
        "gbuffer.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        flag(&mut d, self.alpha_mask, Define::AlphaMask);
        d.extend(self.materials.defines());
        flag(&mut d, self.emission, Define::Emission);
        flag(&mut d, self.extra_test_values, Define::ExtraTestValues);
        d
    }
    fn is_valid(&self) -> bool {
        true
    }
}

/// The per-tile light tests of the tile culling code (`shaders/common/tile_cull.wgsl`,
/// `common/tile_tests.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct CullTests {
    /// The view-space box test: the pipeline constant `AABB_TEST`, not a define (so not part
    /// of the validated space, which leaves it off).
    pub aabb: bool,
    /// `HALF_Z`: two lists per tile.
    pub half_z: bool,
    /// `SPOT_CONE`: spot cones against tiles.
    pub spot_cone: bool,
    /// `COARSE`: candidates from the 64x64-pixel cells.
    pub coarse: bool,
    /// `DEPTH_MASK`: 2.5D culling (not with half-z).
    pub depth_mask: bool,
}

impl CullTests {
    /// Every value (`depth_mask` only when it may be set; never with half-z).
    fn all(depth_mask: bool) -> Vec<Self> {
        let mut v = Vec::new();
        for aabb in [false] {
            for half_z in BOOLS {
                for spot_cone in BOOLS {
                    for coarse in BOOLS {
                        for dm in BOOLS {
                            let t = Self { aabb, half_z, spot_cone, coarse, depth_mask: dm };
                            if (!dm || depth_mask) && t.is_valid() {
                                v.push(t);
                            }
                        }
                    }
                }
            }
        }
        v
    }

    fn is_valid(&self) -> bool {
        !(self.depth_mask && self.half_z)
    }

    fn defines(self, d: &mut Vec<&'static str>) {
        flag(d, self.half_z, Define::HalfZ);
        flag(d, self.spot_cone, Define::SpotCone);
        flag(d, self.coarse, Define::Coarse);
        flag(d, self.depth_mask, Define::DepthMask);
    }
}

/// The tile culling pass (`cull.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct CullKey {
    /// The light tests.
    pub tests: CullTests,
    /// `MSAA`: the depth buffer is multisampled.
    pub msaa: bool,
    /// `BLENDED`: the blended geometry's culling (sphere and planes only, one list).
    pub blended: bool,
    /// `DROP_LIGHT`: the test hook.
    pub drop_light: bool,
}

impl CullKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for tests in CullTests::all(true) {
            for msaa in BOOLS {
                for drop_light in BOOLS {
                    v.push(Self { tests, msaa, blended: false, drop_light });
                }
            }
        }
        v.extend(BOOLS.map(|msaa| Self { tests: CullTests::default(), msaa, blended: true, drop_light: false }));
        v
    }
}

impl ShaderKey for CullKey {
    fn entry(&self) -> &'static str {
        "cull.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        self.tests.defines(&mut d);
        flag(&mut d, self.msaa, Define::Msaa);
        flag(&mut d, self.drop_light, Define::DropLight);
        flag(&mut d, self.blended, Define::Blended);
        d
    }
    fn is_valid(&self) -> bool {
        self.tests.is_valid() && (!self.blended || (self.tests == CullTests::default() && !self.drop_light))
    }
}

/// The 64x64-pixel cell pass of two-level culling (`cull_coarse.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct CullCoarseKey {
    /// `MSAA`.
    pub msaa: bool,
}

impl CullCoarseKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        BOOLS.map(|msaa| Self { msaa }).to_vec()
    }
}

impl ShaderKey for CullCoarseKey {
    fn entry(&self) -> &'static str {
        "cull_coarse.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        if self.msaa {
            vec![Define::Msaa.name()]
        } else {
            Vec::new()
        }
    }
    fn is_valid(&self) -> bool {
        true
    }
}

/// What the tile depth step of light-centric assignment writes besides the ranges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TileDepthOutput {
    /// Ranges only.
    #[default]
    Ranges,
    /// `DEPTH_MASK`: the 2.5D masks.
    DepthMask,
    /// `CLUSTERED`: the cluster occupancy masks.
    Clusters,
}

/// The tile depth step of light-centric assignment (`tile_depth.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TileDepthKey {
    /// `MSAA`.
    pub msaa: bool,
    /// The masks written.
    pub output: TileDepthOutput,
}

impl TileDepthKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let outputs = [TileDepthOutput::Ranges, TileDepthOutput::DepthMask, TileDepthOutput::Clusters];
        BOOLS.into_iter().flat_map(|msaa| outputs.map(|output| Self { msaa, output })).collect()
    }
}

impl ShaderKey for TileDepthKey {
    fn entry(&self) -> &'static str {
        "tile_depth.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        flag(&mut d, self.msaa, Define::Msaa);
        flag(&mut d, self.output == TileDepthOutput::DepthMask, Define::DepthMask);
        flag(&mut d, self.output == TileDepthOutput::Clusters, Define::Clustered);
        d
    }
    fn is_valid(&self) -> bool {
        true
    }
}

/// Light-centric assignment (`assign.wgsl`): tile lists with their tests, or clusters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AssignKey {
    /// Tile lists: `HALF_Z`, `SPOT_CONE`, `DEPTH_MASK` as in [`CullTests`] (no two-level
    /// culling; the box test is a pipeline constant).
    Tiles(CullTests),
    /// `CLUSTERED`, with `GEOMETRY_ONLY` when only clusters holding geometry get lists.
    Clusters {
        /// `GEOMETRY_ONLY`.
        geometry_only: bool,
    },
}

impl AssignKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v: Vec<Self> = CullTests::all(true).into_iter().filter(|t| !t.coarse).map(Self::Tiles).collect();
        v.extend(BOOLS.map(|geometry_only| Self::Clusters { geometry_only }));
        v
    }
}

impl ShaderKey for AssignKey {
    fn entry(&self) -> &'static str {
        "assign.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        match *self {
            Self::Tiles(t) => {
                flag(&mut d, t.half_z, Define::HalfZ);
                flag(&mut d, t.spot_cone, Define::SpotCone);
                flag(&mut d, t.depth_mask, Define::DepthMask);
            }
            Self::Clusters { geometry_only } => {
                d.push(Define::Clustered.name());
                flag(&mut d, geometry_only, Define::GeometryOnly);
            }
        }
        d
    }
    fn is_valid(&self) -> bool {
        match self {
            Self::Tiles(t) => t.is_valid() && !t.coarse,
            Self::Clusters { .. } => true,
        }
    }
}

/// How Tiled Deferred's shading pass gets its lists, which picks its kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DeferredLists {
    /// Culled per tile by the pass itself (`deferred.wgsl`, with MSAA
    /// `deferred_msaa.wgsl`): the light tests (no 2.5D: those lists are assigned) and the
    /// drop-light test hook (`DROP_LIGHT`).
    Culled {
        /// The light tests.
        tests: CullTests,
        /// `DROP_LIGHT`: validated (and so built) only with one sample and without shadows,
        /// VPLs and emission, to keep the kernel's variants few.
        drop_light: bool,
    },
    /// Assigned light-centrically before the pass (`deferred_assigned.wgsl`): tile lists
    /// (with half-z) or clusters.
    Assigned {
        /// `HALF_Z`.
        half_z: bool,
        /// `CLUSTERED`.
        clustered: bool,
    },
}

/// Tiled Deferred's shading pass (`deferred.wgsl`, `deferred_msaa.wgsl`,
/// `deferred_assigned.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DeferredKey {
    /// Where the lists come from (the kernel).
    pub lists: DeferredLists,
    /// `SPOT_LIGHTS`.
    pub spots: bool,
    /// `SHADOWS`, `VPLS`.
    pub shadowing: Shadowing,
    /// `MSAA`: the G-buffer is multisampled.
    pub msaa: bool,
    /// The stress knob's extra G-buffer targets, 0 to 3 (`EXTRA_RTS` with any; the count
    /// is the pipeline constant `EXTRA_TARGETS`, so [`DeferredKey::all`] holds 0 and 1).
    pub extra_targets: u32,
    /// `EMISSION`: the G-buffer's emission target.
    pub emission: bool,
}

impl DeferredKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        // The spot-cone test is a pipeline constant here (the cone code is compiled with any
        // spot light): the space holds the tests without it.
        let mut lists: Vec<DeferredLists> = CullTests::all(false)
            .into_iter()
            .filter(|t| !t.spot_cone)
            .flat_map(|tests| BOOLS.map(|drop_light| DeferredLists::Culled { tests, drop_light }))
            .collect();
        lists.extend(
            [(false, false), (true, false), (false, true)]
                .map(|(half_z, clustered)| DeferredLists::Assigned { half_z, clustered }),
        );
        let mut v = Vec::new();
        for lists in lists {
            for spots in BOOLS {
                for shadowing in Shadowing::ALL {
                    for msaa in BOOLS {
                        // 0 or some: how many is a pipeline constant (`EXTRA_TARGETS`).
                        for extra_targets in 0..=1 {
                            for emission in BOOLS {
                                let k = Self { lists, spots, shadowing, msaa, extra_targets, emission };
                                if k.is_valid() {
                                    v.push(k);
                                }
                            }
                        }
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for DeferredKey {
    fn entry(&self) -> &'static str {
        match (self.lists, self.msaa) {
            (DeferredLists::Assigned { .. }, _) => "deferred_assigned.wgsl",
            (DeferredLists::Culled { .. }, false) => "deferred.wgsl",
            (DeferredLists::Culled { .. }, true) => "deferred_msaa.wgsl",
        }
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        match self.lists {
            DeferredLists::Culled { tests, drop_light } => {
                // The cone code with any spot light; `SPOT_CONE_TEST` switches it.
                CullTests { spot_cone: self.spots, ..tests }.defines(&mut d);
                flag(&mut d, drop_light, Define::DropLight);
            }
            DeferredLists::Assigned { half_z, clustered } => {
                flag(&mut d, half_z, Define::HalfZ);
                flag(&mut d, clustered, Define::Clustered);
            }
        }
        flag(&mut d, self.msaa, Define::Msaa);
        flag(&mut d, self.extra_targets >= 1, Define::ExtraRts);
        flag(&mut d, self.emission, Define::Emission);
        flag(&mut d, self.spots, Define::SpotLights);
        self.shadowing.defines(&mut d);
        d
    }

    fn is_valid(&self) -> bool {
        let lists = match self.lists {
            DeferredLists::Culled { tests, drop_light } => {
                tests.is_valid()
                    && !tests.depth_mask
                    && (self.spots || !tests.spot_cone)
                    && (!drop_light || (!self.msaa && self.shadowing == Shadowing::Off && !self.emission))
            }
            DeferredLists::Assigned { half_z, clustered } => !(half_z && clustered),
        };
        lists && self.extra_targets <= 3
    }
}

/// The visibility buffer's raster pass: the depth pre-pass (`depth_prepass.wgsl`) of the
/// same shape with `IDS`, every fragment writing its triangle's ID.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct VisibilityRasterKey(pub DepthPrepassKey);

impl VisibilityRasterKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        DepthPrepassKey::all().into_iter().map(Self).collect()
    }
}

impl ShaderKey for VisibilityRasterKey {
    fn entry(&self) -> &'static str {
        self.0.entry()
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = self.0.defines();
        d.push(Define::Ids.name());
        d
    }
    fn is_valid(&self) -> bool {
        self.0.is_valid()
    }
}

/// The alpha-masked draws of the visibility buffer's compute raster
/// (`depth_prepass.wgsl` with `IDS ATOMIC`): a masked [`DepthPrepassKey`] whose fragments
/// resolve their ID into the raster's 64-bit texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AtomicIdsKey(pub DepthPrepassKey);

impl AtomicIdsKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        DepthPrepassKey::all().into_iter().map(Self).filter(|k| k.is_valid()).collect()
    }
}

impl ShaderKey for AtomicIdsKey {
    fn entry(&self) -> &'static str {
        self.0.entry()
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = self.0.defines();
        d.extend([Define::Ids.name(), Define::Atomic.name()]);
        d
    }
    fn is_valid(&self) -> bool {
        self.0 != DepthPrepassKey::Opaque
    }
}

/// The visibility buffer's compute raster: its compute kernels
/// (`visibility_raster.wgsl`) or its hardware half for large triangles
/// (`visibility_raster_large.wgsl`); both read the scene's buffers at the visibility
/// group's numbers (`VISIBILITY`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ComputeRasterKey {
    /// `visibility_raster.wgsl`.
    Clusters,
    /// `visibility_raster_large.wgsl`.
    Large,
}

impl ShaderKey for ComputeRasterKey {
    fn entry(&self) -> &'static str {
        match self {
            Self::Clusters => "visibility_raster.wgsl",
            Self::Large => "visibility_raster_large.wgsl",
        }
    }
    fn defines(&self) -> Vec<&'static str> {
        vec![Define::Visibility.name()]
    }
    fn is_valid(&self) -> bool {
        true
    }
}

/// How the visibility buffer's pass looks a pixel's list up in the light grid (written
/// before it by the culling pass or the assignment).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GridLookup {
    /// Its tile's list.
    #[default]
    Tile,
    /// `HALF_Z`: its tile half's.
    HalfZ,
    /// `CLUSTERED`: its cluster's.
    Clustered,
}

impl GridLookup {
    /// Every value.
    pub const ALL: [Self; 3] = [Self::Tile, Self::HalfZ, Self::Clustered];

    fn defines(self, d: &mut Vec<&'static str>) {
        flag(d, self == Self::HalfZ, Define::HalfZ);
        flag(d, self == Self::Clustered, Define::Clustered);
    }
}

/// The visibility buffer's material-and-lights pass (`visibility.wgsl`, with MSAA
/// `visibility_msaa.wgsl`; body `common/assigned_shade.wgsl` with `VISIBILITY`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct VisibilityKey {
    /// The list lookup.
    pub lookup: GridLookup,
    /// `SPOT_LIGHTS`.
    pub spots: bool,
    /// `SHADOWS`, `VPLS`.
    pub shadowing: Shadowing,
    /// `MSAA`: IDs and depth are multisampled.
    pub msaa: bool,
    /// The material paths.
    pub materials: MaterialKey,
}

impl VisibilityKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for lookup in GridLookup::ALL {
            for spots in BOOLS {
                for shadowing in Shadowing::ALL {
                    for msaa in BOOLS {
                        for materials in MaterialKey::all() {
                            v.push(Self { lookup, spots, shadowing, msaa, materials });
                        }
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for VisibilityKey {
    fn entry(&self) -> &'static str {
        if self.msaa {
            "visibility_msaa.wgsl"
        } else {
            "visibility.wgsl"
        }
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = vec![Define::Visibility.name()];
        flag(&mut d, self.msaa, Define::Msaa);
        flag(&mut d, self.spots, Define::SpotLights);
        self.lookup.defines(&mut d);
        self.shadowing.defines(&mut d);
        d.extend(self.materials.defines());
        d
    }

    fn is_valid(&self) -> bool {
        true
    }
}

/// The traced reference's material-and-lights pass (`traced.wgsl`, with MSAA
/// `traced_msaa.wgsl`): the visibility buffer's surface, every light, each with a shadow
/// ray (`shaders/common/trace.wgsl`). No shadow maps (`SHADOWS` is never set: the rays
/// replace them) and no light grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TracedKey {
    /// Without `NO_CUTOFF`: the windowed falloff (`--method traced-reference-cutoff`).
    pub cutoff: bool,
    /// `SPOT_LIGHTS`.
    pub spots: bool,
    /// `VPLS`: every VPL is added, unshadowed, as brute force adds them.
    pub vpls: bool,
    /// `MSAA`.
    pub msaa: bool,
    /// `TRACE_MASKS`: some casting material is alpha-masked.
    pub masks: bool,
    /// The material paths.
    pub materials: MaterialKey,
}

impl TracedKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for cutoff in BOOLS {
            for spots in BOOLS {
                for vpls in BOOLS {
                    for msaa in BOOLS {
                        for masks in BOOLS {
                            for materials in MaterialKey::all() {
                                v.push(Self { cutoff, spots, vpls, msaa, masks, materials });
                            }
                        }
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for TracedKey {
    fn entry(&self) -> &'static str {
        if self.msaa {
            "traced_msaa.wgsl"
        } else {
            "traced.wgsl"
        }
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = vec![Define::Visibility.name(), Define::Traced.name()];
        flag(&mut d, !self.cutoff, Define::NoCutoff);
        flag(&mut d, self.msaa, Define::Msaa);
        flag(&mut d, self.spots, Define::SpotLights);
        flag(&mut d, self.vpls, Define::Vpls);
        flag(&mut d, self.masks, Define::TraceMasks);
        d.extend(self.materials.defines());
        d
    }

    fn is_valid(&self) -> bool {
        true
    }
}

/// The stochastic method's material-and-lights pass (`stochastic.wgsl`): the traced
/// kernel (the visibility buffer's surface, `TRACED`) with the sampler's light loop
/// (`STOCHASTIC`, `shaders/common/stochastic_shade.wgsl`): a few candidates a pixel, one
/// kept, one shadow ray; the near candidates from the light grid's lists (`HALF_Z`,
/// `CLUSTERED` lookups). No cutoff (it converges to the truth), one sample a pixel (MSAA is
/// refused), no VPLs (refused: they are not sampled yet), no shadow maps and no light grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct StochasticKey {
    /// The near candidates' list lookup.
    pub lookup: GridLookup,
    /// `SPOT_LIGHTS`.
    pub spots: bool,
    /// `TRACE_MASKS`: some casting material is alpha-masked.
    pub masks: bool,
    /// The material paths.
    pub materials: MaterialKey,
    /// `DENOISE`: the pass leaves the denoiser's guide (`--denoise N` > 0).
    pub denoise: bool,
    /// `REUSE`: spatial reuse (`--reuse N` > 0): the pass runs twice, through its
    /// reservoirs' records.
    pub reuse: bool,
}

impl StochasticKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for lookup in GridLookup::ALL {
            for spots in BOOLS {
                for masks in BOOLS {
                    for materials in MaterialKey::all() {
                        for denoise in BOOLS {
                            for reuse in BOOLS {
                                v.push(Self { lookup, spots, masks, materials, denoise, reuse });
                            }
                        }
                    }
                }
            }
        }
        v
    }
}

impl ShaderKey for StochasticKey {
    fn entry(&self) -> &'static str {
        "stochastic.wgsl"
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d =
            vec![Define::Visibility.name(), Define::Traced.name(), Define::Stochastic.name(), Define::NoCutoff.name()];
        self.lookup.defines(&mut d);
        flag(&mut d, self.spots, Define::SpotLights);
        flag(&mut d, self.masks, Define::TraceMasks);
        d.extend(self.materials.defines());
        flag(&mut d, self.denoise, Define::Denoise);
        flag(&mut d, self.reuse, Define::Reuse);
        d
    }

    fn is_valid(&self) -> bool {
        true
    }
}

/// The shadow-ray kernel of the traced reference's twin test (`trace_rays.wgsl`): one
/// segment a thread, its answer out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TraceRaysKey {
    /// `TRACE_MASKS`.
    pub masks: bool,
}

impl ShaderKey for TraceRaysKey {
    fn entry(&self) -> &'static str {
        "trace_rays.wgsl"
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        flag(&mut d, self.masks, Define::TraceMasks);
        d
    }

    fn is_valid(&self) -> bool {
        true
    }
}

/// The contribution estimate (`light_contribution.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ContributionKey {
    /// `SPOTS`: the lights include spots (their cone falloff).
    pub spots: bool,
}

impl ShaderKey for ContributionKey {
    fn entry(&self) -> &'static str {
        "light_contribution.wgsl"
    }

    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        flag(&mut d, self.spots, Define::Spots);
        d
    }

    fn is_valid(&self) -> bool {
        true
    }
}

/// The tonemap pass (`tonemap.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TonemapKey {
    /// `AUTO_EXPOSURE`: the exposure is read from the adaptation buffer.
    pub auto_exposure: bool,
}

impl TonemapKey {
    /// Every value.
    pub fn all() -> Vec<Self> {
        BOOLS.map(|auto_exposure| Self { auto_exposure }).to_vec()
    }
}

impl ShaderKey for TonemapKey {
    fn entry(&self) -> &'static str {
        "tonemap.wgsl"
    }
    fn defines(&self) -> Vec<&'static str> {
        if self.auto_exposure {
            vec![Define::AutoExposure.name()]
        } else {
            Vec::new()
        }
    }
    fn is_valid(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader;

    #[test]
    fn every_key_value_is_valid_distinct_and_declared() {
        for (entry, values) in key_spaces() {
            let declared = shader::variants(entry);
            assert!(shader::embedded(entry).is_some(), "{entry}");
            for d in &values {
                for define in d {
                    assert!(declared.iter().any(|v| v == define), "{entry}: {define} not declared");
                }
            }
            let mut sorted: Vec<Vec<&str>> = values
                .iter()
                .map(|d| {
                    let mut d = d.clone();
                    d.sort();
                    d
                })
                .collect();
            sorted.sort();
            sorted.dedup();
            assert_eq!(sorted.len(), values.len(), "{entry}: two key values with the same defines");
            // Issue 45: no entry shader above 256 validated variants.
            assert!(values.len() <= 256, "{entry}: {} variants", values.len());
        }
    }

    #[test]
    fn key_space_counts() {
        let count = |e: &str| key_spaces().into_iter().find(|(x, _)| *x == e).map_or(0, |(_, v)| v.len());
        assert_eq!(MaterialKey::all().len(), 5);
        assert_eq!(count("forward.wgsl"), 120);
        assert_eq!(count("forward_clustered.wgsl"), 60);
        assert_eq!(count("brute_force.wgsl"), 120);
        assert_eq!(count("blended.wgsl"), 80);
        assert_eq!(count("deferred.wgsl"), 112);
        assert_eq!(count("deferred_msaa.wgsl"), 96);
        assert_eq!(count("deferred_assigned.wgsl"), 144);
        // 3 lookups x spots x 3 shadowings x 5 material paths, per sample mode.
        assert_eq!(count("visibility.wgsl"), 90);
        // cutoff x spots x VPLs x masks x 5 material paths, per sample mode.
        assert_eq!(count("traced.wgsl"), 16 * 5);
        assert_eq!(count("traced_msaa.wgsl"), 16 * 5);
        // 3 lookups x spots x masks x 5 material paths x the denoiser's guide x the spatial
        // reuse, one sample a pixel.
        assert_eq!(count("stochastic.wgsl"), 3 * 4 * 5 * 2 * 2);
        assert_eq!(count("trace_rays.wgsl"), 2);
        assert_eq!(count("visibility_msaa.wgsl"), 90);
        // 4 pre-pass and 4 ID-raster variants, and 3 masked ones resolving IDs with atomics
        // (the compute raster's masked draws).
        assert_eq!(count("depth_prepass.wgsl"), 11);
    }

    #[test]
    fn invalid_values_are_refused() {
        let k = DeferredKey {
            lists: DeferredLists::Culled { tests: CullTests::default(), drop_light: true },
            spots: false,
            shadowing: Shadowing::Shadows,
            msaa: false,
            extra_targets: 0,
            emission: false,
        };
        assert!(!k.is_valid());
        assert!(!CullKey {
            tests: CullTests { half_z: true, depth_mask: true, ..Default::default() },
            ..Default::default()
        }
        .is_valid());
    }
}
