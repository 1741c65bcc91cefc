//! Traces one frame's shadow rays on one thread with one traversal and child order, for counting
//! instructions per ray with callgrind: the binary tree front to back, the 8-wide tree front to
//! back or with the per-light sorted order, or each light's SRDH tree.
//!
//! ```text
//! cargo build --release -p antumbra-cli --example order_profile
//! valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*order_profile*trace_*' \
//!   target/release/examples/order_profile binary|fbto8|sorted8|srdh [scene] [triangles] [WxH]
//! ```
//!
//! It prints the shadow rays traced; instructions per ray = callgrind's total / rays.

use antumbra_cli::example_args::{ExampleFrame, FrameArgs, FrameDefaults, SahFrame};
use antumbra_cli::shadow_lights::{shadow_lights, ShadowLight};
use antumbra_core::build::BuildSettings;
use antumbra_core::bvh::{Bvh, WideBvh};
use antumbra_core::geometry::Ray;
use antumbra_core::order::ShadowOrder;
use antumbra_core::order::SrdhSettings;
use antumbra_core::order::{OrderView, PreparedOrder};
use antumbra_core::render::{representative_rays, shadow_rays, srdh_for_light};
use antumbra_core::scene::ImageSize;
use antumbra_core::srdh::SrdhBvh;
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::{NoStats, RayQuery};
use clap::Parser;

#[inline(never)]
fn trace_binary(bvh: &Bvh, rays: &[Ray]) -> usize {
    rays.iter()
        .filter(|r| bvh.occluded(r, &mut NoStats))
        .count()
}

#[inline(never)]
fn trace_wide(bvh: &WideBvh<8>, rays: &[Ray], order: OrderView) -> usize {
    rays.iter()
        .filter(|r| WideQueries::occluded(bvh, r, order, BoxKernel::Auto, &mut NoStats))
        .count()
}

#[inline(never)]
fn trace_srdh(tree: &SrdhBvh, rays: &[Ray]) -> usize {
    rays.iter()
        .filter(|r| tree.occluded(r, &mut NoStats))
        .count()
}

#[derive(Parser)]
#[command(about = "Shadow rays of one frame through one traversal and order, for callgrind")]
struct Cli {
    /// binary, fbto8, sorted8 or srdh.
    #[arg(value_parser = ["binary", "fbto8", "sorted8", "srdh"])]
    mode: String,
    #[command(flatten)]
    frame: FrameArgs,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let mode = cli.mode;
    let frame = cli.frame.open(FrameDefaults {
        scene: "city",
        triangles: 100_000,
        size: ImageSize::new(160, 160),
    })?;
    let SahFrame {
        shadow_bvh, pass, ..
    } = frame.sah();
    let ExampleFrame {
        name,
        size,
        scene,
        geometry: g,
    } = frame;
    let shadow_tris = g
        .shadow
        .as_ref()
        .map_or(&g.camera.vertices, |s| &s.vertices);
    let s8 = WideBvh::<8>::collapse(&shadow_bvh);
    let (mut rays_traced, mut occluded_rays) = (0, 0);
    for ShadowLight { sampler, plan } in shadow_lights(&scene, &g.space, 1, 0) {
        let rays = shadow_rays(&pass, &sampler, plan);
        rays_traced += rays.len();
        occluded_rays += match mode.as_str() {
            "binary" => trace_binary(&shadow_bvh, &rays),
            "fbto8" => trace_wide(&s8, &rays, OrderView::FrontToBack),
            "sorted8" => {
                let reps = representative_rays(&pass, &sampler, plan, 0.05);
                let order: ShadowOrder = "sorted".parse()?;
                let p = PreparedOrder::new(&s8, &order, None, &reps, BoxKernel::Auto);
                trace_wide(&s8, &rays, p.view())
            }
            "srdh" => {
                let settings = SrdhSettings {
                    min_occluded: 0.0,
                    ..SrdhSettings::default()
                };
                let bs = BuildSettings::default();
                let l = srdh_for_light(
                    &pass,
                    &sampler,
                    plan,
                    &settings,
                    &shadow_bvh,
                    shadow_tris,
                    &bs,
                );
                // A light none of whose representative rays reach a surface gets no tree.
                let Some(tree) = l.tree else {
                    rays_traced -= rays.len();
                    continue;
                };
                trace_srdh(&tree, &rays)
            }
            other => unreachable!("clap checks the mode: {other}"),
        };
    }
    println!(
        "{mode} {name} {} {size}: {rays_traced} shadow rays ({occluded_rays} occluded)",
        g.camera.vertices.len()
    );
    Ok(())
}
