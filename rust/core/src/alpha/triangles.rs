//! Which triangles of a triangle set have a non-opaque material, and their material and corner
//! UVs. Unflagged triangles cost a bit each (a bitset with a rank per 64 triangles: 12 bytes per
//! 64 triangles), so a large mesh without alpha carries no UVs at all.

use crate::{Error, Result};

/// A flagged triangle as the exporter hands it over.
#[derive(Clone, Debug, PartialEq)]
pub struct FlaggedTriangle {
    /// Its id in the triangle set (the id a BVH's `triangle_ids` holds).
    pub triangle: u32,
    /// Index into the scene's alpha programs.
    pub material: u32,
    /// Per UV set, the (u, v) of its three corners in vertex order.
    pub uvs: Vec<[[f32; 2]; 3]>,
}

/// The flagged triangles of a triangle set.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlphaTriangles {
    triangle_count: u32,
    uv_set_count: u32,
    /// Bit `t % 64` of word `t / 64`: triangle t is flagged.
    bits: Vec<u64>,
    /// Flagged triangles before word i (the rank of its first bit).
    rank: Vec<u32>,
    /// Per flagged triangle in id order: its material.
    materials: Vec<u32>,
    /// Per UV set, per flagged triangle in id order: its corner UVs.
    uvs: Vec<Vec<[[f32; 2]; 3]>>,
}

impl AlphaTriangles {
    /// The flagged triangles of a set of `triangle_count` triangles with `uv_set_count` UV sets.
    /// Errors name the triangle: an id out of range or given twice, a wrong number of UV sets, a
    /// non-finite UV.
    pub fn new(
        triangle_count: u32,
        uv_set_count: u32,
        mut flagged: Vec<FlaggedTriangle>,
    ) -> Result<Self> {
        flagged.sort_by_key(|f| f.triangle);
        let words = (triangle_count as usize).div_ceil(64);
        let mut bits = vec![0u64; words];
        for (i, f) in flagged.iter().enumerate() {
            let field = format!("alpha.triangles[{}]", f.triangle);
            if f.triangle >= triangle_count {
                return Err(Error::invalid(
                    field,
                    format!("triangle {}, but the set has {triangle_count}", f.triangle),
                ));
            }
            if i > 0 && flagged[i - 1].triangle == f.triangle {
                return Err(Error::invalid(field, "flagged twice"));
            }
            if f.uvs.len() != uv_set_count as usize {
                return Err(Error::invalid(
                    format!("{field}.uvs"),
                    format!("{} UV sets, {uv_set_count} expected", f.uvs.len()),
                ));
            }
            let flat = f.uvs.iter().flat_map(|c| c.iter().flatten());
            if let Some((k, &value)) = flat.enumerate().find(|(_, x)| !x.is_finite()) {
                return Err(Error::NonFinite {
                    owner: format!("alpha triangle {}", f.triangle),
                    what: "corner UVs",
                    index: k,
                    value: value as f64,
                });
            }
            bits[f.triangle as usize / 64] |= 1 << (f.triangle % 64);
        }
        let mut rank = Vec::with_capacity(words);
        let mut before = 0u32;
        for w in &bits {
            rank.push(before);
            before += w.count_ones();
        }
        let materials = flagged.iter().map(|f| f.material).collect();
        let uvs = (0..uv_set_count as usize)
            .map(|s| flagged.iter().map(|f| f.uvs[s]).collect())
            .collect();
        Ok(AlphaTriangles {
            triangle_count,
            uv_set_count,
            bits,
            rank,
            materials,
            uvs,
        })
    }

    pub fn triangle_count(&self) -> u32 {
        self.triangle_count
    }

    pub fn uv_set_count(&self) -> u32 {
        self.uv_set_count
    }

    /// How many triangles are flagged.
    pub fn flagged_count(&self) -> usize {
        self.materials.len()
    }

    /// The materials of the flagged triangles, in triangle id order.
    pub fn materials(&self) -> &[u32] {
        &self.materials
    }

    /// The flagged triangle's rank (its index among flagged triangles), `None` when `triangle`
    /// is unflagged (opaque) or out of range.
    #[inline(always)]
    pub fn rank(&self, triangle: u32) -> Option<usize> {
        let (w, b) = (triangle as usize / 64, triangle % 64);
        let word = *self.bits.get(w)?;
        if word & (1 << b) == 0 {
            return None;
        }
        let below = (word & ((1u64 << b) - 1)).count_ones();
        Some((self.rank[w] + below) as usize)
    }

    /// The material of the flagged triangle of rank `rank`.
    #[inline(always)]
    pub fn material(&self, rank: usize) -> u32 {
        self.materials[rank]
    }

    /// The UV at barycentrics `b` (weights of vertices 0, 1, 2) of flagged triangle `rank` in
    /// UV set `set`: `b0 * uv0 + b1 * uv1 + b2 * uv2`, left to right, per component.
    #[inline(always)]
    pub fn uv(&self, rank: usize, set: u32, b: [f32; 3]) -> [f32; 2] {
        let c = &self.uvs[set as usize][rank];
        [
            b[0] * c[0][0] + b[1] * c[1][0] + b[2] * c[2][0],
            b[0] * c[0][1] + b[1] * c[1][1] + b[2] * c[2][1],
        ]
    }

    /// Bytes held (for the memory tables).
    pub fn bytes(&self) -> usize {
        self.bits.len() * 8
            + self.rank.len() * 4
            + self.materials.len() * 4
            + self.uvs.iter().map(|s| s.len() * 24).sum::<usize>()
    }
}
