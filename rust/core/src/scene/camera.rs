use glam::{DMat4, DVec3};
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Which sensor dimension the focal length refers to (Blender's `sensor_fit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum SensorFit {
    /// The larger image dimension uses `sensor_width`.
    #[default]
    Auto,
    Horizontal,
    Vertical,
}

/// Output size as Blender's render settings give it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Resolution {
    pub x: u32,
    pub y: u32,
    /// `resolution_percentage`: the image is `x * percentage / 100` wide.
    pub percentage: u32,
    pub pixel_aspect_x: f64,
    pub pixel_aspect_y: f64,
}

impl Resolution {
    pub fn new(x: u32, y: u32) -> Self {
        Resolution {
            x,
            y,
            percentage: 100,
            pixel_aspect_x: 1.0,
            pixel_aspect_y: 1.0,
        }
    }

    /// The size in pixels of the image that is rendered.
    pub fn pixels(&self) -> (u32, u32) {
        let scale = |v: u32| ((v as u64 * self.percentage as u64) / 100).max(1) as u32;
        (scale(self.x), scale(self.y))
    }

    pub fn validate(&self) -> Result<()> {
        if self.x == 0 || self.y == 0 || self.percentage == 0 {
            return Err(Error::invalid(
                "resolution",
                format!(
                    "must be positive, got {}x{} at {}%",
                    self.x, self.y, self.percentage
                ),
            ));
        }
        for (field, v) in [
            ("resolution.pixel_aspect_x", self.pixel_aspect_x),
            ("resolution.pixel_aspect_y", self.pixel_aspect_y),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    field,
                    format!("must be a positive number, got {v}"),
                ));
            }
        }
        Ok(())
    }
}

/// A perspective camera with Blender's model: it looks down its local -Z axis with +Y up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub world_from_camera: DMat4,
    /// Focal length in millimetres (`lens`).
    pub lens_mm: f64,
    pub sensor_width_mm: f64,
    pub sensor_height_mm: f64,
    pub sensor_fit: SensorFit,
    /// Lens shift in units of the fitted sensor dimension, as Blender's `shift_x`/`shift_y`.
    pub shift_x: f64,
    pub shift_y: f64,
    /// Clip distances measured along the view axis (depth), as Blender's `clip_start`/`clip_end`.
    pub clip_start: f64,
    pub clip_end: f64,
}

/// The view plane of a camera at depth 1 for one resolution: everything the primary-ray
/// generator needs, computed once per frame.
#[derive(Clone, Copy, Debug)]
pub struct ViewPlane {
    pub width: u32,
    pub height: u32,
    pub x_min: f64,
    pub x_max: f64,
    pub y_min: f64,
    pub y_max: f64,
}

impl Camera {
    /// A camera at `eye` looking at `target` with Blender's defaults (50 mm lens, 36 mm sensor).
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3) -> Self {
        // look_at_rh gives camera-from-world with the camera looking down -Z, as Blender's camera.
        let world_from_camera = DMat4::look_at_rh(eye, target, up).inverse();
        Camera {
            world_from_camera,
            lens_mm: 50.0,
            sensor_width_mm: 36.0,
            sensor_height_mm: 24.0,
            sensor_fit: SensorFit::Auto,
            shift_x: 0.0,
            shift_y: 0.0,
            clip_start: 0.1,
            clip_end: 1000.0,
        }
    }

    pub fn with_lens(mut self, lens_mm: f64) -> Self {
        self.lens_mm = lens_mm;
        self
    }

    pub fn position(&self) -> DVec3 {
        self.world_from_camera.w_axis.truncate()
    }

    pub fn validate(&self) -> Result<()> {
        for (field, v) in [
            ("camera.lens", self.lens_mm),
            ("camera.sensor_width", self.sensor_width_mm),
            ("camera.sensor_height", self.sensor_height_mm),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    field,
                    format!("must be a positive number, got {v}"),
                ));
            }
        }
        for (field, v) in [
            ("camera.shift_x", self.shift_x),
            ("camera.shift_y", self.shift_y),
        ] {
            if !v.is_finite() {
                return Err(Error::invalid(field, format!("must be finite, got {v}")));
            }
        }
        if !(self.clip_start.is_finite()
            && self.clip_start >= 0.0
            && self.clip_end > self.clip_start)
        {
            return Err(Error::invalid(
                "camera.clip_start/clip_end",
                format!(
                    "need 0 <= clip_start < clip_end, got {} and {}",
                    self.clip_start, self.clip_end
                ),
            ));
        }
        if let Some(i) = self
            .world_from_camera
            .to_cols_array()
            .iter()
            .position(|v| !v.is_finite())
        {
            return Err(Error::NonFinite {
                owner: "the camera".into(),
                what: "world matrix",
                index: i,
                value: self.world_from_camera.to_cols_array()[i],
            });
        }
        Ok(())
    }

    /// The view plane at depth 1, following Blender's `BKE_camera_params_compute_viewplane`.
    pub fn view_plane(&self, resolution: &Resolution) -> ViewPlane {
        let (width, height) = resolution.pixels();
        let (win_x, win_y) = (width as f64, height as f64);
        let (asp_x, asp_y) = (resolution.pixel_aspect_x, resolution.pixel_aspect_y);
        let fit = match self.sensor_fit {
            SensorFit::Auto if asp_x * win_x >= asp_y * win_y => SensorFit::Horizontal,
            SensorFit::Auto => SensorFit::Vertical,
            other => other,
        };
        let sensor_size = if self.sensor_fit == SensorFit::Vertical {
            self.sensor_height_mm
        } else {
            self.sensor_width_mm
        };
        let y_cor = asp_y / asp_x;
        let view_fac = if fit == SensorFit::Horizontal {
            win_x
        } else {
            y_cor * win_y
        };
        let pix_size = sensor_size / self.lens_mm / view_fac;
        let dx = self.shift_x * view_fac;
        let dy = self.shift_y * view_fac;
        ViewPlane {
            width,
            height,
            x_min: (-0.5 * win_x + dx) * pix_size,
            x_max: (0.5 * win_x + dx) * pix_size,
            y_min: (-0.5 * y_cor * win_y + dy) * pix_size,
            y_max: (0.5 * y_cor * win_y + dy) * pix_size,
        }
    }

    /// The camera's rotation and position without scale, as Blender normalises the camera matrix.
    pub fn orthonormal_world_from_camera(&self) -> DMat4 {
        let m = self.world_from_camera;
        let x = m.x_axis.truncate().normalize();
        let y = m.y_axis.truncate().normalize();
        let z = m.z_axis.truncate().normalize();
        DMat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), m.w_axis)
    }
}

