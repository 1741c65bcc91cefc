//! [`InstanceAlpha`]: a two-level frame's alpha. One [`AlphaScene`] per (mesh tree, object
//! materials) pair the instances use, its triangle ids the mesh tree's: the instances of one
//! mesh under the same materials share it, so a forest of leaf-card instances holds one.

use crate::alpha::AlphaScene;
use crate::trace::AlphaScenes;

use super::GROUP;

/// An instance with no scene: every triangle opaque.
const OPAQUE: u32 = u32::MAX;

/// The alpha of a two-level frame's instances, by the object each instance names.
#[derive(Clone, Debug, Default)]
pub struct InstanceAlpha {
    scenes: Vec<AlphaScene>,
    /// By object index: its scene in `scenes`, or [`OPAQUE`].
    by_object: Vec<u32>,
    /// The group tree's scene (its ids are the group tree's), or [`OPAQUE`].
    group: u32,
    /// Nothing flagged: what an opaque instance reads.
    opaque: AlphaScene,
}

impl InstanceAlpha {
    /// `by_object[o]`: the index in `scenes` of object `o`'s scene (`None`: opaque); `group`:
    /// the group tree's.
    pub fn new(scenes: Vec<AlphaScene>, by_object: &[Option<u32>], group: Option<u32>) -> Self {
        let index = |s: Option<u32>| s.filter(|&i| (i as usize) < scenes.len()).unwrap_or(OPAQUE);
        InstanceAlpha {
            by_object: by_object.iter().map(|&s| index(s)).collect(),
            group: index(group),
            scenes,
            opaque: AlphaScene::default(),
        }
    }

    pub fn scenes(&self) -> &[AlphaScene] {
        &self.scenes
    }

    /// Whether no instance has a flagged triangle: the frame then traces as an opaque one.
    pub fn flags_nothing(&self) -> bool {
        let used = |i: u32| self.scenes.get(i as usize);
        (self.by_object.iter().copied().chain([self.group]))
            .filter_map(used)
            .all(|s| s.triangles().flagged_count() == 0)
    }

    /// Bytes held by the flag bits, ranks and UVs of every scene, and the object map.
    pub fn bytes(&self) -> usize {
        let scenes: usize = self.scenes.iter().map(|s| s.triangles().bytes()).sum();
        scenes + self.by_object.len() * 4
    }
}

impl AlphaScenes for InstanceAlpha {
    #[inline]
    fn for_instance(&self, instance: u32) -> &AlphaScene {
        let scene = match instance {
            GROUP => self.group,
            o => self.by_object.get(o as usize).copied().unwrap_or(OPAQUE),
        };
        self.scenes.get(scene as usize).unwrap_or(&self.opaque)
    }
}
