//! Traces one frame's shadow rays (8-wide, per-light sorted order) and camera rays (8-wide,
//! closest hit) on one thread, with nothing else in the traced functions: the run to profile
//! with callgrind (instruction counts, stable on a loaded machine).
//!
//! ```text
//! cargo build --release -p antumbra-cli --example trace_profile
//! valgrind --tool=callgrind --dump-instr=no --collect-atstart=no \
//!   --toggle-collect='*trace_profile*trace_*' target/release/examples/trace_profile bedroom 350000 256x256 1 [greedy|sah]
//! target/release/examples/trace_profile bedroom 350000 512x512 5 [sah|greedy] [auto,avx2]   # wall clock, best of 5
//! target/release/examples/trace_profile bedroom 350000 512x512 5 --packets   # packets of 16 rays
//! ```
//!
//! Arguments: scene, triangles, size, timed repetitions (1 under callgrind), and the collapse
//! of the 8-wide trees (default: the default collapse), and the box kernels to time in turn
//! (default: auto).

use antumbra_cli::example_args::{ExampleFrame, FrameArgs, FrameDefaults, SahFrame};
use antumbra_cli::shadow_lights::{shadow_lights, ShadowLight};
use antumbra_core::build::{CollapseMethod, CollapseSettings};
use antumbra_core::bvh::WideBvh;
use antumbra_core::geometry::Ray;
use antumbra_core::order::ShadowOrder;
use antumbra_core::order::{OrderView, PreparedOrder};
use antumbra_core::render::{representative_rays, shadow_rays};
use antumbra_core::scene::ImageSize;
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::NoStats;
use clap::Parser;

#[inline(never)]
fn trace_shadow(bvh: &WideBvh<8>, rays: &[Ray], order: OrderView, kernel: BoxKernel) -> usize {
    rays.iter()
        .filter(|r| bvh.occluded(r, order, kernel, &mut NoStats))
        .count()
}

#[inline(never)]
fn trace_closest(bvh: &WideBvh<8>, rays: &[Ray], kernel: BoxKernel) -> usize {
    rays.iter()
        .filter(|r| bvh.closest_hit(r, kernel, &mut NoStats).is_some())
        .count()
}

#[inline(never)]
fn trace_shadow_packets(
    bvh: &WideBvh<8>,
    rays: &[Ray],
    order: OrderView,
    kernel: BoxKernel,
) -> usize {
    let mut out = vec![false; rays.len()];
    bvh.occluded_packets(
        rays,
        order,
        kernel,
        &mut out,
        &mut vec![NoStats; rays.len()],
    );
    out.iter().filter(|&&o| o).count()
}

#[inline(never)]
fn trace_closest_packets(bvh: &WideBvh<8>, rays: &[Ray], kernel: BoxKernel) -> usize {
    let mut out = vec![None; rays.len()];
    bvh.closest_hit_packets(rays, kernel, &mut out, &mut vec![NoStats; rays.len()]);
    out.iter().filter(|h| h.is_some()).count()
}

type ShadowFn = fn(&WideBvh<8>, &[Ray], OrderView, BoxKernel) -> usize;
type ClosestFn = fn(&WideBvh<8>, &[Ray], BoxKernel) -> usize;

/// Runs `f` `repeat` times; its (last) result and the best time in ms.
fn best_of<T>(repeat: usize, mut f: impl FnMut() -> T) -> (T, f64) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeat.max(1) {
        let start = std::time::Instant::now();
        out = Some(f());
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
    }
    (out.expect("ran at least once"), best)
}

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    frame: FrameArgs,
    /// Timed repetitions (best of); 1 under callgrind.
    #[arg(default_value_t = 1)]
    repeat: usize,
    /// How the 8-wide trees are made: greedy or sah.
    #[arg(default_value_t = Default::default())]
    collapse: CollapseMethod,
    /// Box kernels to time in turn, e.g. auto,avx2 (AVX-512 where present beside AVX2).
    #[arg(default_value = "auto", value_delimiter = ',', value_parser = parse_kernel)]
    kernels: Vec<BoxKernel>,
    /// Trace in packets of 16 neighbouring rays (camera rays in 4x4 pixel blocks) instead of
    /// one ray at a time.
    #[arg(long)]
    packets: bool,
}

