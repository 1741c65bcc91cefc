//! The shadow passes of one frame of a built-in scene, for callgrind: the frame is rendered once
//! (trees, camera hits), then each light's shadow pass is traced again, counters compiled out
//! (`NoStats`), inside `shadow_measured` on one thread, so
//! `--toggle-collect='*shadow_measured*'` over the printed ray count is the instructions per
//! shadow ray (`*camera_measured*`: the camera pass, one ray per pixel). BENCHMARKS.md
//! ("Alpha") has the commands.
//!
//! `shadow_cost SCENE TRIANGLES FRAME WxH [name=value ...]` (values as the CLI's flags take
//! them, e.g. `width=8 order=fbto alpha=false`; `order` must be fixed).

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{
    samples_for, FrameTrees, LightRays, LightSampler, PrimaryPass, PrimaryRays, RenderSettings,
    Renderer, SamplePlan, ShadowPass,
};
use antumbra_core::scene::{Resolution, Scene};
use antumbra_core::settings::{setting, NamedSettings};
use antumbra_core::trace::{NoStats, RayMode};
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
    let mut renderer = Renderer::new();
    let result = renderer.render("shadow_cost", &scene, &settings)?;
    for row in &result.stats {
        println!(
            "{} {}: {} rays, nb {:.3} nl {:.3} nt {:.3}",
            row.pass, row.light, row.rays, row.nb_per_ray, row.nl_per_ray, row.nt_per_ray
        );
    }
    let trees = renderer.trees().ok_or("a flat frame")?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let rays = pool
        .install(|| measured_shadow_passes(&scene, &settings, trees))
        .map_err(|e| e.to_string())?;
    println!("shadow rays {rays}");
    Ok(())
}

/// What callgrind counts of a shadow pass: `f`, on the calling thread.
#[inline(never)]
fn shadow_measured<T>(f: impl FnOnce() -> T) -> T {
    f()
}

/// What callgrind counts of the camera pass.
#[inline(never)]
fn camera_measured<T>(f: impl FnOnce() -> T) -> T {
    f()
}

/// The camera pass as the frame traced it, then every light's shadow pass; returns the shadow
/// rays traced.
fn measured_shadow_passes(
    scene: &Scene,
    settings: &RenderSettings,
    trees: &FrameTrees,
) -> Result<u64, Box<dyn std::error::Error + Send + Sync>> {
    let geometry = trees.geometry();
    let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
    let primary = camera_measured(|| primary_pass(scene, settings, trees, &camera))?;
    let order = *settings.shadow_order.fixed().ok_or("a fixed order")?;
    let mut rays = 0;
    let lights = scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.casts_shadow);
    for (index, light) in lights {
        let sampler = LightSampler::new(light, &geometry.space);
        let plan = SamplePlan {
            light_index: index as u32,
            samples: samples_for(&sampler, settings.spp),
            seed: settings.seed,
        };
        let light_rays = LightRays {
            primary: &primary,
            sampler: &sampler,
            plan,
            sah: &settings.build_settings,
            objects: &scene.objects,
            first: true,
        };
        let tracing = trees.for_light(&order, settings.width, &light_rays);
        let tracer = tracing.tracer(RayMode::Single);
        let pass = shadow_pass(scene, settings, trees, &primary, &tracer, &sampler, plan)?;
        rays += pass.outcome.rays;
    }
    Ok(rays)
}

/// The frame's camera hits (through alpha when the frame has it).
fn primary_pass(
    scene: &Scene,
    settings: &RenderSettings,
    trees: &FrameTrees,
    camera: &PrimaryRays,
) -> antumbra_core::Result<PrimaryPass> {
    let cancel = CancelToken::new();
    let geometry = trees.geometry();
    // ALPHA-BEGIN
    if settings.alpha_active(scene) {
        let alpha = antumbra_core::render::alpha_scene(scene, &geometry.camera)?;
        let tree = antumbra_core::render::AlphaCamera {
            tree: trees.camera_bvh(),
            alpha: &alpha,
            clip: settings.alpha_clip,
        };
        return PrimaryPass::trace::<NoStats>(camera, &tree, &geometry.camera, &cancel);
    }
    // ALPHA-END
    let _ = (scene, settings);
    PrimaryPass::trace::<NoStats>(camera, trees.camera_bvh(), &geometry.camera, &cancel)
}

/// One light's pass: transmission through alpha when the frame has it, else today's pass.
fn shadow_pass(
    scene: &Scene,
    settings: &RenderSettings,
    trees: &FrameTrees,
    primary: &PrimaryPass,
    tracer: &antumbra_core::render::ShadowTracer,
    sampler: &LightSampler,
    plan: SamplePlan,
) -> Result<ShadowPass, Box<dyn std::error::Error + Send + Sync>> {
    let cancel = CancelToken::new();
    // ALPHA-BEGIN
    if settings.alpha_active(scene) {
        use antumbra_core::render::ShadowTracer;
        let alpha = antumbra_core::render::alpha_scene(scene, trees.geometry().shadow_set())?;
        let max_hits = settings.shadow_max_hits();
        let pass = match tracer {
            ShadowTracer::Binary(t) => shadow_measured(|| {
                ShadowPass::trace_alpha::<NoStats>(
                    primary, t, &alpha, max_hits, sampler, plan, &cancel,
                )
            }),
            ShadowTracer::Wide(t) => shadow_measured(|| {
                ShadowPass::trace_alpha::<NoStats>(
                    primary, t, &alpha, max_hits, sampler, plan, &cancel,
                )
            }),
            _ => return Err("binary or wide orders only".into()),
        };
        return Ok(pass?);
    }
    // ALPHA-END
    let _ = (scene, settings, trees);
    Ok(shadow_measured(|| {
        ShadowPass::trace::<NoStats>(primary, tracer, sampler, plan, &cancel)
    })?)
}
