//! One frame of a built-in scene rendered with named settings, for callgrind: the instructions
//! of the frame's shadow passes (`--toggle-collect='*shadow_passes*'`) over the shadow rays it
//! prints are a method's cost per shadow ray. BENCHMARKS.md ("Alpha") has the command.
//!
//! `shadow_cost SCENE TRIANGLES FRAME WxH [name=value ...]` (values as the CLI's flags take
//! them, e.g. `width=8 order=fbto alpha=false`).

use antumbra_core::render::Renderer;
use antumbra_core::scene::Resolution;
use antumbra_core::settings::{setting, NamedSettings};
use antumbra_scenes::{builtin, SceneParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, triangles, frame, size, named @ ..] = args.as_slice() else {
        return Err("usage: shadow_cost SCENE TRIANGLES FRAME WxH [name=value ...]".into());
    };
    let params = SceneParams {
        triangles: triangles.parse()?,
        frames: frame.parse()?,
        ..SceneParams::default()
    };
    let mut scene = builtin(scene, &params)?.frame(frame.parse()?);
    let (w, h) = size.split_once('x').ok_or("size is WxH")?;
    scene.resolution = Resolution::new(w.parse()?, h.parse()?);
    let mut settings = NamedSettings::new();
    for pair in named {
        let (name, value) = pair.split_once('=').ok_or("settings are name=value")?;
        let spec = setting(name).ok_or_else(|| format!("unknown setting '{name}'"))?;
        settings.insert(name, spec.parse(value)?);
    }
    let settings = settings.resolve()?;
    let result = Renderer::new().render("shadow_cost", &scene, &settings)?;
    for row in &result.stats {
        println!(
            "{} {}: {} rays, nb {:.3} nt {:.3}",
            row.pass, row.light, row.rays, row.nb_per_ray, row.nt_per_ray
        );
    }
    let rays: u64 = (result.stats.iter())
        .filter(|r| r.pass == "shadow")
        .map(|r| r.rays)
        .sum();
    println!("shadow rays {rays}");
    Ok(())
}
