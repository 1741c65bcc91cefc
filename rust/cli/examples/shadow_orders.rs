//! Traversal work of shadow rays per child order and BVH width, in the form of Table 5 of
//! Ogaki & Derouet-Jourdan (N_B, N_L, N_T per shadow ray), and the representative-ray budget /
//! depth-limit trade of per-light sorting (node visits against logging + sorting ms).
//! The rays are exactly a frame's shadow rays (one per pixel and hard light, `spp` for soft).
//!
//! ```text
//! cargo run --release -p antumbra-cli --example shadow_orders -- table SCENE [TRIS] [WxH] [SPP] [COLLAPSE]
//! cargo run --release -p antumbra-cli --example shadow_orders -- trade SCENE [TRIS] [WxH] [SPP] [COLLAPSE]
//! cargo run --release -p antumbra-cli --example shadow_orders -- oracle SCENE [TRIS] [WxH] [SPP] [COLLAPSE]
//! ```
//!
//! COLLAPSE is how the 4- and 8-wide trees are made: greedy or sah (default: the default
//! collapse).
//!
//! `oracle` measures, on the 8-wide tree, the fewest node visits any child order could give each
//! ray (an occluded ray: the interior nodes on the path to its shallowest occluding leaf; an
//! unoccluded ray: every interior node it enters, which no order avoids), beside SATO and sorted.

use antumbra_cli::example_args::{ExampleFrame, FrameArgs, FrameDefaults, SahFrame};
use antumbra_cli::shadow_lights::{shadow_lights, ShadowLight};
use antumbra_core::build::{CollapseMethod, CollapseSettings};
use antumbra_core::bvh::WideBvh;
use antumbra_core::geometry::{intersect_triangle, Ray, WatertightRay};
use antumbra_core::order::ShadowOrder;
use antumbra_core::order::{PreparedOrder, SortTables};
use antumbra_core::render::{representative_rays, shadow_rays};
use antumbra_core::scene::ImageSize;
use antumbra_core::trace::wide::{BoxKernel, ChildBoxTest, Scalar, WideQueries, WideRay};
use antumbra_core::trace::TraversalStats;
use clap::Parser;
use rayon::prelude::*;

/// One light's rays and its representative rays for each budget asked for.
struct Light {
    rays: Vec<Ray>,
    /// (budget, representative rays)
    representative: Vec<(f32, Vec<Ray>)>,
}

struct Measured {
    stats: TraversalStats,
    rays: u64,
    prepare_ms: f64,
}

fn measure<const N: usize>(
    bvh: &WideBvh<N>,
    tables: &SortTables,
    lights: &[Light],
    order: &ShadowOrder,
) -> Measured
where
    WideBvh<N>: WideQueries,
{
    let mut m = Measured {
        stats: TraversalStats::default(),
        rays: 0,
        prepare_ms: 0.0,
    };
    for light in lights {
        let budget = match order {
            ShadowOrder::Sorted(s) => s.budget,
            _ => 0.0,
        };
        let reps = light
            .representative
            .iter()
            .find(|(b, _)| *b == budget)
            .map_or(&[][..], |(_, r)| &r[..]);
        // Sorting on one thread, as the per-light cost target is stated.
        let prepared = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool")
            .install(|| PreparedOrder::new(bvh, order, Some(tables), reps, BoxKernel::Auto));
        m.prepare_ms += prepared.prepare_ms();
        let view = prepared.view();
        let stats = light
            .rays
            .par_iter()
            .with_min_len(256)
            .map(|r| {
                let mut s = TraversalStats::default();
                bvh.occluded(r, view, BoxKernel::Auto, &mut s);
                s
            })
            .reduce(TraversalStats::default, |mut a, b| {
                a += b;
                a
            });
        m.stats += stats;
        m.rays += light.rays.len() as u64;
    }
    m.prepare_ms /= lights.len().max(1) as f64;
    m
}

