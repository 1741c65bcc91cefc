//! Materials that let light through (issue 38): what a frame says about alpha, in Blender's
//! terms. A mesh carries per-triangle material slots and the per-corner UV maps its alpha
//! materials read; an object maps its slots to the scene's alpha materials; the scene holds the
//! alpha images (shared between frames, like meshes) and one program per alpha material.
//! Everything without an alpha material is opaque and carries none of this.

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::alpha::{AlphaImage, AlphaProgram};
use crate::{Error, Result};

/// One UV map of a mesh: the (u, v) at each triangle's three corners, in vertex order,
/// parallel to [`super::Mesh::triangles`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UvMap {
    /// The name an [`AlphaMaterial::uv_map`] refers to it by ("" is the active render map).
    pub name: String,
    pub corners: Vec<[[f32; 2]; 3]>,
}

/// A material whose alpha is not 1 everywhere: a leaf card's image, a glass box's constant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlphaMaterial {
    /// Blender's material name, for messages.
    pub name: String,
    /// The UV map an image source reads, by name; a mesh without it reads UV (0, 0), as
    /// Cycles' attribute lookup does. Unused by a constant source.
    pub uv_map: String,
    /// The alpha. An image source's `uv_set` must be 0: the one UV map named above.
    pub program: AlphaProgram,
}

/// The alpha images and materials of a frame; empty for an opaque scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneAlpha {
    pub images: Vec<Arc<AlphaImage>>,
    pub materials: Vec<AlphaMaterial>,
}

impl SceneAlpha {
    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    /// Checks every image (size, texel count, finite texels) and every material (image in
    /// range, UV set 0, finite constants); errors name the image index or the material.
    pub fn validate(&self) -> Result<()> {
        for (i, image) in self.images.iter().enumerate() {
            image.validate(&format!("alpha.images[{i}]"))?;
        }
        for (i, m) in self.materials.iter().enumerate() {
            m.program.validate(
                &format!("alpha.materials[{i}] ('{}')", m.name),
                self.images.len(),
                1,
            )?;
        }
        Ok(())
    }
}

/// Checks a mesh's slots and UV maps against its triangle count; errors name the mesh, the UV
/// map and the triangle.
pub(crate) fn validate_mesh_alpha(
    mesh: &str,
    triangles: usize,
    material_slots: &[u32],
    uv_maps: &[UvMap],
) -> Result<()> {
    if !material_slots.is_empty() && material_slots.len() != triangles {
        return Err(Error::invalid(
            format!("mesh '{mesh}'.material_slots"),
            format!(
                "{} material slots for {triangles} triangles (give one per triangle or none)",
                material_slots.len()
            ),
        ));
    }
    for map in uv_maps {
        if map.corners.len() != triangles {
            return Err(Error::invalid(
                format!("mesh '{mesh}'.uv_maps['{}']", map.name),
                format!(
                    "{} corner-UV triples for {triangles} triangles (give one per triangle)",
                    map.corners.len()
                ),
            ));
        }
        if let Some((index, value)) = map.corners.iter().enumerate().find_map(|(t, c)| {
            c.as_flattened()
                .iter()
                .find(|v| !v.is_finite())
                .map(|&v| (t, v))
        }) {
            return Err(Error::NonFinite {
                owner: format!("mesh '{mesh}', UV map '{}'", map.name),
                what: "corner UV",
                index,
                value: value as f64,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alpha::{Extension, Interpolation};

    #[test]
    fn validation_names_the_mesh_map_triangle_and_material() {
        let bad_uv = UvMap {
            name: "Leaves".into(),
            corners: vec![[[0.0; 2]; 3], [[0.0, f32::NAN], [0.0; 2], [0.0; 2]]],
        };
        let e = validate_mesh_alpha("Card", 2, &[], &[bad_uv]).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("Card") && text.contains("Leaves") && text.contains('1'),
            "{text}"
        );
        let e = validate_mesh_alpha("Card", 2, &[0], &[]).unwrap_err();
        assert!(e.to_string().contains("material_slots"), "{e}");

        let alpha = SceneAlpha {
            images: vec![],
            materials: vec![AlphaMaterial {
                name: "Leaf".into(),
                uv_map: String::new(),
                program: AlphaProgram::image(0, 0, Interpolation::Linear, Extension::Repeat),
            }],
        };
        let e = alpha.validate().unwrap_err().to_string();
        assert!(e.contains("Leaf") && e.contains("image"), "{e}");
    }
}
