//! `antumbra bench`: build time, Mrays/s and work per frame on exactly the rays a frame traces
//! ([`rays`]), build methods side by side ([`methods`]) or over an animation ([`animation`]),
//! optionally beside Embree on the same triangles and rays ([`reference`]).

mod animation;
mod frames;
mod kernels;
mod methods;
mod ray_file_bench;
mod ray_files;
mod rays;
mod reference;
mod tiles;
mod write_rays;

use std::time::Instant;

use antumbra_core::build::BuildMethod;
use antumbra_core::order::ShadowOrder;
use antumbra_core::render::{Pick, RenderSettings};
use antumbra_core::scene::ImageSize;
use antumbra_core::settings::SettingValue;
use anyhow::{bail, Result};
use clap::Args;

use crate::method_args::MethodArgs;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scenes to measure: built-in names, OBJ/glTF files or recordings (.antrec) (default:
    /// every built-in scene).
    #[arg(long, num_args = 1..)]
    pub scene: Vec<String>,
    /// Frames to measure, "A-B" or "N" (default: every frame of a recording, the first frame
    /// of anything else; with --methods a built-in scene's paper viewpoints).
    #[arg(long)]
    pub frames: Option<String>,
    /// Triangle budget of built-in scenes.
    #[arg(long, default_value_t = 350_000)]
    pub triangles: usize,
    /// Image size WxH of the camera rays.
    #[arg(long, value_name = "WxH", default_value = "512x512", value_parser = ImageSize::parse_image)]
    pub size: ImageSize,
    /// Timing repetitions; the best is reported.
    #[arg(long, default_value_t = 3)]
    pub repeat: u32,
    /// Compare with another tracer on the same triangles and rays ("embree").
    #[arg(long)]
    pub compare: Option<String>,
    /// Trace an external ray set instead of a scene's: a triangle file (u64 n, then n x 9 f32)
    /// and a ray file (u64 n, then n x 8 f32: ox oy oz tnear dx dy dz tfar), little-endian;
    /// any hit and closest hit of every ray, beside each of Embree's calls with --compare embree.
    #[arg(long, num_args = 2, value_names = ["TRIANGLES", "RAYS"], conflicts_with_all = ["scene", "methods", "animation", "write_rays"])]
    pub ray_files: Vec<std::path::PathBuf>,
    /// Write each scene's triangles, camera rays and per-light shadow rays in those two
    /// formats into DIR (render space, tile order; one set per frame), then stop.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["methods", "animation"])]
    pub write_rays: Option<std::path::PathBuf>,
    /// Print the table as JSON.
    #[arg(long)]
    pub json: bool,
    /// Embree build quality with --compare embree: medium or high.
    #[arg(long, default_value = "medium")]
    pub embree_quality: String,
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Render this many frames with SAH, SBVH, OSAH-exact and OSAH-previous and write the
    /// per-frame curve (animation.csv, animation.png) into --out.
    #[arg(long)]
    pub animation: Option<i32>,
    /// Output folder of --animation.
    #[arg(long, default_value = "bench-out")]
    pub out: std::path::PathBuf,
    /// The method measured (spp defaults to 1 here); --methods measures each builder in its
    /// list with these build settings.
    #[command(flatten)]
    pub method: MethodArgs,
}

/// The build-method comparison (the OSAH paper's tables) and the variants it sweeps.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Compare build methods on each scene's viewpoints instead (the OSAH paper's tables),
    /// e.g. sah,sbvh,abvh,osah,vsah; the first is the reference of the ratios. A file's or a
    /// recording's viewpoints are its frames' cameras.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<BuildMethod>,
    /// OSAH weights w to sweep with --methods (default: --osah-w).
    #[arg(long, value_delimiter = ',')]
    pub sweep_osah_w: Vec<f32>,
    /// Spatial splits for sbvh/abvh/osah with --methods: on, off, or on,off for both
    /// (default: --spatial-splits).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::BoolishValueParser::new())]
    pub sweep_spatial_splits: Vec<bool>,
}

pub fn run(args: BenchArgs) -> Result<()> {
    check_compare(args.compare.as_deref())?;
    let settings = bench_settings(&args.method)?;
    if let [triangles, rays] = args.ray_files.as_slice() {
        return ray_file_bench::run(&args, triangles, rays);
    }
    let scenes = frames::scene_names(&args.scene);
    if let Some(dir) = &args.write_rays {
        return write_rays::run(&args, &scenes, &settings, dir);
    }
    if let Some(frames) = args.animation {
        for name in &scenes {
            // A file's folder is named by its stem (a path would escape --out).
            let stem = std::path::Path::new(name).file_stem();
            let out = args.out.join(stem.unwrap_or(name.as_ref()));
            animation::animation_curve(name, args.triangles, args.size, frames, &settings, &out)?;
        }
        return Ok(());
    }
    if !args.sweep.methods.is_empty() {
        return methods::run(&args, &scenes, &settings);
    }
    rays::run(&args, &scenes, &settings)
}

/// The command line's method settings, with bench's own defaults: one sample per pixel, and one
/// fixed method (SAH, front to back) where the flags name none, since `auto` chooses over frames.
fn bench_settings(method: &MethodArgs) -> Result<RenderSettings> {
    let mut named = method.named.clone();
    for (name, value) in [("spp", SettingValue::Int(1)), ("build", "sah".into())] {
        if named.get(name).is_none() {
            named.insert(name, value);
        }
    }
    if named.get("order").is_none() && named.get("build").map(SettingValue::as_text) != Some("srdh")
    {
        named.insert("order", "fbto");
    }
    let settings = named.resolve()?;
    if settings.build != Pick::Fixed(BuildMethod::Sah) {
        bail!("--build: bench times SAH trees (compare builders with --methods)");
    }
    if settings.shadow_order.is_auto() {
        bail!(
            "--order: bench times one fixed order; auto chooses per frame (use render or compare)"
        );
    }
    Ok(settings)
}

/// The order bench traces: always a fixed one (`bench_settings` refuses `auto`).
fn bench_order(s: &RenderSettings) -> &ShadowOrder {
    s.shadow_order
        .fixed()
        .expect("bench_settings refuses order=auto")
}

fn check_compare(compare: Option<&str>) -> Result<()> {
    match compare {
        None => Ok(()),
        Some("embree") if cfg!(feature = "embree") => Ok(()),
        Some("embree") => bail!(
            "--compare embree: this antumbra was built without the 'embree' feature (cargo build --features embree)"
        ),
        Some(c) => bail!("--compare: unknown tracer '{c}' (known: embree)"),
    }
}

fn print_json(rows: &impl serde::Serialize) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(rows)?);
    Ok(())
}

/// The best time in ms of `repeat` calls of `f`; what `f` returns is dropped after the clock
/// stops (freeing a 40 MB tree is not part of building it).
fn best_of<T>(repeat: u32, mut f: impl FnMut() -> T) -> f64 {
    (0..repeat.max(1))
        .map(|_| timed(&mut f).1)
        .fold(f64::INFINITY, f64::min)
}

/// What `f` returns and its time in ms.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let out = f();
    (out, t.elapsed().as_secs_f64() * 1e3)
}

fn mrays(n: usize, ms: f64) -> f64 {
    n as f64 / (ms * 1e3)
}
