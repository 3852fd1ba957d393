//! The public test meshes (MIT, see `assets/models/LICENSE-meshes.txt`), embedded in the binary
//! so `builtin:bunny` works from any directory.

use crate::error::{Error, Result};
use crate::scene::loaders::obj::{self, MtlLookup};
use crate::scene::Mesh;

/// Names of the embedded models.
pub(crate) const MODEL_NAMES: [&str; 5] = ["dragon", "bunny", "suzanne", "spot", "teapot"];

fn source(name: &str) -> Option<&'static str> {
    Some(match name {
        "dragon" => include_str!("../../../assets/models/dragon.obj"),
        "bunny" => include_str!("../../../assets/models/bunny.obj"),
        "suzanne" => include_str!("../../../assets/models/suzanne.obj"),
        "spot" => include_str!("../../../assets/models/spot.obj"),
        "teapot" => include_str!("../../../assets/models/teapot.obj"),
        _ => return None,
    })
}

/// The embedded model `name` as one mesh (all its groups merged), with normals.
pub(crate) fn model_mesh(name: &str) -> Result<Mesh> {
    let text = source(name).ok_or_else(|| Error::input(format!("no embedded model '{name}'")))?;
    let what = format!("builtin:{name}");
    // The embedded files' `mtllib` references are not shipped: no materials, no warning.
    let parts = obj::parse_obj_text(text, &what, &|_| MtlLookup::Skip, &mut Vec::new())?;
    let mut merged = Mesh::default();
    for (_, mesh, _) in parts {
        let base = merged.positions.len() as u32;
        merged.positions.extend_from_slice(&mesh.positions);
        merged.normals.extend_from_slice(&mesh.normals);
        merged.indices.extend(mesh.indices.iter().map(|i| i + base));
    }
    merged.validate(&what)?;
    Ok(merged)
}
