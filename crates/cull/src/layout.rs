//! Descriptions of Rust structs that are shared with WGSL, so that `cargo xtask
//! validate-shaders` can compare their size and field offsets with naga's layout of
//! the WGSL struct of the same name. Depends on nothing but `core`.

/// One named field of a shared struct and its byte offset in the Rust type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    /// Field name; the WGSL member must have the same name.
    pub name: &'static str,
    /// Byte offset of the field in the Rust struct.
    pub offset: usize,
}

/// The layout of one `#[repr(C)]` Rust struct that mirrors a WGSL struct.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// Rust type name, for messages.
    pub rust_name: &'static str,
    /// Name of the WGSL struct it mirrors.
    pub wgsl_name: &'static str,
    /// WGSL file (relative to `shaders/`) that declares the struct.
    pub wgsl_file: &'static str,
    /// `size_of` the Rust struct.
    pub size: usize,
    /// Every field that is not padding; padding fields start with `_` and are not listed.
    pub fields: Vec<FieldLayout>,
}

/// Builds a [`StructLayout`] for a `#[repr(C)]` struct: type, WGSL struct name,
/// WGSL file (relative to `shaders/`), then the non-padding fields in order.
#[macro_export]
macro_rules! struct_layout {
    ($ty:ty, $wgsl:literal, $file:literal, [$($field:ident),* $(,)?]) => {
        $crate::layout::StructLayout {
            rust_name: stringify!($ty),
            wgsl_name: $wgsl,
            wgsl_file: $file,
            size: ::core::mem::size_of::<$ty>(),
            fields: vec![$($crate::layout::FieldLayout {
                name: stringify!($field),
                offset: ::core::mem::offset_of!($ty, $field),
            }),*],
        }
    };
}
