//! Visible-triangle sets for visibility-driven builds (ABVH, OSAH, VSAH): where a frame's set
//! comes from, how a set is taken from a primary pass, and how a set of [`TriangleRef`]s (stable
//! across frames) becomes per-triangle flags of this frame's triangle arrays.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{PrimaryPass, PrimaryRays, SurfacePoint};
use crate::bvh::Bvh;
use crate::cancel::CancelToken;
use crate::scene::{FrameGeometry, ImageSize, Resolution, Scene, TriangleRef, TriangleSet};
use crate::trace::NoStats;
use crate::{Error, Result};

/// Where a visibility-driven build takes its visible set from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum VisibilitySource {
    /// The set seen by the previous frame's primary rays, V(t-1); the first frame has none and
    /// builds the tree the method falls back to (SAH for ABVH/OSAH).
    #[default]
    Previous,
    /// This frame's own set V(t), from a primary pass before the build (two passes; a
    /// reference for what "previous" loses).
    Exact,
    /// As `Previous`, but the first frame takes its set from a primary pass at this size.
    Prepass { width: u32, height: u32 },
}

impl VisibilitySource {
    pub fn name(&self) -> String {
        match self {
            VisibilitySource::Previous => "previous".into(),
            VisibilitySource::Exact => "exact".into(),
            VisibilitySource::Prepass { width, height } => {
                format!("prepass:{}", ImageSize::new(*width, *height))
            }
        }
    }

    pub fn validate(&self) -> Result<()> {
        if let VisibilitySource::Prepass { width, height } = *self {
            ImageSize::new(width, height)
                .check(ImageSize::MAX_PREPASS_SIDE)
                .map_err(|e| Error::invalid("visibility", format!("prepass size {e}")))?;
        }
        Ok(())
    }
}

impl std::str::FromStr for VisibilitySource {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let bad = || {
            Error::invalid(
                "visibility",
                format!("'{s}' is not previous, exact or prepass:WxH"),
            )
        };
        match s {
            "previous" => Ok(VisibilitySource::Previous),
            "exact" => Ok(VisibilitySource::Exact),
            _ => {
                let size: ImageSize = s
                    .strip_prefix("prepass:")
                    .ok_or_else(bad)?
                    .parse()
                    .map_err(|_| bad())?;
                let v = VisibilitySource::Prepass {
                    width: size.width,
                    height: size.height,
                };
                v.validate()?;
                Ok(v)
            }
        }
    }
}

/// The sorted set of triangles that primary rays hit. On a flat frame (`camera`, the set the
/// camera tree was built over) one flag per triangle id gives it without a sort; on two levels
/// the surfaces' references are sorted and deduplicated.
pub(super) fn visible_set(
    surfaces: &[Option<SurfacePoint>],
    camera: Option<&TriangleSet>,
) -> Vec<TriangleRef> {
    let hits = surfaces.iter().flatten();
    let mut visible: Vec<TriangleRef> = match camera {
        Some(camera) => {
            let mut seen = vec![false; camera.len()];
            for s in hits {
                seen[s.triangle as usize] = true;
            }
            seen.iter()
                .enumerate()
                .filter(|(_, s)| **s)
                .map(|(i, _)| camera.refs[i])
                .collect()
        }
        None => hits.map(|s| s.reference).collect(),
    };
    visible.sort_unstable();
    visible.dedup();
    visible
}

/// The visible set of `scene`'s camera at `resolution`, traced through `bvh` (any complete tree
/// over the camera set: the answers do not depend on it).
pub(super) fn trace_visible_set(
    scene: &Scene,
    resolution: &Resolution,
    geometry: &FrameGeometry,
    bvh: &Bvh,
) -> Vec<TriangleRef> {
    let rays = PrimaryRays::new(&scene.camera, resolution, &geometry.space);
    let pass = PrimaryPass::trace::<NoStats>(&rays, bvh, &geometry.camera, &CancelToken::new())
        .expect("a new token is never cancelled");
    visible_set(&pass.surfaces, Some(&geometry.camera))
}

