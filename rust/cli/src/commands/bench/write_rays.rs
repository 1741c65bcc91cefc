//! `antumbra bench --write-rays DIR`: each scene's frame as the two ray-file formats of
//! [`super::ray_files`] (its triangles, its camera rays, each light's shadow rays; render
//! space, tile order), so Embree's, tinybvh's or anyone's tools can trace antumbra's own rays.

use std::path::Path;

use antumbra_core::render::RenderSettings;
use anyhow::{Context, Result};

use super::frames::BenchScene;
use super::ray_files::{write_rays, write_triangles};
use super::rays::FrameState;
use super::tiles::TiledRays;
use super::BenchArgs;

/// Writes `SCENE_fFRAME.triangles.bin`, `SCENE_fFRAME.camera.rays.bin` and
/// `SCENE_fFRAME.lightN.rays.bin` per scene and frame into `dir`, and names each file.
pub(super) fn run(
    args: &BenchArgs,
    scenes: &[String],
    settings: &RenderSettings,
    dir: &Path,
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    for name in scenes {
        let scene = BenchScene::open(name, args.triangles, args.frames.as_deref(), 1)?;
        for &f in &scene.frames {
            let state = FrameState::prepare(scene.animation.as_ref(), f, args, settings)?;
            // A file's set is named by its stem (a path would escape DIR).
            let stem = Path::new(name)
                .file_stem()
                .map_or(name.clone(), |s| s.to_string_lossy().into_owned());
            let base = format!("{stem}_f{f}");
            let triangles = &state.trees().geometry().camera.vertices;
            let path = dir.join(format!("{base}.triangles.bin"));
            write_triangles(&path, triangles)?;
            println!("{} ({})", path.display(), triangles.len());
            let lights = state.lights.iter().enumerate().map(|(i, light)| {
                let name = format!("{base}.light{i}.rays.bin");
                (name, TiledRays::shadow(&state.pass, light))
            });
            let camera = (
                format!("{base}.camera.rays.bin"),
                TiledRays::camera(&state.camera),
            );
            for (file, rays) in std::iter::once(camera).chain(lights) {
                let path = dir.join(file);
                write_rays(&path, &rays.rays)?;
                println!("{} ({})", path.display(), rays.len());
            }
        }
    }
    Ok(())
}
