//! Where scenes come from: deterministic built-in animated scenes sized by a triangle budget, and
//! OBJ/glTF import as static scenes.
//!
//! Every built-in scene follows Blender's conventions (Z up, cameras look down local -Z, lights
//! emit along local -Z), keeps meshes that do not change between frames as the same `Arc`, and
//! only rebuilds moving or deforming parts per frame. See `scenes/README.md` for what each
//! scene exercises.

mod bedroom;
mod builder;
mod character_room;
mod city;
mod colonnade;
mod forest;
pub mod fuzzing;
mod hairball;
mod import;
mod indoors;
mod instanced_forest;
mod leaf_cards;
mod params;
mod primitives;
mod rng;
mod rotate;
mod shapes;
mod stage;
mod viewpoints;

use antumbra_core::scene::Animation;
use antumbra_core::{Error, Result};

pub use import::{load_file, load_file_with, load_gltf, load_obj, ImportLimits};
pub use leaf_cards::{fence_image, leaf_image};
pub use params::{SceneParams, MAX_INSTANCES, MAX_TRIANGLES};
pub use rotate::{rotate_scene, Rotated, ROTATED_SUFFIX};
pub use viewpoints::viewpoints;

/// The names [`builtin`] accepts (each also with the [`ROTATED_SUFFIX`], "-rot45").
pub const BUILTIN_SCENES: &[&str] = &[
    "bedroom",
    "colonnade",
    "city",
    "forest",
    "hairball",
    "indoors",
    "instanced-forest",
    "character-room",
    "leaf-cards",
];

/// The built-in scenes that take [`SceneParams::instances`].
pub const INSTANCED_SCENES: &[&str] = &["instanced-forest"];

/// A built-in animated scene by name. A name ending in "-rot45" (e.g. "city-rot45") is the
/// variant rotated by 45 degrees about the vertical axis, as is `params.rotated`.
pub fn builtin(name: &str, params: &SceneParams) -> Result<Box<dyn Animation>> {
    let (base, rotated) = match name.strip_suffix(ROTATED_SUFFIX) {
        Some(base) => (base, true),
        None => (name, params.rotated),
    };
    let make: fn(SceneParams) -> Box<dyn Animation> = match base {
        "bedroom" => |p| Box::new(bedroom::Bedroom::new(p)),
        "colonnade" => |p| Box::new(colonnade::Colonnade::new(p)),
        "city" => |p| Box::new(city::City::new(p)),
        "forest" => |p| Box::new(forest::Forest::new(p)),
        "hairball" => |p| Box::new(hairball::Hairball::new(p)),
        "indoors" => |p| Box::new(indoors::Indoors::new(p)),
        "instanced-forest" => |p| Box::new(instanced_forest::InstancedForest::new(p)),
        "character-room" => |p| Box::new(character_room::CharacterRoom::new(p)),
        "leaf-cards" => |p| Box::new(leaf_cards::LeafCards::new(p)),
        _ => {
            let known = BUILTIN_SCENES.join(", ");
            return Err(Error::invalid(
                "scene",
                format!(
                    "unknown scene '{name}' (known: {known}; each also with '{ROTATED_SUFFIX}')"
                ),
            ));
        }
    };
    if params.instances.is_some() && !INSTANCED_SCENES.contains(&base) {
        return Err(Error::invalid(
            "instances",
            format!(
                "scene '{name}' does not take an instance count (only {} do)",
                INSTANCED_SCENES.join(", ")
            ),
        ));
    }
    let anim = make(params.validated()?);
    Ok(if rotated {
        Box::new(Rotated::new(anim))
    } else {
        anim
    })
}

/// The actual triangle count of an animation: that of its first frame (every built-in scene
/// keeps the same count in all frames).
pub fn triangle_count(anim: &dyn Animation) -> usize {
    anim.frame(*anim.frame_range().start()).triangle_count()
}