fn parse_kernel(k: &str) -> anyhow::Result<BoxKernel> {
    match k {
        "auto" => Ok(BoxKernel::Auto),
        "avx2" => Ok(BoxKernel::Avx2),
        "sse" => Ok(BoxKernel::Sse),
        "scalar" => Ok(BoxKernel::Scalar),
        _ => Err(anyhow::anyhow!(
            "unknown kernel '{k}' (auto, avx2, sse, scalar)"
        )),
    }
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let repeat = cli.repeat;
    let collapse = CollapseSettings::new(cli.collapse);
    let frame = cli.frame.open(FrameDefaults {
        scene: "bedroom",
        triangles: 350_000,
        size: ImageSize::new(256, 256),
    })?;
    let SahFrame {
        bvh,
        shadow_bvh,
        camera,
        pass,
    } = frame.sah();
    let ExampleFrame {
        name,
        size,
        scene,
        geometry: g,
    } = frame;
    let (w, h) = (size.width, size.height);
    // Pixels in 4x4 blocks, so that each 16 consecutive camera rays are a packet's neighbours.
    let primary: Vec<Ray> = (0..h.div_ceil(4) * w.div_ceil(4))
        .flat_map(|b| {
            (0..16).map(move |k| {
                (
                    (b % w.div_ceil(4)) * 4 + k % 4,
                    (b / w.div_ceil(4)) * 4 + k / 4,
                )
            })
        })
        .filter(|&(x, y)| x < w && y < h)
        .map(|(x, y)| camera.ray(x, y))
        .collect();
    let (shadow_fn, closest_fn): (ShadowFn, ClosestFn) = if cli.packets {
        (trace_shadow_packets, trace_closest_packets)
    } else {
        (trace_shadow, trace_closest)
    };
    let w8 = WideBvh::<8>::collapse_with(&bvh, &collapse);
    let s8 = WideBvh::<8>::collapse_with(&shadow_bvh, &collapse);
    let order: ShadowOrder = "sorted".parse().expect("order");
    // Timed in turn within each repetition so that load changes hit them alike.
    let kernels = cli.kernels;
    let mut lights = Vec::new();
    for ShadowLight { sampler, plan } in shadow_lights(&scene, &g.space, 1, 0) {
        let rays = shadow_rays(&pass, &sampler, plan);
        let reps = representative_rays(&pass, &sampler, plan, 0.05);
        let prepared = PreparedOrder::new(&s8, &order, None, &reps, BoxKernel::Auto);
        lights.push((rays, prepared));
    }
    let shadow: usize = lights.iter().map(|(r, _)| r.len()).sum();
    let mut best = vec![(f64::INFINITY, f64::INFINITY); kernels.len()];
    let (mut occluded, mut hits) = (0, 0);
    for _ in 0..repeat.max(1) {
        for (k, &kernel) in kernels.iter().enumerate() {
            let (o, shadow_ms) = best_of(1, || {
                lights
                    .iter()
                    .map(|(rays, p)| shadow_fn(&s8, rays, p.view(), kernel))
                    .sum::<usize>()
            });
            let (h, closest_ms) = best_of(1, || closest_fn(&w8, &primary, kernel));
            (occluded, hits) = (o, h);
            best[k] = (best[k].0.min(shadow_ms), best[k].1.min(closest_ms));
        }
    }
    println!(
        "{name} ({} collapse): {shadow} shadow rays ({occluded} occluded), {} camera rays ({hits} hit)",
        collapse.method,
        primary.len()
    );
    for (kernel, (shadow_ms, closest_ms)) in kernels.iter().zip(best) {
        println!(
            "{kernel:?} best of {repeat}: shadow {:.1} ns/ray, closest {:.1} ns/ray (one thread)",
            shadow_ms * 1e6 / shadow.max(1) as f64,
            closest_ms * 1e6 / primary.len().max(1) as f64
        );
    }
    Ok(())
}
