//! Renders one frame of a scene as a grey PNG: surfaces shaded by how squarely they face the
//! camera, times the combined shadow mask. For eyeballing the built-in scenes:
//! `cargo run --release -p antumbra-scenes --example preview -- city 100000 1 out.png`
//! (a name with "-rot45" gives the rotated variant; a path to an .obj/.gltf/.glb loads a file).

use std::path::Path;

use antumbra_core::image::ImagePlane;
use antumbra_core::output::write_mask_png;
use antumbra_core::render::{RenderSettings, Renderer, StatsMode};
use antumbra_scenes::{builtin, load_file, SceneParams};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("bedroom", String::as_str);
    let triangles = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(100_000);
    let frame = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(1);
    let out = args.get(3).map_or("preview.png", String::as_str);
    if let Err(e) = run(name, triangles, frame, Path::new(out)) {
        eprintln!("preview: {e}");
        std::process::exit(1);
    }
}

fn run(name: &str, triangles: usize, frame: i32, out: &Path) -> antumbra_core::Result<()> {
    let anim = if name.contains('.') {
        load_file(Path::new(name), 24)?
    } else {
        let params = SceneParams {
            triangles,
            ..SceneParams::default()
        };
        builtin(name, &params)?
    };
    let scene = anim.frame(frame);
    let settings = RenderSettings {
        spp: 8,
        stats: StatsMode::TimingOnly,
        ..RenderSettings::default()
    };
    let mut renderer = Renderer::new();
    let result = renderer.render(anim.name(), &scene, &settings)?;
    let Some((geometry, _, _)) = renderer.current() else {
        return Ok(());
    };
    let cam = geometry
        .space
        .point(scene.camera.world_from_camera.w_axis.truncate())
        .as_vec3();
    let mut image = ImagePlane::new("preview", result.width, result.height);
    for (i, hit) in result.primary_hits.iter().enumerate() {
        // The flat set's refs are in object, then primitive order.
        let id = geometry.camera.refs.binary_search(hit).ok();
        let Some(tri) = id.and_then(|id| geometry.camera.vertices.get(id)) else {
            image.data[i] = 0.15;
            continue;
        };
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
        let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
        let facing = n.dot((cam - centre).normalize_or_zero()).abs();
        image.data[i] = (0.25 + 0.75 * facing) * (0.2 + 0.8 * result.combined.data[i]);
    }
    write_mask_png(out, &image)?;
    println!(
        "{}: frame {frame}, {} triangles -> {}",
        anim.name(),
        scene.triangle_count(),
        out.display()
    );
    Ok(())
}
