//! Fixed cameras for the OSAH comparison tables, after the paper's four viewpoints per scene:
//! an outside view of a detail, an outside overview and two views from inside. The rotated
//! variants get the same cameras rotated with the scene.

use antumbra_core::scene::Camera;
use antumbra_core::Result;
use glam::DVec3;

use crate::city::street;
use crate::stage::camera;
use crate::{builtin, Rotated, SceneParams, ROTATED_SUFFIX};

/// Named cameras for a built-in scene (four for bedroom and city; the animation's first and
/// last camera for the others).
pub fn viewpoints(name: &str, params: &SceneParams) -> Result<Vec<(String, Camera)>> {
    let (base, rotated) = match name.strip_suffix(ROTATED_SUFFIX) {
        Some(base) => (base, true),
        None => (name, params.rotated),
    };
    let anim = builtin(
        base,
        &SceneParams {
            rotated: false,
            ..params.clone()
        },
    )?;
    let range = anim.frame_range();
    let first = anim.frame(*range.start()).camera;
    let last = anim.frame(*range.end()).camera;
    let mut cams: Vec<(&str, Camera)> = match base {
        "bedroom" => vec![
            (
                "outside-detail",
                camera(
                    DVec3::new(-4.5, -0.6, 1.4),
                    DVec3::new(0.0, 0.3, 1.3),
                    50.0,
                    (0.05, 50.0),
                ),
            ),
            (
                "outside-overview",
                camera(
                    DVec3::new(-9.0, -7.0, 5.5),
                    DVec3::new(0.0, 0.0, 1.2),
                    30.0,
                    (0.05, 50.0),
                ),
            ),
            ("inside-a", first),
            ("inside-b", last),
        ],
        "city" => {
            // The fly-over camera starts at y = -0.8 x the city's extent.
            let e = -first.position().y / 0.8;
            let s = |i| street(i, e);
            let eye_level = 1.7;
            vec![
                ("outside-detail", first.clone().with_lens(90.0)),
                ("outside-overview", first),
                (
                    "street-a",
                    camera(
                        DVec3::new(s(1), s(0) + 2.0, eye_level),
                        DVec3::new(s(1), s(3), eye_level),
                        24.0,
                        (0.1, 4.0 * e),
                    ),
                ),
                (
                    "street-b",
                    camera(
                        DVec3::new(s(2), s(2), eye_level),
                        DVec3::new(s(0), s(2) + 20.0, eye_level + 5.0),
                        24.0,
                        (0.1, 4.0 * e),
                    ),
                ),
            ]
        }
        _ => vec![("first", first), ("last", last)],
    };
    if rotated {
        for (_, c) in &mut cams {
            c.world_from_camera = Rotated::rotation() * c.world_from_camera;
        }
    }
    Ok(cams.into_iter().map(|(n, c)| (n.to_string(), c)).collect())
}
