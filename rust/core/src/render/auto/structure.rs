//! `auto`'s structure for a scene with moving parts: two levels keep the static objects' tree
//! across frames and rebuild only what moves, but trace more slowly than the flat tree (an
//! instance entered is a transform and a second traversal). Which wins is the flat rebuild of
//! the static triangles against that extra trace, so the rule weighs the static triangles
//! against the rays a frame traces. It reads only counts that a warm-up sees as a render does
//! (the frames' objects and the last frame's camera hits), so a farm chunk chooses as one run.

use crate::render::SceneStructure;

/// Static triangles per traced ray from which two levels are taken when the geometry moves:
/// on the built-in scenes at one thread, two levels framed 0.49-0.54x the flat tree at 0.48
/// (character-room, 350k, 320x180) and 0.84x at 0.25 (bedroom, 350k), while at 0.07-0.12
/// (the default 100k at 640x360) they were even or up to 1.3x slower (forest), BENCHMARKS.md
/// "Flat and two levels".
pub const ENTER_TRIANGLES_PER_RAY: f64 = 0.2;

/// Two levels are kept down to this share: leaving them rebuilds every static triangle in a
/// flat tree, and a scene that hovers about the entry share would otherwise pay that often.
pub const LEAVE_TRIANGLES_PER_RAY: f64 = 0.1;

/// What the rule reads of a frame and the frames before it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StructureContext {
    /// Triangles of the objects that have not changed so far: the tree two levels keep.
    pub static_triangles: u64,
    /// Triangles of the objects that have changed in some frame: what two levels rebuild.
    pub dynamic_triangles: u64,
    /// Whether an object changed since the last frame (the flat tree is then rebuilt).
    pub moved: bool,
    /// The rays the last frame traced (camera rays and every light's samples at the surfaces
    /// it reaches), 0 before the first frame.
    pub rays: u64,
    /// The structure of the last frame, if `auto` chose it.
    pub current: Option<SceneStructure>,
}

/// Two levels where the objects that move are a part of the scene and the static rest is many
/// triangles per ray ([`ENTER_TRIANGLES_PER_RAY`] on a frame that moves, kept down to
/// [`LEAVE_TRIANGLES_PER_RAY`]); else the flat tree.
pub fn choose_structure(c: &StructureContext) -> SceneStructure {
    let per_ray = c.static_triangles as f64 / c.rays.max(1) as f64;
    let parts_move = c.dynamic_triangles > 0 && c.static_triangles > 0 && c.rays > 0;
    let two_level = parts_move
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

    fn context(static_triangles: u64, rays: u64) -> StructureContext {
        StructureContext {
            static_triangles,
            dynamic_triangles: 10_000,
            moved: true,
            rays,
            current: Some(SceneStructure::Flat),
        }
    }

    #[test]
    fn many_static_triangles_per_ray_take_two_levels_once_something_moves() {
        let c = context(340_000, 700_000);
        assert_eq!(choose_structure(&c), SceneStructure::TwoLevel);
        let still = StructureContext { moved: false, ..c };
        assert_eq!(choose_structure(&still), SceneStructure::Flat);
        let nothing_dynamic = StructureContext {
            dynamic_triangles: 0,
            ..c
        };
        assert_eq!(choose_structure(&nothing_dynamic), SceneStructure::Flat);
        let first_frame = StructureContext { rays: 0, ..c };
        assert_eq!(choose_structure(&first_frame), SceneStructure::Flat);
    }

    #[test]
    fn few_static_triangles_per_ray_stay_flat() {
        assert_eq!(
            choose_structure(&context(90_000, 2_800_000)),
            SceneStructure::Flat
        );
    }

    #[test]
    fn two_levels_are_kept_between_the_leave_and_the_entry_share() {
        // 0.15 triangles a ray: not enough to enter, enough to stay (and stay while still).
        let c = context(150_000, 1_000_000);
        assert_eq!(choose_structure(&c), SceneStructure::Flat);
        let on_two = StructureContext {
            current: Some(SceneStructure::TwoLevel),
            moved: false,
            ..c
        };
        assert_eq!(choose_structure(&on_two), SceneStructure::TwoLevel);
        let below = StructureContext {
            static_triangles: 90_000,
            ..on_two
        };
        assert_eq!(choose_structure(&below), SceneStructure::Flat);
    }
}
