//! `antumbra bench --ray-files TRIANGLES RAYS`: an external ray set (see [`super::ray_files`]) traced
//! through antumbra's public ray queries (`antumbra-rays`: any hit and closest hit) and, with
//! `--compare embree`, through each of Embree's calls on the same rays in groups of
//! [`super::tiles::FILE_TILE`], so anyone can run the same rays through both.

use std::path::Path;

use antumbra_core::geometry::Ray;
use antumbra_rays::{BuildOptions, Interval, Scene, TraceOptions};
use anyhow::Result;
use serde::Serialize;

use super::kernels::{print_kernel_table, time_in_turn, Answers, KernelRow};
use super::ray_files::{read_rays, read_triangles};
use super::reference::Reference;
use super::tiles::TiledRays;
use super::{best_of, mrays, print_json, timed, BenchArgs};

#[derive(Debug, Serialize)]
pub struct RayFileRow {
    pub triangles_file: String,
    pub rays_file: String,
    pub triangles: usize,
    pub rays: usize,
    pub threads: usize,
    /// antumbra's tree (`antumbra-rays` defaults: SAH, 8 wide), on all threads.
    pub build_ms: f64,
    /// Share of the rays that any triangle blocks.
    pub occluded: f64,
    /// Any hit (`Scene::occluded`) and closest hit (`Scene::intersect`) of every ray.
    pub any_hit_mrays: f64,
    pub closest_hit_mrays: f64,
    pub embree_build_ms: Option<f64>,
    /// Each of Embree's calls, any hit first.
    pub embree_kernels: Vec<KernelRow>,
}

pub(super) fn run(args: &BenchArgs, triangles_file: &Path, rays_file: &Path) -> Result<()> {
    let triangles = read_triangles(triangles_file)?;
    let rays = read_rays(rays_file)?;
    let vertices: Vec<[f32; 3]> = triangles.iter().flatten().map(|v| v.to_array()).collect();
    let indices: Vec<[u32; 3]> = (0..triangles.len() as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    let (scene, build_ms) = timed(|| Scene::build(&vertices, &indices, &BuildOptions::default()));
    let scene = scene?;
    // Embree's segment is [tnear, tfar]; the files are in its terms.
    let options = TraceOptions {
        interval: Interval::Closed,
        ..TraceOptions::default()
    };
    let ours: Vec<antumbra_rays::Ray> = rays.iter().map(public_ray).collect();
    let occluded = scene.occluded(&ours, &options)?;
    let triangles_hit: Vec<Option<u32>> = scene
        .intersect(&ours, &options)?
        .iter()
        .map(|h| h.map(|h| h.triangle))
        .collect();
    let tiled = TiledRays::in_groups(rays);

    let mut rows = Vec::new();
    for threads in [1, rayon::current_num_threads()] {
        let reference = match &args.compare {
            Some(_) => Some(Reference::build(
                &args.embree_quality,
                &triangles,
                threads,
                args.repeat,
            )?),
            None => None,
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let any_hit = || std::hint::black_box(scene.occluded(&ours, &options));
        let closest = || std::hint::black_box(scene.intersect(&ours, &options));
        let (any_ms, closest_ms, kernels) = pool.install(|| match &reference {
            Some(r) => {
                let (a, mut k) =
                    time_in_turn(r, &tiled, Answers::Occluded(&occluded), args.repeat, || {
                        drop(any_hit())
                    });
                let answers = Answers::Triangles(&triangles_hit);
                let (c, camera) = time_in_turn(r, &tiled, answers, args.repeat, || drop(closest()));
                k.extend(camera);
                (a, c, k)
            }
            None => (
                best_of(args.repeat, any_hit),
                best_of(args.repeat, closest),
                Vec::new(),
            ),
        });
        rows.push(RayFileRow {
            triangles_file: triangles_file.display().to_string(),
            rays_file: rays_file.display().to_string(),
            triangles: triangles.len(),
            rays: tiled.len(),
            threads,
            build_ms,
            occluded: occluded.iter().filter(|o| **o).count() as f64 / tiled.len().max(1) as f64,
            any_hit_mrays: mrays(tiled.len(), any_ms),
            closest_hit_mrays: mrays(tiled.len(), closest_ms),
            embree_build_ms: reference.map(|r| r.build_ms),
            embree_kernels: kernels,
        });
    }
    if args.json {
        return print_json(&rows);
    }
    print_table(&rows);
    Ok(())
}

/// A checked file ray as the public query API takes it.
fn public_ray(r: &Ray) -> antumbra_rays::Ray {
    let f64s = |v: glam::Vec3| v.as_dvec3().to_array();
    antumbra_rays::Ray::segment(f64s(r.origin), f64s(r.direction), r.t_min, r.t_max)
}

fn print_table(rows: &[RayFileRow]) {
    let Some(first) = rows.first() else { return };
    println!(
        "{} on {}: {} rays, {} triangles, {:.1}% occluded",
        first.rays_file,
        first.triangles_file,
        first.rays,
        first.triangles,
        first.occluded * 100.0
    );
    println!(
        "{:>3} {:>9} {:>12} {:>12} {:>9}",
        "thr", "build ms", "any Mr/s", "closest Mr/s", "E build"
    );
    for r in rows {
        let embree = r
            .embree_build_ms
            .map_or("-".into(), |ms| format!("{ms:.1}"));
        println!(
            "{:>3} {:>9.1} {:>12.2} {:>12.2} {:>9}",
            r.threads, r.build_ms, r.any_hit_mrays, r.closest_hit_mrays, embree
        );
    }
    println!("antumbra: antumbra-rays' Scene (SAH, 8 wide), every ray in one call of occluded (any hit) and intersect (closest hit), segments [tnear, tfar] as Embree's");
    if rows.iter().any(|r| !r.embree_kernels.is_empty()) {
        println!();
        let name = Path::new(&first.rays_file)
            .file_name()
            .map_or(first.rays_file.clone(), |n| n.to_string_lossy().into());
        print_kernel_table(
            rows.iter()
                .map(|r| (name.clone(), r.threads, r.embree_kernels.as_slice())),
        );
    }
}
