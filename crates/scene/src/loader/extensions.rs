//! glTF extensions: which ones tiledlight reads ([`SUPPORTED_EXTENSIONS`]), the error for
//! a file that requires another one, and the warning for a file that merely uses one.
//! Depends on the gltf crate only.

/// The glTF extensions this loader reads. A file whose `extensionsRequired` names any
/// other fails to load; one whose `extensionsUsed` names another loads with a warning and
/// is drawn without it. Add an extension here when the loader reads it.
pub const SUPPORTED_EXTENSIONS: &[&str] =
    &["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_mesh_quantization", "KHR_texture_transform"];

/// The extensions of `names` this loader cannot read, in file order, each once.
fn unsupported(names: &[String]) -> Vec<&str> {
    let mut out: Vec<&str> = Vec::new();
    for n in names {
        if !SUPPORTED_EXTENSIONS.contains(&n.as_str()) && !out.contains(&n.as_str()) {
            out.push(n);
        }
    }
    out
}

fn quoted(names: &[&str]) -> String {
    names.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")
}

fn supported_list() -> String {
    SUPPORTED_EXTENSIONS.join(", ")
}

/// An error message when `root` requires extensions that are not supported.
pub(crate) fn check_required(root: &gltf::json::Root) -> Result<(), String> {
    let missing = unsupported(&root.extensions_required);
    if missing.is_empty() {
        return Ok(());
    }
    let (s, it) = if missing.len() == 1 { ("", "it") } else { ("s", "them") };
    Err(format!(
        "requires the glTF extension{s} {} (extensionsRequired), which tiledlight cannot read: it cannot be drawn without {it} (supported: {})",
        quoted(&missing),
        supported_list()
    ))
}

/// A warning when `root` uses extensions that are not supported (and not required: those
/// failed in [`check_required`]).
pub(crate) fn used_warning(root: &gltf::json::Root) -> Option<String> {
    let unknown = unsupported(&root.extensions_used);
    if unknown.is_empty() {
        return None;
    }
    let (s, it) = if unknown.len() == 1 { ("", "it") } else { ("s", "them") };
    Some(format!(
        "uses the glTF extension{s} {} (extensionsUsed), which tiledlight does not read: drawn without {it}, so the image may differ from the model's (supported: {})",
        quoted(&unknown),
        supported_list()
    ))
}
