//! Bounding volume hierarchies: the flat binary node layout every traverser reads, and the
//! builders that produce it. Builders are chosen by [`BuildMethod`]; the later builders (spatial
//! splits, OSAH, SRDH) slot in beside binned SAH without changing the layout.

mod binned_sah;
mod node;
mod wide;

pub use binned_sah::{build_binned_sah, BuildSettings};
pub use node::{Bvh, BvhNode, NodeArray, MAX_DEPTH};
pub use wide::{BvhWidth, WideBvh, WideNode, EMPTY_CHILD};

use serde::{Deserialize, Serialize};

/// Which builder makes the binary BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum BuildMethod {
    #[default]
    Sah,
}

impl BuildMethod {
    pub fn name(&self) -> &'static str {
        match self {
            BuildMethod::Sah => "sah",
        }
    }
}

impl std::str::FromStr for BuildMethod {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        match s {
            "sah" => Ok(BuildMethod::Sah),
            other => Err(crate::Error::invalid(
                "build",
                format!("unknown build method '{other}' (known: sah)"),
            )),
        }
    }
}

/// Builds a BVH over `triangles` with the chosen method.
pub fn build(method: BuildMethod, triangles: &[[glam::Vec3; 3]], settings: &BuildSettings) -> Bvh {
    match method {
        BuildMethod::Sah => build_binned_sah(triangles, settings),
    }
}
