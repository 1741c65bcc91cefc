//! The camera, the lights and the resolution, from their dicts.

use antumbra_protocol::{
    AreaShapeState, CameraState, LightKindState, LightState, ResolutionState, SensorFitState,
};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use super::fields::{choice, integer, Fields};
use super::objects::item_label;
use crate::error::{ClientError, ClientResult};

pub(super) const CAMERA_FIELDS: &[&str] = &[
    "matrix_world",
    "lens",
    "sensor_width",
    "sensor_height",
    "sensor_fit",
    "shift_x",
    "shift_y",
    "clip_start",
    "clip_end",
];

/// A camera dict with Blender's field names; unset fields take Blender's defaults for a new
/// camera (50 mm lens, 36 x 24 mm sensor, AUTO fit, no shift, clip 0.1 to 1000).
pub fn camera(v: &Bound<'_, PyAny>, owner: &str) -> ClientResult<CameraState> {
    let f = Fields::new(v, owner, CAMERA_FIELDS)?;
    let fit = f.string_or("sensor_fit", "AUTO")?;
    Ok(CameraState {
        world_from_camera: f.matrix("matrix_world")?,
        lens_mm: f.f64_or("lens", 50.0)?,
        sensor_width_mm: f.f64_or("sensor_width", 36.0)?,
        sensor_height_mm: f.f64_or("sensor_height", 24.0)?,
        sensor_fit: choice(
            &fit,
            &f.field("sensor_fit"),
            &[
                ("AUTO", SensorFitState::Auto),
                ("HORIZONTAL", SensorFitState::Horizontal),
                ("VERTICAL", SensorFitState::Vertical),
            ],
        )?,
        shift_x: f.f64_or("shift_x", 0.0)?,
        shift_y: f.f64_or("shift_y", 0.0)?,
        clip_start: f.f64_or("clip_start", 0.1)?,
        clip_end: f.f64_or("clip_end", 1000.0)?,
    })
}

pub(super) const LIGHT_FIELDS: &[&str] = &[
    "name",
    "matrix_world",
    "type",
    "shadow_soft_size",
    "angle",
    "spot_size",
    "spot_blend",
    "shape",
    "size",
    "size_y",
    "use_shadow",
];

/// Blender's default sun angle, 0.526 degrees.
pub(super) const DEFAULT_SUN_ANGLE: f64 = 0.526 * std::f64::consts::PI / 180.0;

pub(super) fn light(v: &Bound<'_, PyAny>, index: usize) -> ClientResult<LightState> {
    let f = Fields::new(v, item_label(v, "lights", index), LIGHT_FIELDS)?;
    let name = f.string("name")?;
    let world_from_light = f.matrix("matrix_world")?;
    let kind_name = f.string("type")?;
    #[derive(Clone, Copy)]
    enum Kind {
        Point,
        Sun,
        Spot,
        Area,
    }
    let kind = choice(
        &kind_name,
        &f.field("type"),
        &[
            ("POINT", Kind::Point),
            ("SUN", Kind::Sun),
            ("SPOT", Kind::Spot),
            ("AREA", Kind::Area),
        ],
    )?;
    let radius = || f.f64_or("shadow_soft_size", 0.25);
    let kind = match kind {
        Kind::Point => LightKindState::Point { radius: radius()? },
        Kind::Sun => LightKindState::Sun {
            angle: f.f64_or("angle", DEFAULT_SUN_ANGLE)?,
        },
        Kind::Spot => LightKindState::Spot {
            radius: radius()?,
            spot_size: f.f64_or("spot_size", std::f64::consts::FRAC_PI_4)?,
            spot_blend: f.f64_or("spot_blend", 0.15)?,
        },
        Kind::Area => {
            let shape_name = f.string_or("shape", "SQUARE")?;
            let shape = choice(
                &shape_name,
                &f.field("shape"),
                &[
                    ("SQUARE", AreaShapeState::Square),
                    ("RECTANGLE", AreaShapeState::Rectangle),
                    ("DISK", AreaShapeState::Disk),
                    ("ELLIPSE", AreaShapeState::Ellipse),
                ],
            )?;
            let size_x = f.f64_or("size", 0.25)?;
            let size_y = match shape {
                AreaShapeState::Square | AreaShapeState::Disk => size_x,
                AreaShapeState::Rectangle | AreaShapeState::Ellipse => f.f64_or("size_y", 0.25)?,
            };
            LightKindState::Area {
                shape,
                size_x,
                size_y,
            }
        }
    };
    Ok(LightState {
        name,
        world_from_light,
        kind,
        casts_shadow: f.bool_or("use_shadow", true)?,
    })
}

pub(super) const RESOLUTION_FIELDS: &[&str] = &[
    "x",
    "y",
    "percentage",
    "resolution_x",
    "resolution_y",
    "resolution_percentage",
    "pixel_aspect_x",
    "pixel_aspect_y",
];

/// A resolution: a dict (`x`, `y`, `percentage`, `pixel_aspect_x`, `pixel_aspect_y`; Blender's
/// `resolution_x`, `resolution_y`, `resolution_percentage` are accepted too) or an `(x, y)` pair.
pub fn resolution(v: &Bound<'_, PyAny>) -> ClientResult<ResolutionState> {
    let dimension = |v: &Bound<'_, PyAny>, field: &str| -> ClientResult<u32> {
        integer::<u32>(v, field, "a positive 32-bit size")
    };
    if let Ok(t) = v.cast::<PyTuple>() {
        if t.len() != 2 {
            return Err(ClientError::invalid(format!(
                "resolution: expected a dict or an (x, y) pair, got a tuple of {} items",
                t.len()
            )));
        }
        return Ok(ResolutionState {
            x: dimension(&t.get_item(0)?, "resolution.x")?,
            y: dimension(&t.get_item(1)?, "resolution.y")?,
            percentage: 100,
            pixel_aspect_x: 1.0,
            pixel_aspect_y: 1.0,
        });
    }
    let f = Fields::new(v, "resolution", RESOLUTION_FIELDS)?;
    let either = |a: &str, b: &str| -> ClientResult<Option<(Bound<'_, PyAny>, String)>> {
        match (f.get(a)?, f.get(b)?) {
            (Some(_), Some(_)) => Err(ClientError::invalid(format!(
                "resolution: give either {a} or {b}, not both"
            ))),
            (Some(v), None) => Ok(Some((v, f.field(a)))),
            (None, Some(v)) => Ok(Some((v, f.field(b)))),
            (None, None) => Ok(None),
        }
    };
    let dim = |a: &str, b: &str| -> ClientResult<u32> {
        let (v, field) = either(a, b)?
            .ok_or_else(|| ClientError::invalid(format!("resolution.{a}: missing")))?;
        dimension(&v, &field)
    };
    let percentage = match either("percentage", "resolution_percentage")? {
        None => 100,
        Some((v, field)) => integer::<u32>(&v, &field, "a percentage")?,
    };
    Ok(ResolutionState {
        x: dim("x", "resolution_x")?,
        y: dim("y", "resolution_y")?,
        percentage,
        pixel_aspect_x: f.f64_or("pixel_aspect_x", 1.0)?,
        pixel_aspect_y: f.f64_or("pixel_aspect_y", 1.0)?,
    })
}
