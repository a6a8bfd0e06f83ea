//! Bindings declared once, as data: each pass states in Rust which `@group(g) @binding(b)`
//! resources its WGSL entry file declares, of which kind, visible to which stages, and
//! under which shader defines each exists. The pass builds its bind group layouts from
//! that declaration ([`layout_entries`], [`create_layout`]) for the defines it compiles
//! its shader with, and `cargo xtask validate-shaders` compares the same declaration,
//! filtered by the same defines, with naga's reflection of every variant of the entry
//! file. Only the layouts come from here: the bind groups with the actual resources stay
//! with the passes.
//!
//! A group's declaration is a `&[Binding]` (shared by every pass that binds that group:
//! [`crate::view::BINDINGS`] at group 0, the scene's groups 1 and 2, the light grid's
//! compute group); a pass's declaration ([`PassBindings`]) names its entry file and the
//! group declarations at each index. Pure data and wgpu types: no device needed to read
//! or check them.

use std::fmt;

use crate::define::Define;

/// When a binding (or a whole group) exists, in terms of the shader defines of the
/// variant: the same condition the WGSL's `#ifdef`s put around its declaration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cond {
    /// In every variant.
    Always,
    /// In no variant (a shared group's binding that this pass never has).
    Never,
    /// When the define is set.
    Defined(Define),
    /// When the define is not set.
    NotDefined(Define),
    /// When every condition holds.
    All(&'static [Cond]),
    /// When at least one condition holds.
    Any(&'static [Cond]),
}

impl Cond {
    /// [`Cond::Always`] or [`Cond::Never`].
    pub const fn from_bool(b: bool) -> Self {
        if b {
            Cond::Always
        } else {
            Cond::Never
        }
    }

    /// Whether the condition holds for a variant compiled with `defines`.
    pub fn holds(&self, defines: &[&str]) -> bool {
        match self {
            Cond::Always => true,
            Cond::Never => false,
            Cond::Defined(d) => defines.contains(&d.name()),
            Cond::NotDefined(d) => !defines.contains(&d.name()),
            Cond::All(c) => c.iter().all(|c| c.holds(defines)),
            Cond::Any(c) => c.iter().any(|c| c.holds(defines)),
        }
    }
}

impl fmt::Display for Cond {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |f: &mut fmt::Formatter<'_>, c: &[Cond], op: &str| {
            f.write_str("(")?;
            for (i, c) in c.iter().enumerate() {
                if i > 0 {
                    f.write_str(op)?;
                }
                write!(f, "{c}")?;
            }
            f.write_str(")")
        };
        match self {
            Cond::Always => f.write_str("always"),
            Cond::Never => f.write_str("never"),
            Cond::Defined(d) => f.write_str(d.name()),
            Cond::NotDefined(d) => write!(f, "!{}", d.name()),
            Cond::All(c) => list(f, c, " && "),
            Cond::Any(c) => list(f, c, " || "),
        }
    }
}

/// What is bound: the part of `wgpu::BindingType` a declaration fixes, with the
/// multisampling of a texture allowed to depend on the defines (`MSAA`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    /// `var<uniform>`.
    Uniform {
        /// Bound with a dynamic offset.
        dynamic_offset: bool,
        /// Minimum binding size in bytes (0: none).
        min_size: u64,
    },
    /// `var<storage, read>` or `var<storage, read_write>`.
    Storage {
        /// `read` (true) or `read_write`.
        read_only: bool,
    },
    /// A sampled texture (`texture_2d<f32>`, `texture_depth_2d`, ...).
    Texture {
        /// Float (filterable or not), depth, sint or uint.
        sample_type: wgpu::TextureSampleType,
        /// View dimension.
        dimension: wgpu::TextureViewDimension,
        /// When the texture is multisampled.
        multisampled: Cond,
    },
    /// A storage texture (`texture_storage_2d<format, access>`).
    StorageTexture {
        /// Texel format.
        format: wgpu::TextureFormat,
        /// Access mode.
        access: wgpu::StorageTextureAccess,
        /// View dimension.
        dimension: wgpu::TextureViewDimension,
    },
    /// A sampler.
    Sampler(wgpu::SamplerBindingType),
}

