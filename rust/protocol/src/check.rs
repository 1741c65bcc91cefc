//! The request checks against the daemon's [`Limits`]: counts and sizes of a message, before
//! it is converted (whether a request may start, its work and memory, is [`crate::admission`]).

use std::collections::HashSet;

use antumbra_core::render::{RenderSettings, StatsMode};
use antumbra_core::scene::Scene;

use crate::error::ProtocolError;
use crate::limits::Limits;
use crate::messages::{FrameUpdate, Passes, Request, UploadImage};

fn check(
    what: impl FnOnce() -> String,
    value: u64,
    limit: u64,
    limit_name: &'static str,
) -> Result<(), ProtocolError> {
    if value > limit {
        Err(ProtocolError::LimitExceeded {
            what: what(),
            value,
            limit,
            limit_name,
        })
    } else {
        Ok(())
    }
}

/// Checks a request's counts and sizes against `limits` before any work is done on it: triangles
/// per upload, objects, lights and distinct meshes per frame, image size and samples per pixel.
/// Content (NaN, indices, hashes) is checked by the conversions.
pub fn check_limits(request: &Request, limits: &Limits) -> Result<(), ProtocolError> {
    match request {
        Request::MissingMeshes { hashes } => check(
            || "MissingMeshes: hashes".into(),
            hashes.len() as u64,
            limits.max_meshes,
            "max_meshes",
        ),
        Request::UploadMesh(upload) => {
            check(
                || format!("mesh '{}': triangles", upload.name),
                upload.triangles.len() as u64 / 12,
                limits.max_triangles_per_mesh,
                "max_triangles_per_mesh",
            )?;
            check(
                || format!("mesh '{}': uv_maps", upload.name),
                upload.uv_maps.len() as u64,
                limits.max_uv_maps,
                "max_uv_maps",
            )
        }
        Request::MissingImages { hashes } => check(
            || "MissingImages: hashes".into(),
            hashes.len() as u64,
            limits.max_alpha_materials,
            "max_alpha_materials",
        ),
        Request::UploadImage(upload) => check_image_texels(upload, limits),
        Request::FrameUpdate(update) => check_frame_limits(update, limits),
        Request::Render(render) => check_spp(
            || format!("Render frame {}: settings.spp", render.frame),
            &render.settings,
            limits,
        ),
        Request::Compare(c) => {
            check_spp(
                || format!("Compare frame {}: settings.spp", c.frame),
                &c.settings,
                limits,
            )?;
            for m in &c.methods {
                check_spp(
                    || format!("Compare frame {}: method '{}': spp", c.frame, m.label),
                    &m.settings,
                    limits,
                )?;
            }
            check_repeat(
                || format!("Compare frame {}: repeat", c.frame),
                c.repeat as u64,
            )
        }
        Request::Trade(t) => {
            check_spp(
                || format!("Trade frame {}: settings.spp", t.frame),
                &t.settings,
                limits,
            )?;
            check_repeat(
                || format!("Trade frame {}: repeat", t.frame),
                t.repeat as u64,
            )
        }
        Request::Hello { .. }
        | Request::Cancel { .. }
        | Request::Stats
        | Request::Close
        | Request::Shutdown => Ok(()),
    }
}

/// An image upload's size (as announced and as sent) against `max_image_texels`, before its
/// texels are decoded; the error names the image by its hash.
pub fn check_image_texels(upload: &UploadImage, limits: &Limits) -> Result<(), ProtocolError> {
    let announced = upload.width as u64 * upload.height as u64;
    check(
        || {
            format!(
                "image {:#018x} ({}x{}): texels",
                upload.hash, upload.width, upload.height
            )
        },
        announced.max(upload.texels.len() as u64 / 4),
        limits.max_image_texels,
        "max_image_texels",
    )
}

/// A frame's counts against the limits: objects (instances included), lights, distinct meshes,
/// pixels, alpha materials, their operations and the material slots every object (instance)
/// keeps. The daemon checks a frame again once its unchanged arrays are filled in.
pub fn check_frame_limits(update: &FrameUpdate, limits: &Limits) -> Result<(), ProtocolError> {
    let frame = update.frame;
    check(
        || format!("frame {frame}: alpha_materials"),
        update.alpha_materials.len() as u64,
        limits.max_alpha_materials,
        "max_alpha_materials",
    )?;
    for (i, m) in update.alpha_materials.iter().enumerate() {
        check(
            || format!("frame {frame}: alpha_materials[{i}] '{}': ops", m.name),
            m.ops.len() as u64,
            limits.max_alpha_ops,
            "max_alpha_ops",
        )?;
    }
    check(
        || format!("frame {frame}: material slots (every object's and instance's)"),
        crate::instances::material_slot_count(update),
        limits.max_material_slots,
        "max_material_slots",
    )?;
    check(
        || format!("frame {frame}: objects"),
        crate::instances::object_count(update),
        limits.max_objects,
        "max_objects",
    )?;
    check(
        || format!("frame {frame}: lights"),
        update.lights.len() as u64,
        limits.max_lights as u64,
        "max_lights",
    )?;
    let distinct: HashSet<u64> = crate::convert::frame_mesh_hashes(update).collect();
    check(
        || format!("frame {frame}: distinct meshes"),
        distinct.len() as u64,
        limits.max_meshes,
        "max_meshes",
    )?;
    let r = &update.resolution;
    // As Resolution::pixels, in u64 so that no input overflows.
    let scale = |v: u32| (v as u64 * r.percentage as u64 / 100).max(1);
    check(
        || {
            format!(
                "frame {frame}: resolution {}x{} at {}% (pixels)",
                r.x, r.y, r.percentage
            )
        },
        scale(r.x).saturating_mul(scale(r.y)),
        limits.max_image_pixels,
        "max_image_pixels",
    )
}

/// Timed passes a `Compare` (or `Trade`) may ask for per method (a fixed bound, not a configurable limit).
pub const MAX_COMPARE_REPEAT: u64 = 100;

/// Checks a repeat count (timed passes per method and frame) against [`MAX_COMPARE_REPEAT`];
/// `what` names the request and the field.
pub fn check_repeat(what: impl FnOnce() -> String, repeat: u64) -> Result<(), ProtocolError> {
    check(what, repeat, MAX_COMPARE_REPEAT, "max_compare_repeat")
}

fn check_spp(
    what: impl FnOnce() -> String,
    settings: &crate::messages::NamedSettings,
    limits: &Limits,
) -> Result<(), ProtocolError> {
    check(
        what,
        // A wrong type passes here and is named when the settings are resolved.
        settings.get("spp").map_or(
            antumbra_core::render::RenderSettings::default().spp as u64,
            |v| v.as_int().max(0) as u64,
        ),
        limits.max_spp as u64,
        "max_spp",
    )
}

/// The image planes a reply with `passes` copies out of a frame's result.
pub fn reply_planes(passes: &Passes, scene: &Scene, settings: &RenderSettings) -> u64 {
    let lights = scene.lights.iter().filter(|l| l.casts_shadow).count() as u64;
    let heat = settings.stats != StatsMode::TimingOnly;
    [
        (passes.masks, lights),
        (passes.combined, 1),
        (passes.heat_maps && heat, 6),
        (passes.object_ids, 1),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, n)| n)
    .sum()
}
