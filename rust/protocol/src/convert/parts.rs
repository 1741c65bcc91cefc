//! Scene parts both ways: camera, sensor fit, lights and their kinds, resolution.

use antumbra_core::scene::{AreaShape, Camera, Light, LightKind, Resolution, SensorFit};
use glam::DMat4;

use crate::messages::{
    AreaShapeState, CameraState, LightKindState, LightState, ResolutionState, SensorFitState,
};

impl From<SensorFit> for SensorFitState {
    fn from(f: SensorFit) -> Self {
        match f {
            SensorFit::Auto => SensorFitState::Auto,
            SensorFit::Horizontal => SensorFitState::Horizontal,
            SensorFit::Vertical => SensorFitState::Vertical,
        }
    }
}

impl From<SensorFitState> for SensorFit {
    fn from(f: SensorFitState) -> Self {
        match f {
            SensorFitState::Auto => SensorFit::Auto,
            SensorFitState::Horizontal => SensorFit::Horizontal,
            SensorFitState::Vertical => SensorFit::Vertical,
        }
    }
}

impl From<&Camera> for CameraState {
    fn from(c: &Camera) -> Self {
        CameraState {
            world_from_camera: c.world_from_camera.to_cols_array(),
            lens_mm: c.lens_mm,
            sensor_width_mm: c.sensor_width_mm,
            sensor_height_mm: c.sensor_height_mm,
            sensor_fit: c.sensor_fit.into(),
            shift_x: c.shift_x,
            shift_y: c.shift_y,
            clip_start: c.clip_start,
            clip_end: c.clip_end,
        }
    }
}

impl From<&CameraState> for Camera {
    fn from(c: &CameraState) -> Self {
        Camera {
            world_from_camera: DMat4::from_cols_array(&c.world_from_camera),
            lens_mm: c.lens_mm,
            sensor_width_mm: c.sensor_width_mm,
            sensor_height_mm: c.sensor_height_mm,
            sensor_fit: c.sensor_fit.into(),
            shift_x: c.shift_x,
            shift_y: c.shift_y,
            clip_start: c.clip_start,
            clip_end: c.clip_end,
        }
    }
}

impl From<AreaShape> for AreaShapeState {
    fn from(s: AreaShape) -> Self {
        match s {
            AreaShape::Square => AreaShapeState::Square,
            AreaShape::Rectangle => AreaShapeState::Rectangle,
            AreaShape::Disk => AreaShapeState::Disk,
            AreaShape::Ellipse => AreaShapeState::Ellipse,
        }
    }
}

impl From<AreaShapeState> for AreaShape {
    fn from(s: AreaShapeState) -> Self {
        match s {
            AreaShapeState::Square => AreaShape::Square,
            AreaShapeState::Rectangle => AreaShape::Rectangle,
            AreaShapeState::Disk => AreaShape::Disk,
            AreaShapeState::Ellipse => AreaShape::Ellipse,
        }
    }
}

impl From<LightKind> for LightKindState {
    fn from(k: LightKind) -> Self {
        match k {
            LightKind::Point { radius } => LightKindState::Point { radius },
            LightKind::Sun { angle } => LightKindState::Sun { angle },
            LightKind::Spot {
                radius,
                spot_size,
                spot_blend,
            } => LightKindState::Spot {
                radius,
                spot_size,
                spot_blend,
            },
            LightKind::Area {
                shape,
                size_x,
                size_y,
            } => LightKindState::Area {
                shape: shape.into(),
                size_x,
                size_y,
            },
        }
    }
}

impl From<LightKindState> for LightKind {
    fn from(k: LightKindState) -> Self {
        match k {
            LightKindState::Point { radius } => LightKind::Point { radius },
            LightKindState::Sun { angle } => LightKind::Sun { angle },
            LightKindState::Spot {
                radius,
                spot_size,
                spot_blend,
            } => LightKind::Spot {
                radius,
                spot_size,
                spot_blend,
            },
            LightKindState::Area {
                shape,
                size_x,
                size_y,
            } => LightKind::Area {
                shape: shape.into(),
                size_x,
                size_y,
            },
        }
    }
}

impl From<&Light> for LightState {
    fn from(l: &Light) -> Self {
        LightState {
            name: l.name.clone(),
            world_from_light: l.world_from_light.to_cols_array(),
            kind: l.kind.into(),
            casts_shadow: l.casts_shadow,
        }
    }
}

impl From<&LightState> for Light {
    fn from(l: &LightState) -> Self {
        Light {
            name: l.name.clone(),
            world_from_light: DMat4::from_cols_array(&l.world_from_light),
            kind: l.kind.into(),
            casts_shadow: l.casts_shadow,
        }
    }
}

impl From<&Resolution> for ResolutionState {
    fn from(r: &Resolution) -> Self {
        ResolutionState {
            x: r.x,
            y: r.y,
            percentage: r.percentage,
            pixel_aspect_x: r.pixel_aspect_x,
            pixel_aspect_y: r.pixel_aspect_y,
        }
    }
}

impl From<&ResolutionState> for Resolution {
    fn from(r: &ResolutionState) -> Self {
        Resolution {
            x: r.x,
            y: r.y,
            percentage: r.percentage,
            pixel_aspect_x: r.pixel_aspect_x,
            pixel_aspect_y: r.pixel_aspect_y,
        }
    }
}