/// The lower bound of N_B for one ray over all child orders (see the module comment), and
/// whether the ray is occluded.
fn oracle_visits<const N: usize>(bvh: &WideBvh<N>, ray: &Ray) -> (u64, bool)
where
    Scalar: ChildBoxTest<N>,
{
    let wray = WideRay::new(ray);
    let wt = WatertightRay::new(ray);
    let t_max = ray.t_max + wray.pre.t_margin;
    let r = &bvh.root_bounds;
    if bvh.nodes.is_empty() || wray.pre.hit(r.min, r.max, ray.t_min, t_max).is_none() {
        return (0, false);
    }
    let (mut entered, mut best) = (0u64, u64::MAX);
    let mut stack = vec![0usize];
    let mut t_near = [0f32; N];
    while let Some(i) = stack.pop() {
        entered += 1;
        let node = &bvh.nodes[i];
        let mask = Scalar::test(&wray, node, ray.t_min, t_max, &mut t_near);
        for s in (0..N).filter(|s| mask & (1 << s) != 0) {
            if node.is_leaf_slot(s) {
                let first = node.child[s] as usize;
                let tris = &bvh.triangles[first..first + node.count[s] as usize];
                if tris
                    .iter()
                    .any(|t| intersect_triangle(&wt, t, ray.t_min, ray.t_max).is_some())
                {
                    // Interior nodes from the root down to this leaf's node.
                    best = best.min(bvh.depth[i] as u64 + 1);
                }
            } else {
                stack.push(node.child[s] as usize);
            }
        }
    }
    if best == u64::MAX {
        (entered, false)
    } else {
        (best, true)
    }
}

