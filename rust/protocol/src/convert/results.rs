//! Results both ways: a rendered frame (or a warm-up) as its reply, and a reply's images,
//! visible set and statistics back.

use antumbra_core::image::ImagePlane;
use antumbra_core::render::{FrameResult, WarmUp};
use antumbra_core::scene::TriangleRef;
use antumbra_core::stats::StatsRow;

use crate::bytes::{bytes_to_f32s, bytes_to_triangle_refs, f32s_to_bytes, triangle_refs_to_bytes};
use crate::error::ProtocolError;
use crate::messages::{FrameResultReply, Image, Passes};

pub(crate) fn image(plane: &ImagePlane, name: String) -> Image {
    Image {
        name,
        width: plane.width,
        height: plane.height,
        data: f32s_to_bytes(&plane.data),
    }
}

/// The reply for a rendered frame, with the requested passes. Image names follow the CLI's EXR
/// channels: `shadow.<light>` per mask, `combined`, `primary.N_B|N_L|N_T`,
/// `shadow.N_B|N_L|N_T`, then `primary.object` (the object-id pass), in that order.
pub fn frame_result_reply(
    result: &FrameResult,
    request_id: u64,
    passes: &Passes,
) -> FrameResultReply {
    let mut images = Vec::new();
    if passes.masks {
        let names = antumbra_core::output::mask_names(result);
        for (m, name) in result.masks.iter().zip(names) {
            images.push(image(m, name.plane));
        }
    }
    if passes.combined {
        images.push(image(&result.combined, result.combined.name.clone()));
    }
    if passes.heat_maps {
        if let Some(h) = &result.heat {
            for p in h.primary.iter().chain(h.shadow.iter()) {
                images.push(image(p, p.name.clone()));
            }
        }
    }
    if passes.object_ids {
        let plane = result.object_plane();
        images.push(image(&plane, plane.name.clone()));
    }
    FrameResultReply {
        request_id,
        frame: result.frame,
        width: result.width,
        height: result.height,
        images,
        stats: result.stats.clone(),
        visible: passes
            .visible_set
            .then(|| triangle_refs_to_bytes(&result.visible)),
    }
}

/// The reply to a warm-up (`RenderRequest::warm_up`): the frame's size, no images, no
/// statistics rows, and the visible set when `passes` asks for it.
pub fn warm_up_reply(warmed: &WarmUp, request_id: u64, passes: &Passes) -> FrameResultReply {
    FrameResultReply {
        request_id,
        frame: warmed.frame,
        width: warmed.width,
        height: warmed.height,
        images: Vec::new(),
        stats: Vec::new(),
        visible: passes
            .visible_set
            .then(|| triangle_refs_to_bytes(&warmed.visible)),
    }
}

/// The images of a result as core planes (named as on the wire), checking each one's size.
pub fn planes_from_reply(reply: &FrameResultReply) -> Result<Vec<ImagePlane>, ProtocolError> {
    reply
        .images
        .iter()
        .map(|img| plane_from_image(img, reply.frame))
        .collect()
}

/// One image of frame `frame`'s reply as a plane; data that does not fill its size is an error.
pub(crate) fn plane_from_image(img: &Image, frame: i32) -> Result<ImagePlane, ProtocolError> {
    let field = format!("frame {frame}: image '{}'.data", img.name);
    let data = bytes_to_f32s(&img.data, &field)?;
    let expected = img.width as u64 * img.height as u64;
    if data.len() as u64 != expected {
        return Err(ProtocolError::invalid(
            field,
            format!(
                "{}x{} needs {expected} values, has {}",
                img.width,
                img.height,
                data.len()
            ),
        ));
    }
    Ok(ImagePlane {
        name: img.name.clone(),
        width: img.width,
        height: img.height,
        data,
    })
}

/// The visible set of a result, if it was requested.
pub fn visible_from_reply(
    reply: &FrameResultReply,
) -> Result<Option<Vec<TriangleRef>>, ProtocolError> {
    reply
        .visible
        .as_ref()
        .map(|v| bytes_to_triangle_refs(v, &format!("frame {}: visible", reply.frame)))
        .transpose()
}

pub fn stats_from_reply(reply: &FrameResultReply) -> Vec<StatsRow> {
    reply.stats.clone()
}
