//! `antumbra bench --animation N`: renders N frames per build method (SAH, SBVH, OSAH with the
//! exact and the previous frame's visible set) and writes the per-frame curve.

use std::path::Path;

use antumbra_core::atomic_file::write_bytes_atomic;
use antumbra_core::build::BuildMethod;
use antumbra_core::render::{RenderSettings, Renderer, StatsMode, VisibilitySource};
use antumbra_core::scene::{ImageSize, Resolution};
use anyhow::Result;

use crate::scene_source::open_scene;
use antumbra_report::plots::LinePlot;

const CSV_HEADER: &str =
    "frame,method,primary_mrays,primary_nit,primary_nts,shadow_mrays,build_ms,visibility_ms,rebuilt\n";

/// Renders the first `frames` frames of `scene_name` (any scene `open_scene` opens) with each method and writes the per-frame primary
/// Mrays/s (and work) as `animation.csv` and `animation.svg`.
pub(super) fn animation_curve(
    scene_name: &str,
    triangles: usize,
    size: ImageSize,
    frames: i32,
    settings: &RenderSettings,
    out: &Path,
) -> Result<()> {
    std::fs::create_dir_all(out)?;
    let anim = open_scene(scene_name, triangles, None, frames)?;
    let configs = [
        ("SAH", BuildMethod::Sah, VisibilitySource::Previous),
        ("SBVH", BuildMethod::Sbvh, VisibilitySource::Previous),
        ("OSAH-exact", BuildMethod::Osah, VisibilitySource::Exact),
        (
            "OSAH-previous",
            BuildMethod::Osah,
            VisibilitySource::Previous,
        ),
    ];
    let mut csv = String::from(CSV_HEADER);
    let mut series = Vec::new();
    for (name, build, visibility) in configs {
        let s = RenderSettings {
            build: build.into(),
            visibility,
            stats: StatsMode::CountsAndTiming,
            ..settings.clone()
        };
        let mrays = render_curve(anim.as_ref(), frames, size, name, &s, &mut csv)?;
        let mean = mrays.iter().sum::<f64>() / mrays.len().max(1) as f64;
        println!(
            "{scene_name} {name}: mean primary {mean:.3} Mrays/s over {} frames",
            mrays.len()
        );
        series.push((format!("{name} ({mean:.2})"), mrays));
    }
    write_bytes_atomic(&out.join("animation.csv"), csv.as_bytes())?;
    LinePlot {
        ranges: None,
        title: &format!("{scene_name}: primary Mrays/s per frame"),
        y_label: "primary Mrays/s",
        first_frame: *anim.frame_range().start(),
        series: &series,
    }
    .write_svg(&out.join("animation.svg"), 900, 420)?;
    Ok(())
}

/// Renders the frames with `s`, adding a CSV line per frame; the primary Mrays/s per frame.
fn render_curve(
    anim: &dyn antumbra_core::scene::Animation,
    frames: i32,
    size: ImageSize,
    name: &str,
    s: &RenderSettings,
    csv: &mut String,
) -> Result<Vec<f64>> {
    let mut renderer = Renderer::new();
    let mut mrays = Vec::new();
    for f in anim.frame_range().take(frames as usize) {
        let mut scene = anim.frame(f);
        scene.resolution = Resolution::new(size.width, size.height);
        let r = renderer.render(anim.name(), &scene, s)?;
        let p = &r.stats[0];
        let shadow: Vec<f64> = r.stats[1..].iter().map(|x| x.mrays_per_s).collect();
        let shadow_mean = shadow.iter().sum::<f64>() / shadow.len().max(1) as f64;
        *csv += &format!(
            "{f},{name},{:.4},{:.4},{:.4},{:.4},{:.3},{:.3},{}\n",
            p.mrays_per_s,
            p.nt_per_ray,
            p.nts_per_ray,
            shadow_mean,
            p.build_ms,
            p.visibility_ms,
            p.rebuilt
        );
        mrays.push(p.mrays_per_s);
    }
    Ok(mrays)
}
