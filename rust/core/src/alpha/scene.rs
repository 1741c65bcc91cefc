//! Everything a traversal needs to evaluate alpha at a hit: the images, one program per
//! material, and the flagged triangles of the triangle set the tree was built from.

use std::sync::Arc;

use super::{AlphaImage, AlphaProgram, AlphaTriangles};
use crate::{Error, Result};

/// The alpha of one triangle set, validated once when made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlphaScene {
    /// Shared with the frame's scene: a frame's alpha copies no texels.
    images: Vec<Arc<AlphaImage>>,
    programs: Vec<AlphaProgram>,
    triangles: AlphaTriangles,
}

impl AlphaScene {
    /// Checks every image (size, texel count, finite texels), every program (image and UV set
    /// in range, finite constants) and every flagged triangle's material; errors name the field.
    pub fn new(
        images: Vec<AlphaImage>,
        programs: Vec<AlphaProgram>,
        triangles: AlphaTriangles,
    ) -> Result<Self> {
        Self::shared(
            images.into_iter().map(Arc::new).collect(),
            programs,
            triangles,
        )
    }

    /// As [`AlphaScene::new`] over images shared with their owner (the frame's scene).
    pub fn shared(
        images: Vec<Arc<AlphaImage>>,
        programs: Vec<AlphaProgram>,
        triangles: AlphaTriangles,
    ) -> Result<Self> {
        for (i, image) in images.iter().enumerate() {
            image.validate(&format!("alpha.images[{i}]"))?;
        }
        let uv_sets = triangles.uv_set_count() as usize;
        for (i, p) in programs.iter().enumerate() {
            p.validate(&format!("alpha.materials[{i}]"), images.len(), uv_sets)?;
        }
        // The first flagged triangle with a bad material, named by its triangle id.
        if let Some(rank) = triangles
            .materials()
            .iter()
            .position(|&m| m as usize >= programs.len())
        {
            let id = (0..triangles.triangle_count())
                .find(|&t| triangles.rank(t) == Some(rank))
                .unwrap_or(u32::MAX);
            return Err(Error::invalid(
                format!("alpha.triangles[{id}].material"),
                format!(
                    "material {}, but the scene has {} alpha materials",
                    triangles.material(rank),
                    programs.len()
                ),
            ));
        }
        Ok(AlphaScene {
            images,
            programs,
            triangles,
        })
    }

    pub fn images(&self) -> &[Arc<AlphaImage>] {
        &self.images
    }

    pub fn programs(&self) -> &[AlphaProgram] {
        &self.programs
    }

    pub fn triangles(&self) -> &AlphaTriangles {
        &self.triangles
    }

    /// The alpha of `triangle` at barycentrics `b` (weights of its vertices 0, 1, 2), `None`
    /// for an unflagged (opaque, no lookup) triangle.
    #[inline]
    pub fn alpha(&self, triangle: u32, b: [f32; 3]) -> Option<f32> {
        let rank = self.triangles.rank(triangle)?;
        let program = &self.programs[self.triangles.material(rank) as usize];
        let uv = match program.uv_set() {
            Some(set) => self.triangles.uv(rank, set, b),
            None => [0.0; 2],
        };
        Some(program.eval_shared(&self.images, uv))
    }
}
