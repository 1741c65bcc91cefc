//! The SRDH paper's figures in our form (issue 7), on exactly a frame's shadow rays.
//!
//! ```text
//! cargo run --release -p antumbra-cli --example srdh_figures -- counts SCENE [TRIS] [WxH]
//! cargo run --release -p antumbra-cli --example srdh_figures -- wall SCENE [TRIS] [WxH] [SPP]
//! ```
//!
//! `counts` prints exact box-test counts (machine load does not change them): Figure 2 (box
//! tests per shadow ray split into occluded path-to-hit, occluded faux hits and unoccluded,
//! normalised to random order on the SAH tree), Figure 4 (SRDH cost against prepass size),
//! Figure 5 (kernel sets) and Table 1 (build times and ray-set sizes).
//! `wall` prints per light the wall-clock shadow time including the per-light preparation:
//! SRDH (16x16 prepass) against per-light sorting on the 8-wide tree.
//!
//! Binary methods of Figure 2 use the paper's setting, one triangle per leaf (SAH with
//! `max_leaf_size = 1`, SRDH `leaf = 1`, 32 bins = 31 planes), and the kernel-guided traversal,
//! which tests a child's box when it enters it. The 8-wide sorted baseline is collapsed from the
//! renderer's default SAH tree and counts its child-box tests (N_box).

use std::time::Instant;

use antumbra_cli::example_args::{ExampleFrame, FrameArgs, FrameDefaults};
use antumbra_cli::shadow_lights::{shadow_lights, ShadowLight};
use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::bvh::{Bvh, WideBvh};
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::order::ShadowOrder;
use antumbra_core::order::{
    rtsah_kernels, ChildOrder as KernelSource, Kernel, KernelSet, RandomKernel, RaySetSource,
    SrdhSettings, Uniform,
};
use antumbra_core::order::{PreparedOrder, SortTables};
use antumbra_core::render::{
    shadow_rays, srdh_for_light, srdh_rays, LightSampler, PrimaryPass, PrimaryRays, SamplePlan,
};
use antumbra_core::scene::ImageSize;
use antumbra_core::srdh::{build_srdh, RaySet};
use antumbra_core::trace::occluding_leaf;
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::{NoStats, RayQuery, TraversalStats};
use clap::Parser;
use rayon::prelude::*;

/// Box tests of a set of rays in the three parts of the paper's Figure 2.
#[derive(Clone, Copy, Default, Debug)]
struct Split {
    /// Occluded rays: tests of the nodes on the path from the root to the leaf that stopped them.
    path: u64,
    /// Occluded rays: every other test (nodes that did not lead to the hit).
    faux: u64,
    /// Unoccluded rays: all their tests.
    unoccluded: u64,
}

impl Split {
    fn total(&self) -> u64 {
        self.path + self.faux + self.unoccluded
    }
    fn add(mut self, o: Split) -> Split {
        self.path += o.path;
        self.faux += o.faux;
        self.unoccluded += o.unoccluded;
        self
    }
}

/// Depth of every node (root 0).
fn depths(bvh: &Bvh) -> Vec<u32> {
    let mut d = vec![0u32; bvh.nodes.len()];
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let n = &bvh.nodes[i];
        if !n.is_leaf() {
            for c in [n.first as usize, n.first as usize + 1] {
                d[c] = d[i] + 1;
                stack.push(c);
            }
        }
    }
    d
}

/// Figure 2's split for a binary tree traversed with `kernels`: every ancestor of the stopping
/// leaf (and the leaf) is box-tested exactly once, so the path part is its depth + 1.
fn split_binary<K: KernelSource>(bvh: &Bvh, kernels: &K, rays: &[Ray]) -> Split {
    let depth = depths(bvh);
    rays.par_iter()
        .with_min_len(256)
        .map(|r| {
            let mut s = TraversalStats::default();
            match occluding_leaf(bvh, kernels, r, &mut s) {
                Some(leaf) => {
                    let path = depth[leaf] as u64 + 1;
                    Split {
                        path,
                        faux: s.boxes - path,
                        unoccluded: 0,
                    }
                }
                None => Split {
                    unoccluded: s.boxes,
                    ..Split::default()
                },
            }
        })
        .reduce(Split::default, Split::add)
}

/// The wide tree's N_box split into occluded and unoccluded rays (its path is not separated).
fn split_wide(bvh: &WideBvh<8>, order: &PreparedOrder, rays: &[Ray]) -> Split {
    let view = order.view();
    rays.par_iter()
        .with_min_len(256)
        .map(|r| {
            let mut s = TraversalStats::default();
            if WideQueries::occluded(bvh, r, view, BoxKernel::Auto, &mut s) {
                Split {
                    faux: s.boxes,
                    ..Split::default()
                }
            } else {
                Split {
                    unoccluded: s.boxes,
                    ..Split::default()
                }
            }
        })
        .reduce(Split::default, Split::add)
}

