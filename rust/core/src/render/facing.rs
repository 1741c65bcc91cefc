//! Which normal decides that a light sample is behind the surface (shadowed without a ray): the
//! triangle's geometric normal, or, as Cycles does, the interpolated shading normal.

use std::fmt;
use std::str::FromStr;

use glam::{DMat3, Vec3};
use serde::{Deserialize, Serialize};

use super::{HitGeometry, PrimaryPass, PrimaryRays};
use crate::geometry::{intersect_triangle, triangle_normal, WatertightRay};
use crate::scene::Scene;
use crate::{Error, Result};

/// The back-facing convention of the shadow masks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Facing {
    /// The triangle's own plane: exact for the geometry, blind to smooth shading.
    #[default]
    Geometric,
    /// The mesh's corner normals interpolated at the hit (Cycles' convention); meshes without
    /// normals keep the geometric normal.
    Shading,
}

impl Facing {
    pub fn name(self) -> &'static str {
        match self {
            Facing::Geometric => "geometric",
            Facing::Shading => "shading",
        }
    }
}

impl fmt::Display for Facing {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Facing {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "geometric" => Ok(Facing::Geometric),
            "shading" => Ok(Facing::Shading),
            _ => Err(Error::invalid(
                "facing",
                format!("expected geometric or shading, got '{s}'"),
            )),
        }
    }
}

/// Sets each surface's `facing` to its shading normal: the hit triangle's corner normals
/// interpolated at the hit's barycentrics (recomputed with the traversal's own triangle test),
/// taken to world space by the object's normal matrix and turned to the camera's side exactly
/// when the geometric normal was. Surfaces of meshes without normals keep the geometric one.
pub(crate) fn face_shading_normals(
    primary: &mut PrimaryPass,
    rays: &PrimaryRays,
    scene: &Scene,
    triangles: &HitGeometry,
) {
    // The normal matrix of the last object hit, and whether it mirrors (which turns the
    // winding's normal): neighbouring pixels mostly hit one object, and a table for every
    // object would hold 80 bytes each (80 MB for a million instances).
    let mut last: Option<(u32, DMat3, bool)> = None;
    let mut normal_matrix = |object: u32| match last {
        Some((o, m, mirrors)) if o == object => (m, mirrors),
        _ => {
            let linear = DMat3::from_mat4(scene.objects[object as usize].world_from_object);
            let made = (linear.inverse().transpose(), linear.determinant() < 0.0);
            last = Some((object, made.0, made.1));
            made
        }
    };
    let width = primary.width as usize;
    for (pixel, surface) in primary.surfaces.iter_mut().enumerate() {
        let Some(s) = surface else { continue };
        let r = s.reference;
        let object = &scene.objects[r.object as usize];
        let Some(corners) = scene.meshes[object.mesh].normals.get(r.primitive as usize) else {
            continue;
        };
        let (v, _) = triangles.triangle(s.instance, s.triangle);
        let ray = rays.ray((pixel % width) as u32, (pixel / width) as u32);
        let Some(hit) = intersect_triangle(&WatertightRay::new(&ray), &v, ray.t_min, ray.t_max)
        else {
            continue;
        };
        let local = corners[0] * hit.b0 + corners[1] * hit.b1 + corners[2] * hit.b2;
        let (normal_matrix, mirrors) = normal_matrix(r.object);
        let shading = (normal_matrix * local.as_dvec3())
            .as_vec3()
            .normalize_or_zero();
        if shading == Vec3::ZERO {
            continue;
        }
        // The winding's normal in world terms; the surface's normal was turned to the camera.
        let mut outward = triangle_normal(&v);
        if mirrors {
            outward = -outward;
        }
        s.facing = if outward.dot(s.normal) >= 0.0 {
            shading
        } else {
            -shading
        };
    }
}