impl ViewPlane {
    /// Direction in camera space through image position (`px`, `py`) given in pixels from the
    /// top-left corner. Its z component is -1, so a ray parameter equals depth along the view
    /// axis and Blender's clip range applies to it directly.
    pub fn camera_direction(&self, px: f64, py: f64) -> DVec3 {
        let x = self.x_min + px / self.width as f64 * (self.x_max - self.x_min);
        let y = self.y_max - py / self.height as f64 * (self.y_max - self.y_min);
        DVec3::new(x, y, -1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn horizontal_field_of_view_matches_blender_default() {
        // 50 mm lens on a 36 mm sensor: half-width at depth 1 is 18/50.
        let cam = Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y);
        let vp = cam.view_plane(&Resolution::new(1920, 1080));
        assert!((vp.x_max - 0.36).abs() < 1e-12);
        assert!((vp.y_max - 0.36 * 1080.0 / 1920.0).abs() < 1e-12);
    }

    #[test]
    fn auto_fit_uses_sensor_width_on_the_longer_side() {
        let cam = Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y);
        let vp = cam.view_plane(&Resolution::new(1080, 1920));
        assert!((vp.y_max - 0.36).abs() < 1e-12);
        assert!((vp.x_max - 0.36 * 1080.0 / 1920.0).abs() < 1e-12);
    }

    #[test]
    fn shift_moves_the_plane_by_the_fitted_dimension() {
        let mut cam = Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y);
        cam.shift_x = 0.5;
        cam.shift_y = 0.25;
        let vp = cam.view_plane(&Resolution::new(200, 100));
        assert!((vp.x_min - 0.0).abs() < 1e-12 && (vp.x_max - 0.72).abs() < 1e-12);
        // Shift is in units of the fitted (horizontal, 0.72 wide) dimension: 0.25 * 0.72 = 0.18.
        assert!((vp.y_min - (-0.18 + 0.18)).abs() < 1e-12, "{}", vp.y_min);
    }

    #[test]
    fn vertical_fit_uses_sensor_height() {
        let mut cam = Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y);
        cam.sensor_fit = SensorFit::Vertical;
        let vp = cam.view_plane(&Resolution::new(200, 100));
        assert!((vp.y_max - 0.24).abs() < 1e-12);
        assert!((vp.x_max - 0.48).abs() < 1e-12);
    }

    #[test]
    fn percentage_and_pixel_aspect() {
        let mut res = Resolution::new(200, 100);
        res.percentage = 50;
        assert_eq!(res.pixels(), (100, 50));
        res.pixel_aspect_y = 2.0;
        let cam = Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y);
        let vp = cam.view_plane(&res);
        // 100 x (50*2) logical: horizontal fit still (100 >= 100), so height doubles.
        assert!((vp.x_max - 0.36).abs() < 1e-12);
        assert!((vp.y_max - 0.36).abs() < 1e-12);
    }
}
