//! The gltf crate's validation of a document, with two corrections: its check of
//! `extensionsRequired` (against the extensions the gltf crate parses) is left out, since
//! [`super::extensions`] decides that with tiledlight's own list; and a primitive whose
//! POSITION names a missing accessor is reported here, because gltf-json 1.4.1 indexes
//! the accessor list unchecked there and panics (found by the mutation test). Depends on
//! the gltf crate only.

use gltf::json::validation::{Error, Validate};
use gltf::json::Path;

/// Validates `doc`; the error lists every problem with its JSON path.
pub(crate) fn validate(doc: &gltf::Document) -> Result<(), gltf::Error> {
    let root = doc.as_json();
    let mut errors = Vec::new();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position =
                prim.attributes.get(&gltf::json::validation::Checked::Valid(gltf::json::mesh::Semantic::Positions));
            if position.is_some_and(|a| a.value() >= root.accessors.len()) {
                let path = Path::new().field("meshes").index(m).field("primitives").index(p);
                errors.push((path.field("attributes").key("POSITION"), Error::IndexOutOfBounds));
            }
        }
    }
    if !errors.is_empty() {
        // The gltf crate's validation would panic on these.
        return Err(gltf::Error::Validation(errors));
    }
    root.validate(root, Path::new, &mut |path, error| {
        let path = path();
        if !path.as_str().starts_with("extensionsRequired") {
            errors.push((path, error));
        }
    });
    if errors.is_empty() {
        Ok(())
    } else {
        Err(gltf::Error::Validation(errors))
    }
}