fn per_ray(v: u64, rays: u64) -> f64 {
    v as f64 / rays.max(1) as f64
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Mode {
    Table,
    Trade,
    Oracle,
}

#[derive(Parser)]
struct Cli {
    #[arg(default_value = "table")]
    mode: Mode,
    #[command(flatten)]
    frame: FrameArgs,
    /// Shadow samples per pixel of soft lights.
    #[arg(default_value_t = 1)]
    spp: u32,
    /// How the 4- and 8-wide trees are made: greedy or sah.
    #[arg(default_value_t = Default::default())]
    collapse: CollapseMethod,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let (mode, spp) = (cli.mode, cli.spp);
    let collapse = CollapseSettings::new(cli.collapse);
    let frame = cli.frame.open(FrameDefaults {
        scene: "bedroom",
        triangles: 350_000,
        size: ImageSize::new(512, 512),
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
    let (w, h) = (size.width, size.height);
    let budgets = [0.001f32, 0.01, 0.05, 0.1, 1.0];
    let lights: Vec<Light> = shadow_lights(&scene, &g.space, spp, 0)
        .into_iter()
        .map(|ShadowLight { sampler, plan }| Light {
            rays: shadow_rays(&pass, &sampler, plan),
            representative: budgets
                .iter()
                .map(|&b| (b, representative_rays(&pass, &sampler, plan, b)))
                .collect(),
        })
        .collect();
    let rays: usize = lights.iter().map(|l| l.rays.len()).sum();
    println!(
        "{name}: {} triangles ({} casting shadows), {w}x{h}, {} lights, {rays} shadow rays",
        g.camera.vertices.len(),
        g.shadow
            .as_ref()
            .map_or(g.camera.vertices.len(), |s| s.vertices.len()),
        lights.len()
    );
    let w2 = WideBvh::<2>::collapse(&shadow_bvh);
    let w4 = WideBvh::<4>::collapse_with(&shadow_bvh, &collapse);
    let w8 = WideBvh::<8>::collapse_with(&shadow_bvh, &collapse);
    let model = collapse.cost;
    println!(
        "collapse {}: 4-wide {} nodes, {:.2} children/node, cost {:.4e} ({:.0} ms); \
         8-wide {} nodes, {:.2} children/node, cost {:.4e} ({:.0} ms)",
        collapse.method,
        w4.nodes.len(),
        w4.children_per_node(),
        w4.sah_cost(&model),
        w4.collapse_ms,
        w8.nodes.len(),
        w8.children_per_node(),
        w8.sah_cost(&model),
        w8.collapse_ms,
    );
    let (t2, t4, t8) = (
        SortTables::new(&w2),
        SortTables::new(&w4),
        SortTables::new(&w8),
    );
    let run = |width: u32, order: &ShadowOrder| match width {
        2 => measure(&w2, &t2, &lights, order),
        4 => measure(&w4, &t4, &lights, order),
        _ => measure(&w8, &t8, &lights, order),
    };
    let parse = |s: &str| s.parse::<ShadowOrder>().expect("order");
    if mode == Mode::Table {
        let columns = [
            "fbto",
            "sorted:logging=fbto",
            "sato",
            "sorted:logging=sato",
            "stored",
            "rtsah",
            "random:seed=1",
        ];
        println!("\n| N | order | N_B/ray | N_L/ray | N_T/ray | sort ms/light |");
        println!("|---|---|---:|---:|---:|---:|");
        for width in [2u32, 4, 8] {
            for c in columns {
                let m = run(width, &parse(c));
                println!(
                    "| {width} | {c} | {:.2} | {:.2} | {:.2} | {:.2} |",
                    per_ray(m.stats.inner, m.rays),
                    per_ray(m.stats.leaves, m.rays),
                    per_ray(m.stats.triangles, m.rays),
                    m.prepare_ms
                );
            }
        }
    } else if mode == Mode::Oracle {
        let all: Vec<Ray> = lights.iter().flat_map(|l| l.rays.iter().copied()).collect();
        let (mut occ, mut occ_nb, mut free_nb) = (0u64, 0u64, 0u64);
        let mut by_depth = [0u64; 16];
        for (nb, occluded) in all
            .par_iter()
            .map(|r| oracle_visits(&w8, r))
            .collect::<Vec<_>>()
        {
            if occluded {
                occ += 1;
                occ_nb += nb;
                by_depth[(nb as usize).min(15)] += 1;
            } else {
                free_nb += nb;
            }
        }
        let n = all.len() as u64;
        println!("\n8-wide: lower bound of N_B over all child orders (per ray, oracle)");
        println!(
            "occluded {occ} of {n}: N_B >= {:.2} per occluded ray; unoccluded: N_B = {:.2} per ray",
            per_ray(occ_nb, occ),
            per_ray(free_nb, n - occ)
        );
        println!(
            "all rays: N_B >= {:.2} per ray",
            per_ray(occ_nb + free_nb, n)
        );
        println!("occluded rays by the interior nodes on the path to their shallowest occluder:");
        for (d, c) in by_depth.iter().enumerate().filter(|(_, &c)| c > 0) {
            println!("  {d}: {c} ({:.1}%)", 100.0 * *c as f64 / occ.max(1) as f64);
        }
        for o in [
            "sato",
            "fbto",
            "sorted",
            "sorted:budget=1",
            "sorted:p=area",
            "sorted:p=area:budget=1",
        ] {
            let m = run(8, &parse(o));
            println!("{o}: N_B {:.2} per ray", per_ray(m.stats.inner, m.rays));
        }
    } else {
        println!("\n8-wide, sorted (logging SATO, P_i = 1): N_B per shadow ray / logging+sorting ms per light");
        print!("| depth \\ budget |");
        for b in budgets {
            print!(" {}% |", b * 100.0);
        }
        println!();
        println!("|---|{}", "---:|".repeat(budgets.len()));
        let sato = run(8, &parse("sato"));
        for depth in ["1", "2", "3", "4", "6", "all"] {
            print!("| {depth} |");
            for b in budgets {
                let depth_opt = if depth == "all" {
                    String::new()
                } else {
                    format!(":depth={depth}")
                };
                let m = run(8, &parse(&format!("sorted:budget={b}{depth_opt}")));
                print!(
                    " {:.2} / {:.1} |",
                    per_ray(m.stats.inner, m.rays),
                    m.prepare_ms
                );
            }
            println!();
        }
        println!(
            "\nSATO (no sorting): N_B {:.2} per shadow ray",
            per_ray(sato.stats.inner, sato.rays)
        );
    }
    Ok(())
}