/// One `@binding` of a group: number, kind, visibility, and when it exists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    /// The `@binding` number.
    pub binding: u32,
    /// What is bound.
    pub kind: BindingKind,
    /// Stages that may use it.
    pub visibility: wgpu::ShaderStages,
    /// The defines under which the WGSL declares it (and the pass binds it).
    pub when: Cond,
}

impl Binding {
    const fn new(binding: u32, visibility: wgpu::ShaderStages, kind: BindingKind) -> Self {
        Self { binding, kind, visibility, when: Cond::Always }
    }

    /// A uniform buffer.
    pub const fn uniform(binding: u32, visibility: wgpu::ShaderStages) -> Self {
        Self::new(binding, visibility, BindingKind::Uniform { dynamic_offset: false, min_size: 0 })
    }

    /// A read-only storage buffer (`var<storage, read>`).
    pub const fn storage(binding: u32, visibility: wgpu::ShaderStages) -> Self {
        Self::new(binding, visibility, BindingKind::Storage { read_only: true })
    }

    /// A read-write storage buffer (`var<storage, read_write>`).
    pub const fn storage_rw(binding: u32, visibility: wgpu::ShaderStages) -> Self {
        Self::new(binding, visibility, BindingKind::Storage { read_only: false })
    }

    /// A single-sampled 2D sampled texture of `sample_type`.
    pub const fn texture(binding: u32, visibility: wgpu::ShaderStages, sample_type: wgpu::TextureSampleType) -> Self {
        Self::new(
            binding,
            visibility,
            BindingKind::Texture { sample_type, dimension: wgpu::TextureViewDimension::D2, multisampled: Cond::Never },
        )
    }

    /// A filterable float 2D-array texture (`texture_2d_array<f32>`: the material arrays).
    pub const fn texture_array(binding: u32, visibility: wgpu::ShaderStages) -> Self {
        Self::new(
            binding,
            visibility,
            BindingKind::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: Cond::Never,
            },
        )
    }

    /// A depth 2D-array texture (`texture_depth_2d_array`: the shadow atlas).
    pub const fn depth_array(binding: u32, visibility: wgpu::ShaderStages) -> Self {
        Self::new(
            binding,
            visibility,
            BindingKind::Texture {
                sample_type: wgpu::TextureSampleType::Depth,
                dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: Cond::Never,
            },
        )
    }

    /// A 2D storage texture.
    pub const fn storage_texture(
        binding: u32,
        visibility: wgpu::ShaderStages,
        format: wgpu::TextureFormat,
        access: wgpu::StorageTextureAccess,
    ) -> Self {
        Self::new(
            binding,
            visibility,
            BindingKind::StorageTexture { format, access, dimension: wgpu::TextureViewDimension::D2 },
        )
    }

    /// A sampler.
    pub const fn sampler(binding: u32, visibility: wgpu::ShaderStages, ty: wgpu::SamplerBindingType) -> Self {
        Self::new(binding, visibility, BindingKind::Sampler(ty))
    }

    /// This binding, existing only when `when` holds.
    pub const fn when(mut self, when: Cond) -> Self {
        self.when = when;
        self
    }

    /// This uniform buffer, bound with a dynamic offset and at least `min_size` bytes.
    /// Panics (at compile time in a `const`) on anything but a uniform.
    pub const fn dynamic_offset(mut self, min_size: u64) -> Self {
        match self.kind {
            BindingKind::Uniform { .. } => self.kind = BindingKind::Uniform { dynamic_offset: true, min_size },
            _ => panic!("dynamic_offset on a binding that is not a uniform"),
        }
        self
    }

    /// This texture, multisampled when `when` holds. Panics on anything but a texture.
    pub const fn multisampled_when(mut self, when: Cond) -> Self {
        match self.kind {
            BindingKind::Texture { sample_type, dimension, .. } => {
                self.kind = BindingKind::Texture { sample_type, dimension, multisampled: when }
            }
            _ => panic!("multisampled_when on a binding that is not a texture"),
        }
        self
    }

    /// The wgpu binding type for a variant compiled with `defines`.
    pub fn binding_type(&self, defines: &[&str]) -> wgpu::BindingType {
        match self.kind {
            BindingKind::Uniform { dynamic_offset, min_size } => wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic_offset,
                min_binding_size: wgpu::BufferSize::new(min_size),
            },
            BindingKind::Storage { read_only } => wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            BindingKind::Texture { sample_type, dimension, multisampled } => wgpu::BindingType::Texture {
                sample_type,
                view_dimension: dimension,
                multisampled: multisampled.holds(defines),
            },
            BindingKind::StorageTexture { format, access, dimension } => {
                wgpu::BindingType::StorageTexture { access, format, view_dimension: dimension }
            }
            BindingKind::Sampler(ty) => wgpu::BindingType::Sampler(ty),
        }
    }

    /// The layout entry of a variant compiled with `defines`, or None when the binding
    /// does not exist there.
    pub fn layout_entry(&self, defines: &[&str]) -> Option<wgpu::BindGroupLayoutEntry> {
        self.when.holds(defines).then(|| wgpu::BindGroupLayoutEntry {
            binding: self.binding,
            visibility: self.visibility,
            ty: self.binding_type(defines),
            count: None,
        })
    }
}