/// Per-triangle flags of `set` for the sorted `visible` refs. Refs of triangles this frame does
/// not have (an object removed, a mesh with fewer triangles) are ignored; new triangles are
/// invisible until a frame sees them.
pub fn visibility_flags(set: &TriangleSet, visible: &[TriangleRef]) -> Vec<bool> {
    // A frame collects its refs object by object in ascending order, so one merge walk against
    // the sorted visible refs flags them all, instead of a binary search per triangle; any
    // other order searches.
    if set.refs.is_sorted() {
        let mut next = visible.iter().peekable();
        set.refs
            .iter()
            .map(|r| {
                while next.next_if(|v| *v < r).is_some() {}
                next.peek() == Some(&r)
            })
            .collect()
    } else {
        set.refs
            .par_iter()
            .map(|r| visible.binary_search(r).is_ok())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn parses_the_three_sources() {
        assert_eq!(
            "previous".parse::<VisibilitySource>().unwrap(),
            VisibilitySource::Previous
        );
        assert_eq!(
            "exact".parse::<VisibilitySource>().unwrap(),
            VisibilitySource::Exact
        );
        let p: VisibilitySource = "prepass:32x16".parse().unwrap();
        assert_eq!(
            p,
            VisibilitySource::Prepass {
                width: 32,
                height: 16
            }
        );
        assert_eq!(p.name(), "prepass:32x16");
        for bad in ["prepass", "prepass:0x4", "prepass:8", "nearest"] {
            assert!(bad.parse::<VisibilitySource>().is_err(), "{bad}");
        }
    }

    #[test]
    fn flags_follow_refs_not_indices() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let r = |object, primitive| TriangleRef { object, primitive };
        // Object 1 disappeared, object 3 is new: indices moved, identities did not.
        let set = TriangleSet {
            vertices: vec![tri; 4],
            refs: vec![r(0, 0), r(0, 1), r(2, 0), r(3, 0)],
            degenerate: 0,
        };
        let visible = vec![r(0, 1), r(1, 0), r(2, 0)];
        assert_eq!(visibility_flags(&set, &visible), [false, true, true, false]);
    }

    #[test]
    fn merge_walk_and_search_agree_in_any_order() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let r = |object, primitive| TriangleRef { object, primitive };
        let refs: Vec<TriangleRef> = (0..6)
            .flat_map(|o| (0..50).map(move |p| r(o, p)))
            .filter(|t| (t.object * 7 + t.primitive * 13) % 5 != 0)
            .collect();
        // Visible: some of the frame's refs, repeats, and refs the frame no longer has.
        let mut visible: Vec<TriangleRef> = refs
            .iter()
            .copied()
            .filter(|t| (t.primitive * 31 + t.object) % 3 == 0)
            .chain([r(0, 0), r(9, 1), r(2, 999)])
            .collect();
        visible.sort_unstable();
        visible.dedup();
        let want = |refs: &[TriangleRef]| -> Vec<bool> {
            refs.iter().map(|t| visible.contains(t)).collect()
        };
        let set = |refs: Vec<TriangleRef>| TriangleSet {
            vertices: vec![tri; refs.len()],
            refs,
            degenerate: 0,
        };
        let sorted = set(refs.clone());
        assert!(sorted.refs.is_sorted());
        let flags = visibility_flags(&sorted, &visible);
        assert_eq!(flags, want(&sorted.refs));
        assert!(flags.iter().any(|&f| f) && flags.iter().any(|&f| !f));
        let mut shuffled = refs;
        shuffled.reverse();
        shuffled.swap(3, 100);
        let shuffled = set(shuffled);
        assert_eq!(visibility_flags(&shuffled, &visible), want(&shuffled.refs));
        assert_eq!(
            visibility_flags(&sorted, &[]),
            vec![false; sorted.refs.len()]
        );
    }
}
