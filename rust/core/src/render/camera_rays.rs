use glam::{DMat4, Vec3};

use super::tiles::{tiles, Tile};
use crate::geometry::Ray;
use crate::scene::{Camera, RenderSpace, Resolution, ViewPlane};

/// Generates the primary ray of each pixel (through its centre) in render space.
#[derive(Clone, Debug)]
pub struct PrimaryRays {
    pub width: u32,
    pub height: u32,
    plane: ViewPlane,
    render_from_camera: DMat4,
    origin: Vec3,
    t_min: f32,
    t_max: f32,
}

impl PrimaryRays {
    pub fn new(camera: &Camera, resolution: &Resolution, space: &RenderSpace) -> Self {
        let plane = camera.view_plane(resolution);
        let world_from_camera = camera.orthonormal_world_from_camera();
        let render_from_world = DMat4::from_scale(glam::DVec3::splat(space.scale))
            * DMat4::from_translation(-space.origin);
        let render_from_camera = render_from_world * world_from_camera;
        let origin = render_from_camera
            .transform_point3(glam::DVec3::ZERO)
            .as_vec3();
        // The camera-space direction has z = -1 and the render-space transform scales origin
        // offsets and directions alike, so the ray parameter stays the world depth: Blender's
        // clip range applies unchanged.
        PrimaryRays {
            width: plane.width,
            height: plane.height,
            plane,
            render_from_camera,
            origin,
            t_min: camera.clip_start as f32,
            t_max: camera.clip_end as f32,
        }
    }

    #[inline]
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let d = self.plane.camera_direction(x as f64 + 0.5, y as f64 + 0.5);
        let dir = self.render_from_camera.transform_vector3(d).as_vec3();
        Ray::new(self.origin, dir, self.t_min, self.t_max)
    }

    /// A tile's camera rays in the order the primary pass hands them to the tree.
    #[inline]
    pub fn tile_rays(&self, tile: Tile) -> impl Iterator<Item = Ray> + '_ {
        tile.pixels().map(|(x, y)| self.ray(x, y))
    }

    /// The primary pass's batches: each tile's camera rays ([`Self::tile_rays`]), for benchmarks
    /// that must batch rays as the pass does.
    pub fn batches(&self) -> Vec<Vec<Ray>> {
        tiles(self.width, self.height)
            .map(|tile| self.tile_rays(tile).collect())
            .collect()
    }
}