/// The layout entries of a group declared as `bindings`, for a variant compiled with
/// `defines` (in declaration order; bindings whose condition fails are left out).
pub fn layout_entries(bindings: &[Binding], defines: &[&str]) -> Vec<wgpu::BindGroupLayoutEntry> {
    bindings.iter().filter_map(|b| b.layout_entry(defines)).collect()
}

/// A labelled bind group layout of the group declared as `bindings`, for `defines`.
pub fn create_layout(
    device: &wgpu::Device,
    label: &str,
    bindings: &[Binding],
    defines: &[&str],
) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &layout_entries(bindings, defines),
    })
}

/// One group of a pass: its index, when the pass binds it, and its bindings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassGroup {
    /// The `@group` index.
    pub group: u32,
    /// When the pass has this group (e.g. the material textures only with `TEXTURES`).
    pub when: Cond,
    /// Its bindings.
    pub bindings: &'static [Binding],
}

impl PassGroup {
    /// Group `group` declared as `bindings`, always present.
    pub const fn new(group: u32, bindings: &'static [Binding]) -> Self {
        Self { group, when: Cond::Always, bindings }
    }

    /// This group, present only when `when` holds.
    pub const fn when(mut self, when: Cond) -> Self {
        self.when = when;
        self
    }
}

/// Every binding of one pass: the entry file (relative to `shaders/`) whose variants
/// declare them and the groups, for `cargo xtask validate-shaders` to compare with naga.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassBindings {
    /// The WGSL entry file, relative to `shaders/`.
    pub entry: &'static str,
    /// The Rust file declaring it (`file!()`), for messages.
    pub source: &'static str,
    /// Its groups.
    pub groups: &'static [PassGroup],
}

