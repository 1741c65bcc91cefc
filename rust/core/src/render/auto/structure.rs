//! `auto`'s structure for a scene with moving parts: two levels keep the trees of the meshes a
//! frame shares with the last (static objects, and rigidly moving ones under a new transform)
//! and build only the new meshes (deformed ones), but trace more slowly than the flat tree (an
//! instance entered is a transform and a second traversal), which a flat frame rebuilds whole
//! whenever anything moves. Which wins is that rebuild of the kept triangles against the
//! extra trace, so the rule weighs the kept triangles against the rays a frame traces. It reads
//! only counts that a warm-up sees as a render does (the frames' objects and meshes, the last
//! frame's camera hits), so a farm chunk chooses as one run does.

use crate::render::SceneStructure;

/// Kept triangles per traced ray from which two levels are taken on a frame that moves: on the
/// built-in scenes at one thread (8-wide top level), two levels framed 0.45x the flat tree at
/// 0.48 (character-room, 350k, 320x180), 0.79-0.83x at 0.11-0.16 (character-room and bedroom
/// at 350k, 640x360), 0.91-0.95x at 0.10 (city, hairball), 0.99-1.05x at 0.04-0.05 (bedroom,
/// colonnade) and 1.08x at 0.03 (character-room), BENCHMARKS.md "Flat and two levels".
pub const ENTER_TRIANGLES_PER_RAY: f64 = 0.08;

/// Two levels are kept down to this share: leaving them rebuilds every kept triangle in a flat
/// tree, and a scene that hovers about the entry share would otherwise pay that often.
pub const LEAVE_TRIANGLES_PER_RAY: f64 = 0.05;

/// What the rule reads of a frame and the frames before it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StructureContext {
    /// Triangles whose mesh the last frame had too: what two levels keep and a flat frame
    /// rebuilds when anything moves.
    pub kept_triangles: u64,
    /// Whether an object changed since the last frame (the flat tree is then rebuilt).
    pub moved: bool,
    /// The rays the last frame traced (camera rays and every light's samples at the surfaces
    /// it reaches), 0 before the first frame.
    pub rays: u64,
    /// The structure of the last frame, if `auto` chose it.
    pub current: Option<SceneStructure>,
}

/// Two levels on a frame that moves where the kept triangles are
/// [`ENTER_TRIANGLES_PER_RAY`] per ray or more, kept down to [`LEAVE_TRIANGLES_PER_RAY`];
/// else the flat tree.
pub fn choose_structure(c: &StructureContext) -> SceneStructure {
    let per_ray = c.kept_triangles as f64 / c.rays.max(1) as f64;
    let two_level = c.rays > 0
        && match c.current {
            Some(SceneStructure::TwoLevel) => per_ray >= LEAVE_TRIANGLES_PER_RAY,
            _ => c.moved && per_ray >= ENTER_TRIANGLES_PER_RAY,
        };
    if two_level {
        SceneStructure::TwoLevel
    } else {
        SceneStructure::Flat
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn context(kept_triangles: u64, rays: u64) -> StructureContext {
        StructureContext {
            kept_triangles,
            moved: true,
            rays,
            current: Some(SceneStructure::Flat),
        }
    }

    #[test]
    fn many_kept_triangles_per_ray_take_two_levels_once_something_moves() {
        let c = context(340_000, 700_000);
        assert_eq!(choose_structure(&c), SceneStructure::TwoLevel);
        let still = StructureContext { moved: false, ..c };
        assert_eq!(choose_structure(&still), SceneStructure::Flat);
        let everything_new = StructureContext {
            kept_triangles: 0,
            ..c
        };
        assert_eq!(choose_structure(&everything_new), SceneStructure::Flat);
        let first_frame = StructureContext { rays: 0, ..c };
        assert_eq!(choose_structure(&first_frame), SceneStructure::Flat);
    }

    #[test]
    fn few_kept_triangles_per_ray_stay_flat() {
        assert_eq!(
            choose_structure(&context(90_000, 2_800_000)),
            SceneStructure::Flat
        );
    }

    #[test]
    fn two_levels_are_kept_between_the_leave_and_the_entry_share() {
        // 0.06 triangles a ray: not enough to enter, enough to stay (and stay while still).
        let c = context(60_000, 1_000_000);
        assert_eq!(choose_structure(&c), SceneStructure::Flat);
        let on_two = StructureContext {
            current: Some(SceneStructure::TwoLevel),
            moved: false,
            ..c
        };
        assert_eq!(choose_structure(&on_two), SceneStructure::TwoLevel);
        let below = StructureContext {
            kept_triangles: 40_000,
            ..on_two
        };
        assert_eq!(choose_structure(&below), SceneStructure::Flat);
    }
}