struct Light {
    name: String,
    sampler: LightSampler,
    plan: SamplePlan,
    rays: Vec<Ray>,
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn best_of(n: u32, mut f: impl FnMut()) -> f64 {
    (0..n)
        .map(|_| {
            let t = Instant::now();
            f();
            ms_since(t)
        })
        .fold(f64::INFINITY, f64::min)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Mode {
    Counts,
    Wall,
}

#[derive(Parser)]
struct Cli {
    #[arg(default_value = "counts")]
    mode: Mode,
    #[command(flatten)]
    frame: FrameArgs,
    /// Shadow samples per pixel of soft lights.
    #[arg(default_value_t = 1)]
    spp: u32,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let (mode, spp) = (cli.mode, cli.spp);
    let ExampleFrame {
        name,
        size,
        scene,
        geometry: g,
    } = cli.frame.open(FrameDefaults {
        scene: "bedroom",
        triangles: 100_000,
        size: ImageSize::new(128, 128),
    })?;
    let (w, h) = (size.width, size.height);
    let default_settings = BuildSettings::default();
    let camera_bvh = build_binned_sah(&g.camera.vertices, &default_settings);
    let tris = g
        .shadow
        .as_ref()
        .map_or(&g.camera.vertices, |s| &s.vertices);
    let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
    let pass = PrimaryPass::trace::<NoStats>(&camera, &camera_bvh, &g.camera, &CancelToken::new())
        .expect("a new token is never cancelled");
    let lights: Vec<Light> = shadow_lights(&scene, &g.space, spp, 0)
        .into_iter()
        .map(|ShadowLight { sampler, plan }| {
            let rays = shadow_rays(&pass, &sampler, plan);
            Light {
                name: scene.lights[plan.light_index as usize].name.clone(),
                sampler,
                plan,
                rays,
            }
        })
        .collect();
    let all_rays: usize = lights.iter().map(|l| l.rays.len()).sum();
    println!(
        "{name}: {} shadow-casting triangles, {w}x{h}, spp {spp}, {} lights, {all_rays} shadow rays, {} threads",
        tris.len(),
        lights.len(),
        rayon::current_num_threads()
    );
    if mode == Mode::Wall {
        wall(&pass, tris, &lights, &default_settings)
    } else {
        counts(&pass, tris, &lights, &default_settings)
    }
}

fn counts(
    pass: &PrimaryPass,
    tris: &[[glam::Vec3; 3]],
    lights: &[Light],
    default_settings: &BuildSettings,
) -> anyhow::Result<()> {
    let leaf1 = BuildSettings {
        max_leaf_size: 1,
        bins: 32,
        ..*default_settings
    };
    let t = Instant::now();
    let sah = build_binned_sah(tris, &leaf1);
    let sah_leaf1_ms = ms_since(t);
    let t = Instant::now();
    let sah_default = build_binned_sah(tris, default_settings);
    let sah_default_ms = ms_since(t);
    let wide = WideBvh::<8>::collapse(&sah_default);
    let tables = SortTables::new(&wide);
    let rtsah = rtsah_kernels(&sah);
    let srdh = |source: RaySetSource, kernels: KernelSet| SrdhSettings {
        rays: source,
        kernels,
        leaf: 1,
        bins: 32,
        min_occluded: 0.0,
    };

    // Figure 2: per method the three parts, summed over lights.
    let mut fig2: Vec<(String, Split)> = Vec::new();
    let mut add = |label: &str, s: Split| match fig2.iter_mut().find(|(l, _)| l == label) {
        Some((_, acc)) => *acc = acc.add(s),
        None => fig2.push((label.to_string(), s)),
    };
    let mut fig4: Vec<(String, u64)> = Vec::new();
    let mut fig5: Vec<(String, u64)> = Vec::new();
    let acc = |v: &mut Vec<(String, u64)>, label: &str, x: u64| match v
        .iter_mut()
        .find(|(l, _)| l == label)
    {
        Some((_, a)) => *a += x,
        None => v.push((label.to_string(), x)),
    };
    let mut table1: Vec<(String, usize, f64, f64)> = Vec::new(); // (set, rays, hits ms, build ms)
    let mut occluded_rays = 0usize;
    for light in lights {
        let rays = &light.rays;
        occluded_rays += rays
            .par_iter()
            .filter(|r| sah.occluded(r, &mut NoStats))
            .count();
        add(
            "random",
            split_binary(&sah, &RandomKernel { seed: 1 }, rays),
        );
        add(
            "front-to-back",
            split_binary(&sah, &Uniform(Kernel::FrontToBack), rays),
        );
        add(
            "back-to-front",
            split_binary(&sah, &Uniform(Kernel::BackToFront), rays),
        );
        add("RTSAH", split_binary(&sah, &rtsah, rays));
        let sorted: ShadowOrder = "sorted".parse().expect("order");
        let ShadowOrder::Sorted(ss) = sorted else {
            unreachable!()
        };
        let reps =
            antumbra_core::render::representative_rays(pass, &light.sampler, light.plan, ss.budget);
        let prepared = PreparedOrder::new(&wide, &sorted, Some(&tables), &reps, BoxKernel::Auto);
        add("sorted 8-wide (N_box)", split_wide(&wide, &prepared, rays));
        let sources = [
            (
                "8x8",
                RaySetSource::Prepass {
                    width: 8,
                    height: 8,
                },
            ),
            (
                "16x16",
                RaySetSource::Prepass {
                    width: 16,
                    height: 16,
                },
            ),
            (
                "32x32",
                RaySetSource::Prepass {
                    width: 32,
                    height: 32,
                },
            ),
            (
                "64x64",
                RaySetSource::Prepass {
                    width: 64,
                    height: 64,
                },
            ),
            ("all", RaySetSource::All),
        ];
        for (label, source) in sources {
            let set = RaySet::trace(&sah, srdh_rays(pass, &light.sampler, light.plan, source));
            let tree = build_srdh(tris, &set, &srdh(source, KernelSet::All), &leaf1);
            let s = split_binary(&tree.bvh, &tree.kernels, rays);
            acc(&mut fig4, label, s.total());
            if label == "all" {
                add("SRDH (all rays)", s);
                for ks in [KernelSet::Constant, KernelSet::Directional] {
                    let t = build_srdh(tris, &set, &srdh(source, ks), &leaf1);
                    acc(
                        &mut fig5,
                        ks.name(),
                        split_binary(&t.bvh, &t.kernels, rays).total(),
                    );
                }
                acc(&mut fig5, "all", s.total());
            }
            if label == "16x16" {
                add("SRDH (16x16 prepass)", s);
            }
            if label == "16x16" || label == "32x32" {
                // Table 1: the renderer's settings (leaf 1, SAH fallback with default leaves).
                let t = Instant::now();
                let set = RaySet::trace(
                    &sah_default,
                    srdh_rays(pass, &light.sampler, light.plan, source),
                );
                let hits_ms = ms_since(t);
                let tree = build_srdh(tris, &set, &srdh(source, KernelSet::All), default_settings);
                match table1.iter_mut().find(|(l, ..)| l == label) {
                    Some(e) => {
                        e.1 += set.len();
                        e.2 += hits_ms;
                        e.3 += tree.build_ms;
                    }
                    None => table1.push((label.to_string(), set.len(), hits_ms, tree.build_ms)),
                }
            }
        }
    }
    let rays: u64 = lights.iter().map(|l| l.rays.len() as u64).sum();
    let random = fig2[0].1.total() as f64;
    println!(
        "occluded shadow rays: {:.1}%",
        100.0 * occluded_rays as f64 / rays.max(1) as f64
    );
    println!("\nFigure 2: box tests per shadow ray, and relative to random (SAH tree, leaf 1)");
    println!("| method | path to hit | faux hits | unoccluded | total/ray | vs random |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (label, s) in &fig2 {
        let pr = |v: u64| v as f64 / rays.max(1) as f64;
        println!(
            "| {label} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} |",
            pr(s.path),
            pr(s.faux),
            pr(s.unoccluded),
            pr(s.total()),
            s.total() as f64 / random
        );
    }
    println!("\nFigure 4: SRDH box tests relative to random against the ray set");
    println!(
        "| set | {} |",
        fig4.iter()
            .map(|(l, _)| l.as_str())
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---:|".repeat(fig4.len()));
    println!(
        "| cost | {} |",
        fig4.iter()
            .map(|(_, v)| format!("{:.3}", *v as f64 / random))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("\nFigure 5: kernel sets (all rays), relative to random");
    for (l, v) in &fig5 {
        println!("| {l} | {:.3} |", *v as f64 / random);
    }
    println!("\nTable 1: SAH build (leaf 1 / default) {sah_leaf1_ms:.1} / {sah_default_ms:.1} ms");
    println!(
        "| set | rays | hit lists ms | SRDH build ms | SRDH total ms | total / SAH(default) |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for (l, n, hits_ms, build_ms) in &table1 {
        let total = hits_ms + build_ms;
        println!(
            "| {l} | {n} | {hits_ms:.1} | {build_ms:.1} | {total:.1} | {:.2} |",
            (sah_default_ms + total) / sah_default_ms
        );
    }
    Ok(())
}

fn wall(
    pass: &PrimaryPass,
    tris: &[[glam::Vec3; 3]],
    lights: &[Light],
    settings: &BuildSettings,
) -> anyhow::Result<()> {
    let t = Instant::now();
    let sah = build_binned_sah(tris, settings);
    let sah_ms = ms_since(t);
    let t = Instant::now();
    let wide = WideBvh::<8>::collapse(&sah);
    let tables = SortTables::new(&wide);
    let wide_ms = ms_since(t);
    println!("SAH build {sah_ms:.1} ms; 8-wide collapse + sort tables {wide_ms:.1} ms (once per tree, shared by lights)");
    println!("| light | rays | occluded (16x16 set) | SAH fbto trace | SRDH prep | SRDH trace | SRDH total | SRDH leaf 4 prep + trace | sorted prep | sorted trace | sorted total | SRDH / sorted |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let sorted: ShadowOrder = "sorted".parse().expect("order");
    let ShadowOrder::Sorted(ss) = sorted else {
        unreachable!()
    };
    let srdh_settings = SrdhSettings {
        min_occluded: 0.0,
        ..SrdhSettings::default()
    };
    let (mut sum_srdh, mut sum_sorted) = (0.0, 0.0);
    for light in lights {
        let rays = &light.rays;
        let fbto = best_of(3, || {
            rays.par_iter().with_min_len(256).for_each(|r| {
                std::hint::black_box(sah.occluded(r, &mut NoStats));
            })
        });
        let l = srdh_for_light(
            pass,
            &light.sampler,
            light.plan,
            &srdh_settings,
            &sah,
            tris,
            settings,
        );
        let Some(tree) = l.tree.as_ref() else {
            println!(
                "| {} | {} | no representative rays: traces the SAH tree | {fbto:.1} |",
                light.name,
                rays.len()
            );
            continue;
        };
        let srdh_trace = best_of(3, || {
            rays.par_iter().with_min_len(256).for_each(|r| {
                std::hint::black_box(tree.occluded(r, &mut NoStats));
            })
        });
        // The same rays with 4-triangle leaves: fewer, cheaper steps for the timed path.
        let leaf4 = SrdhSettings {
            leaf: 4,
            ..srdh_settings
        };
        let l4 = srdh_for_light(
            pass,
            &light.sampler,
            light.plan,
            &leaf4,
            &sah,
            tris,
            settings,
        );
        let t4 = l4.tree.as_ref().expect("same rays as above");
        let leaf4_trace = best_of(3, || {
            rays.par_iter().with_min_len(256).for_each(|r| {
                std::hint::black_box(t4.occluded(r, &mut NoStats));
            })
        });
        let t = Instant::now();
        let reps =
            antumbra_core::render::representative_rays(pass, &light.sampler, light.plan, ss.budget);
        let prepared = PreparedOrder::new(&wide, &sorted, Some(&tables), &reps, BoxKernel::Auto);
        let sorted_prep = ms_since(t);
        let view = prepared.view();
        let sorted_trace = best_of(3, || {
            rays.par_iter().with_min_len(256).for_each(|r| {
                std::hint::black_box(WideQueries::occluded(
                    &wide,
                    r,
                    view,
                    BoxKernel::Auto,
                    &mut NoStats,
                ));
            })
        });
        let (a, b) = (l.ms + srdh_trace, sorted_prep + sorted_trace);
        sum_srdh += a;
        sum_sorted += b;
        println!(
            "| {} | {} | {:.0}% | {fbto:.1} | {:.1} | {srdh_trace:.1} | {a:.1} | {:.1} + {leaf4_trace:.1} | {sorted_prep:.1} | {sorted_trace:.1} | {b:.1} | {:.2} |",
            light.name,
            rays.len(),
            100.0 * l.occluded_fraction,
            l.ms,
            l4.ms,
            a / b
        );
    }
    println!(
        "| all lights | | | | | | {sum_srdh:.1} | | | | {:.1} (+{wide_ms:.1} shared) | {:.2} |",
        sum_sorted,
        sum_srdh / (sum_sorted + wide_ms)
    );
    Ok(())
}
