//! The positional arguments the example programs share, `SCENE [TRIS] [WxH]` (each program with
//! its own defaults), the first frame of that scene they all start from, and its SAH trees.

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::bvh::Bvh;
use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{PrimaryPass, PrimaryRays};
use antumbra_core::scene::{FrameGeometry, ImageSize, Resolution, Scene};
use antumbra_core::trace::NoStats;
use anyhow::Result;
use clap::Args;

#[derive(Args, Debug, Clone)]
pub struct FrameArgs {
    /// Built-in scene ("-rot45" for the rotated variant).
    pub scene: Option<String>,
    /// Triangle budget of the scene.
    pub triangles: Option<usize>,
    /// Image size WxH of the camera rays.
    #[arg(value_name = "WxH", value_parser = ImageSize::parse_image)]
    pub size: Option<ImageSize>,
}

/// What a program takes when an argument is left out.
pub struct FrameDefaults {
    pub scene: &'static str,
    pub triangles: usize,
    pub size: ImageSize,
}

/// The first frame of a built-in scene at the size asked for, and its geometry.
pub struct ExampleFrame {
    pub name: String,
    pub size: ImageSize,
    pub scene: Scene,
    pub geometry: FrameGeometry,
}

impl FrameArgs {
    pub fn open(&self, defaults: FrameDefaults) -> Result<ExampleFrame> {
        let name = self.scene.as_deref().unwrap_or(defaults.scene).to_string();
        let size = self.size.unwrap_or(defaults.size);
        let params = antumbra_scenes::SceneParams {
            triangles: self.triangles.unwrap_or(defaults.triangles),
            frames: 1,
            rotated: name.ends_with("-rot45"),
            instances: None,
        };
        let anim = antumbra_scenes::builtin(name.trim_end_matches("-rot45"), &params)?;
        // Its only frame, taken from the scene (then dropped) rather than copied out of it.
        let first = *anim.frame_range().start();
        let mut scene = anim.into_frame(first);
        scene.resolution = Resolution::new(size.width, size.height);
        let geometry = FrameGeometry::from_scene(&scene)?;
        Ok(ExampleFrame {
            name,
            size,
            scene,
            geometry,
        })
    }
}

/// The binned-SAH trees of a frame (camera set and shadow set) and its primary pass: where the
/// profiling programs start.
pub struct SahFrame {
    pub bvh: Bvh,
    pub shadow_bvh: Bvh,
    pub camera: PrimaryRays,
    pub pass: PrimaryPass,
}

impl ExampleFrame {
    pub fn sah(&self) -> SahFrame {
        let g = &self.geometry;
        let bvh = build_binned_sah(&g.camera.vertices, &BuildSettings::default());
        let shadow_tris = g
            .shadow
            .as_ref()
            .map_or(&g.camera.vertices, |s| &s.vertices);
        let shadow_bvh = build_binned_sah(shadow_tris, &BuildSettings::default());
        let camera = PrimaryRays::new(&self.scene.camera, &self.scene.resolution, &g.space);
        let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
            .expect("a new token is never cancelled");
        SahFrame {
            bvh,
            shadow_bvh,
            camera,
            pass,
        }
    }
}