impl PassBindings {
    /// The bindings declared for group `group`. Panics when the pass declares no such
    /// group (a mistake in the pass's own code).
    pub fn group(&self, group: u32) -> &'static [Binding] {
        match self.groups.iter().find(|g| g.group == group) {
            Some(g) => g.bindings,
            None => panic!("{} declares no group {group} for shaders/{}", self.source, self.entry),
        }
    }

    /// Every (group, layout entry) of a variant compiled with `defines`, in declaration
    /// order: what the pass's layouts hold for that variant.
    pub fn resolve(&self, defines: &[&str]) -> Vec<(u32, wgpu::BindGroupLayoutEntry)> {
        self.groups
            .iter()
            .filter(|g| g.when.holds(defines))
            .flat_map(|g| layout_entries(g.bindings, defines).into_iter().map(move |e| (g.group, e)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT;
    const GROUP: &[Binding] = &[
        Binding::storage(0, FS),
        Binding::uniform(5, FS),
        Binding::storage(4, FS).when(Cond::All(&[Cond::Defined(Define::HalfZ), Cond::NotDefined(Define::BruteForce)])),
        Binding::texture(3, FS, wgpu::TextureSampleType::Depth).multisampled_when(Cond::Defined(Define::Msaa)),
    ];

    #[test]
    fn conditions_follow_the_defines() {
        const COND: Cond = Cond::Any(&[
            Cond::Defined(Define::HalfZ),
            Cond::All(&[Cond::Defined(Define::Blended), Cond::NotDefined(Define::Coarse)]),
        ]);
        let (a, b, c, cond) = (Define::HalfZ, Define::Blended, Define::Coarse, COND);
        assert!(cond.holds(&[a.name()]));
        assert!(cond.holds(&[b.name()]));
        assert!(!cond.holds(&[b.name(), c.name()]));
        assert!(!cond.holds(&[]));
        assert_eq!(cond.to_string(), "(HALF_Z || (BLENDED && !COARSE))");
        assert!(Cond::from_bool(true).holds(&[]) && !Cond::from_bool(false).holds(&[a.name()]));
    }

    #[test]
    fn entries_are_filtered_by_the_defines() {
        let bindings = |defines: &[&str]| layout_entries(GROUP, defines).iter().map(|e| e.binding).collect::<Vec<_>>();
        assert_eq!(bindings(&[]), [0, 5, 3]);
        assert_eq!(bindings(&["HALF_Z"]), [0, 5, 4, 3]);
        assert_eq!(bindings(&["HALF_Z", "BRUTE_FORCE"]), [0, 5, 3]);
        let depth = |defines: &[&str]| layout_entries(GROUP, defines)[2].ty;
        assert!(matches!(depth(&[]), wgpu::BindingType::Texture { multisampled: false, .. }));
        assert!(matches!(depth(&["MSAA"]), wgpu::BindingType::Texture { multisampled: true, .. }));
    }

    // The entries the passes wrote by hand before the declarations: the declarations must
    // give exactly these.
    /// Layout entry for a uniform buffer.
    fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }
    }

    /// Layout entry for a storage buffer.
    fn storage_entry(binding: u32, visibility: wgpu::ShaderStages, read_only: bool) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }
    }

    /// Layout entry for a sampled 2D float texture.
    fn texture_entry(
        binding: u32,
        visibility: wgpu::ShaderStages,
        sample_type: wgpu::TextureSampleType,
    ) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        }
    }

    #[test]
    fn entries_match_the_hand_written_ones() {
        let cs = wgpu::ShaderStages::COMPUTE;
        assert_eq!(Binding::storage(1, cs).layout_entry(&[]), Some(storage_entry(1, cs, true)));
        assert_eq!(Binding::storage_rw(2, cs).layout_entry(&[]), Some(storage_entry(2, cs, false)));
        assert_eq!(Binding::uniform(3, cs).layout_entry(&[]), Some(uniform_entry(3, cs)));
        let float = wgpu::TextureSampleType::Float { filterable: false };
        assert_eq!(Binding::texture(0, cs, float).layout_entry(&[]), Some(texture_entry(0, cs, float)));
    }

    #[test]
    fn every_declared_group_resolves_without_duplicates() {
        for pass in crate::binding_declarations() {
            // Every define any condition names, all set and none set.
            for defines in [&[][..], &["MSAA", "HALF_Z", "COARSE", "SPOT_CONE", "TEXTURES"][..]] {
                let mut seen: Vec<(u32, u32)> = pass.resolve(defines).iter().map(|(g, e)| (*g, e.binding)).collect();
                let n = seen.len();
                seen.sort();
                seen.dedup();
                assert_eq!(seen.len(), n, "{} {defines:?}", pass.entry);
            }
        }
    }

    #[test]
    fn missing_group_panics_with_the_pass_named() {
        const PASS: PassBindings =
            PassBindings { entry: "x.wgsl", source: "here.rs", groups: &[PassGroup::new(0, GROUP)] };
        let pass = PASS;
        assert_eq!(pass.group(0).len(), 4);
        let err = std::panic::catch_unwind(|| pass.group(1)).unwrap_err();
        let msg = err.downcast_ref::<String>().unwrap();
        assert_eq!(msg, "here.rs declares no group 1 for shaders/x.wgsl");
    }
}
